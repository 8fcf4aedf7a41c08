"""The contact law at points (solver.contact_law): pressure and shear traction, and their
tangents against finite differences."""

import numpy as np
import pytest
from roughfriction.solver.contact_law import ContactLaw

TAU_C = 577e6  # [Pa]
RAMP = 10e6  # [Pa]
LAW = ContactLaw(penalty=1e18, tangential_penalty=1e17, shear_strength=TAU_C, ramp_pressure=RAMP)
POINTS = 400


def away_from_kinks(rng) -> tuple[np.ndarray, np.ndarray]:
    """Slips s [m] (POINTS, 2) and pressures p [Pa] (POINTS,) whose trial traction is not
    within 10 % of its cap and whose pressure is not within 10 % of 0 or p_r: the law is smooth
    there."""
    pressure = RAMP * rng.uniform(0.1, 2.0, POINTS)
    pressure[np.abs(pressure / RAMP - 1.0) < 0.1] *= 1.3
    cap = LAW.shear_cap(pressure)
    angle = rng.uniform(0.0, 2.0 * np.pi, POINTS)
    ratio = rng.choice([0.3, 0.6, 1.5, 3.0], POINTS) * rng.uniform(0.95, 1.05, POINTS)
    slip = (ratio * cap / LAW.tangential_penalty)[:, None] * np.column_stack(
        [np.cos(angle), np.sin(angle)])
    return slip, pressure


def traction(slip, pressure):
    everywhere = np.ones(len(pressure), dtype=bool)
    return LAW.friction(slip, pressure, everywhere, everywhere)


def test_the_traction_tangents_match_central_differences():
    """dt/ds and dt/dp of sticking and slipping points (on and above the cap's ramp) are the
    central differences of t(s, p) to 1e-6."""
    slip, pressure = away_from_kinks(np.random.default_rng(5))
    everywhere = np.ones(POINTS, dtype=bool)
    state = traction(slip, pressure)
    assert 0 < np.count_nonzero(state.slipping) < POINTS
    assert np.any(state.slipping & (pressure < RAMP)) and np.any(state.slipping & (pressure > RAMP))
    tangent = LAW.slip_tangent(state, everywhere)
    for k in range(2):
        step = np.zeros_like(slip)
        step[:, k] = 1e-6 * np.linalg.norm(slip, axis=1)
        difference = (traction(slip + step, pressure).traction
                      - traction(slip - step, pressure).traction) / (2 * step[:, k:k + 1])
        np.testing.assert_allclose(tangent[:, :, k], difference, rtol=1e-6,
                                   atol=1e-6 * LAW.tangential_penalty)
    step = 1e-6 * pressure
    difference = (traction(slip, pressure + step).traction
                  - traction(slip, pressure - step).traction) / (2 * step[:, None])
    np.testing.assert_allclose(LAW.pressure_coupling(state, pressure), difference, rtol=1e-6,
                               atol=1e-9 * TAU_C / RAMP)


def test_points_without_shear_carry_none_and_have_no_tangent():
    """Points that are not frictional carry no traction, whatever their slip, and no
    tangent; points that are not capped stick beyond the cap (a predictor)."""
    slip, pressure = away_from_kinks(np.random.default_rng(6))
    frictional = np.arange(POINTS) % 2 == 0
    uncapped = np.zeros(POINTS, dtype=bool)
    state = LAW.friction(slip, pressure, frictional, uncapped)
    np.testing.assert_array_equal(state.traction[~frictional], 0.0)
    np.testing.assert_array_equal(LAW.slip_tangent(state, frictional)[~frictional], 0.0)
    assert not np.any(state.slipping)
    np.testing.assert_allclose(state.traction[frictional],
                               LAW.tangential_penalty * slip[frictional], rtol=1e-15)


def test_a_slipping_point_carries_its_cap():
    slip, pressure = away_from_kinks(np.random.default_rng(7))
    state = traction(slip, pressure)
    cap = np.minimum(1.0, pressure / RAMP) * TAU_C
    norm = np.linalg.norm(state.traction, axis=1)
    np.testing.assert_allclose(norm[state.slipping], cap[state.slipping], rtol=1e-12)
    assert np.all(norm[~state.slipping] < cap[~state.slipping])


@pytest.mark.parametrize("frozen", [False, True])
def test_the_pressure_and_its_stiffness_match_central_differences(frozen):
    """p(g) = <lambda - eps_N g> and -dp/dg = eps_N on the active set; a frozen point stays
    active (and pulls) where lambda - eps_N g < 0."""
    rng = np.random.default_rng(8)
    multiplier = rng.uniform(0.0, 1e8, POINTS)
    gap = rng.uniform(-1e-10, 2e-10, POINTS)
    gap[np.abs(multiplier - LAW.penalty * gap) < 1e6] += 1e-11  # away from the kink
    frozen_set = np.arange(POINTS) % 3 == 0 if frozen else None
    pressure, active = LAW.pressure(multiplier, gap, frozen_set)
    step = 1e-18
    difference = (LAW.pressure(multiplier, gap + step, frozen_set)[0]
                  - LAW.pressure(multiplier, gap - step, frozen_set)[0]) / (2 * step)
    np.testing.assert_allclose(-LAW.pressure_stiffness(active), difference, rtol=1e-6)
    assert np.any(~active) and np.all(pressure[~active] == 0.0)
    if frozen:
        assert np.all(active[frozen_set]) and np.any(pressure[frozen_set] < 0.0)
    else:
        assert np.all(pressure >= 0.0)


def test_the_shear_cap_rises_with_pressure_up_to_tau_c():
    cap = LAW.shear_cap(np.array([-1e6, 0.0, 2.5e6, RAMP, 1e9]))
    np.testing.assert_allclose(cap, [0.0, 0.0, 0.25 * TAU_C, TAU_C, TAU_C])
    pure = ContactLaw(1e18, 1e17, TAU_C, ramp_pressure=0.0)
    assert pure.shear_cap(np.array([1.0]))[0] == TAU_C
    assert pure.cap_slope(np.array([1.0]), np.array([True]))[0] == 0.0
