"""Richardson error estimates and refined cases on the same bilinear surface."""

import numpy as np
import pytest
from roughfriction.case import FemCase, Loading
from roughfriction.geometry.surface import Surface
from roughfriction.studies.refinement import refined_case, richardson


def test_two_meshes_assume_first_order():
    estimate = richardson([1.2, 1.1])
    assert estimate.extrapolated == pytest.approx(1.0)
    assert estimate.error == pytest.approx(0.1)
    assert estimate.order == 1.0 and not estimate.observed


@pytest.mark.parametrize("order", [1.0, 2.0, 1.5])
def test_three_meshes_recover_the_order_of_a_power_law(order):
    exact, constant = 0.4, 0.3
    values = [exact + constant * h**order for h in (1.0, 0.5, 0.25)]
    estimate = richardson(values)
    assert estimate.observed and estimate.order == pytest.approx(order)
    assert estimate.extrapolated == pytest.approx(exact)
    assert estimate.error == pytest.approx(abs(values[-1] - exact))


def test_non_converging_ladder_keeps_the_assumed_order():
    estimate = richardson([1.0, 1.1, 1.0])  # differences change sign: no asymptotic range
    assert not estimate.observed and estimate.order == 1.0
    assert estimate.error == pytest.approx(0.1)


def test_refined_case_samples_the_same_bilinear_surface():
    heights = np.random.default_rng(3).normal(size=(8, 8)) * 1e-7
    case = FemCase(Surface(heights, 1e-6, "s"), Loading(0.1))
    fine = refined_case(case, 2)
    assert fine.surface.n == 16 and fine.surface.spacing == pytest.approx(0.5e-6)
    assert fine.nominal_area == pytest.approx(case.nominal_area)
    np.testing.assert_allclose(fine.surface.heights[::2, ::2], heights)
    np.testing.assert_allclose(fine.surface.heights[1, 1], heights[:2, :2].mean())
    assert refined_case(case, 1) is case


@pytest.mark.fem
def test_a_refined_case_deepens_the_blend_where_its_thinner_layers_would_distort():
    """A valley 1.25 h deep meshes with 2 blend layers of thickness h, but not with 2 of h/2:
    the refined case takes the 3 it needs, and meshes; a case already deep enough keeps its
    count."""
    from mpi4py import MPI
    from roughfriction.errors import InputError
    from roughfriction.solver.block import build_block

    spacing = 1e-6
    heights = np.zeros((8, 8))
    heights[3, 4] = -1.25 * spacing
    case = FemCase(Surface(heights, spacing, "valley"), Loading(0.1))
    fine = refined_case(case, 2)
    assert case.mesh.blend_layers == 2 and fine.mesh.blend_layers == 3
    build_block(case.surface.heights, spacing, case.mesh, MPI.COMM_SELF)
    build_block(fine.surface.heights, fine.surface.spacing, fine.mesh, MPI.COMM_SELF)
    with pytest.raises(InputError, match="needs >= 3 blend layers"):
        build_block(fine.surface.heights, fine.surface.spacing, case.mesh, MPI.COMM_SELF)
    shallow = FemCase(Surface(0.2 * heights, spacing, "valley"), Loading(0.1))
    assert refined_case(shallow, 2).mesh.blend_layers == 2
