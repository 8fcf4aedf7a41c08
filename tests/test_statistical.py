"""CKE (Eq. 8) and LET (Eq. 20) statistical friction models (theory.md §7; hand values §9)."""

import math

import pytest
from roughfriction.errors import InputError
from roughfriction.multiscale.statistical import cke_friction, let_friction


@pytest.mark.parametrize("psi, expected", [(1.32, 0.6768), (3.33, 0.4339), (6.62, 0.3418)])
def test_cke_hand_values(psi, expected):
    result = cke_friction(psi, 0.155)
    assert result.mu_s == pytest.approx(expected, abs=5e-5)
    assert result.valid and result.reason == ""


@pytest.mark.parametrize(
    "psi, expected",
    [(1.32, 0.5742), (3.33, 0.3675), (6.62, 0.2818), (10.04, 0.2657), (13.20, 0.2626),
     (26.17, 0.2604)],
)
def test_let_hand_values(psi, expected):
    result = let_friction(psi, 0.155)
    assert result.mu_s == pytest.approx(expected, abs=5e-5)
    assert result.valid and result.reason == ""


def test_let_at_a_lighter_load():
    assert let_friction(13.20, 0.05).mu_s == pytest.approx(0.2640, abs=5e-5)


def test_cke_is_the_dimensionless_friction_force_over_the_load():
    psi, load_star = 4.0, 0.2
    friction_force = (0.26 + 0.43 / psi) * load_star ** (0.0095 * psi + 0.91)  # Eq. 7
    assert cke_friction(psi, load_star).mu_s == pytest.approx(friction_force / load_star, rel=1e-14)


def test_cke_range_limits():
    assert cke_friction(8.0, 0.3).valid
    outside = cke_friction(13.20, 0.155)
    assert not outside.valid
    assert outside.reason == "CKE (Eq. 8) is outside its published range: psi = 13.2 > 8"
    assert outside.mu_s == pytest.approx((0.26 + 0.43 / 13.2) * 0.155 ** (0.0095 * 13.2 - 0.09))
    assert not cke_friction(5.0, 0.31).valid


def test_let_range_limits():
    assert let_friction(32.0, 0.3).valid
    assert not let_friction(32.5, 0.155).valid
    outside = let_friction(13.20, 0.62)  # paper Sect. 5.3.1: outside its applicable range
    assert not outside.valid
    assert outside.reason == "LET (Eq. 20) is outside its published range: F* = 0.62 > 0.3"
    assert 0.2 < outside.mu_s < 0.3
    both = let_friction(40.0, 1.0)
    assert "psi = 40 > 32" in both.reason and "F* = 1 > 0.3" in both.reason


@pytest.mark.parametrize("model", [cke_friction, let_friction])
@pytest.mark.parametrize("psi, load_star", [(0.0, 0.155), (-1.0, 0.155), (math.nan, 0.155),
                                            (5.0, 0.0), (5.0, -0.1), (5.0, math.inf)])
def test_bad_inputs_raise_input_error(model, psi, load_star):
    with pytest.raises(InputError):
        model(psi, load_star)
