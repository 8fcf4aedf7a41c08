"""The certificate of a ladder's finest value (``studies.certificate``)."""

import math

import numpy as np
import pytest
from roughfriction.solver.results import count_boundary_nodes
from roughfriction.studies.certificate import LADDER_FACTOR, Certificate, certify


def test_boundary_nodes_are_contact_nodes_beside_a_free_node_on_the_periodic_grid():
    contact = np.zeros((8, 8), dtype=bool)
    contact[2:5, 2:5] = True  # a 3 x 3 patch: all but its centre are on the boundary
    assert count_boundary_nodes(contact) == 8
    contact[:, 7] = contact[:, 0] = True  # a band two columns wide across the seam
    assert count_boundary_nodes(contact) == 8 + 16
    assert count_boundary_nodes(np.ones((4, 4), dtype=bool)) == 0  # complete contact: no edge


def test_the_certificate_adds_its_two_terms_in_quadrature():
    one = certify((0.30, 0.20), contact_nodes=400, boundary=100, ladder_factor=0.15,
                  boundary_factor=0.2)
    assert one.ladder_term == pytest.approx(0.015)
    assert one.resolution_term == pytest.approx(0.2 * 0.20 * 10 / 400)
    assert one.error == pytest.approx(math.hypot(0.015, 0.001))
    assert one.relative_error == pytest.approx(one.error / 0.20)
    assert one.values == (0.30, 0.20) and one.contact_nodes == 400


def test_levels_that_agree_by_chance_keep_the_resolution_term():
    chance = certify((0.2001, 0.2), contact_nodes=54, boundary=40)
    assert chance.error > 0.1 * chance.ladder_term + chance.resolution_term * 0.99
    assert chance.resolution_term > 10 * chance.ladder_term


def test_a_certificate_needs_two_levels_and_contact():
    with pytest.raises(ValueError, match="2 levels"):
        certify((0.2,), 10, 5)
    assert math.isinf(certify((0.3, 0.2), 0, 0).error)
    assert isinstance(certify((0.3, 0.2, 0.21), 10, 5), Certificate)
    assert certify((0.3, 0.2, 0.21), 10, 5).ladder_term == pytest.approx(LADDER_FACTOR * 0.01)
