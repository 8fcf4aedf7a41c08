"""Tests of geometry.statistics against the paper's Table 1 and docs/theory.md §2."""

import math

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.generate import builtin_surface, gaussian_surface
from roughfriction.geometry.statistics import (
    MAX_SEAM_RATIO,
    SMALL_STRAIN_MAX_SLOPE,
    SurfaceStatistics,
    bandwidth_parameter,
    periodic_seam_ratio,
    periodic_seam_warning,
    plasticity_index,
    rms_height,
    small_strain_slope,
    spectral_moments,
    summit_height_std,
    summit_radius,
    surface_statistics,
)
from roughfriction.geometry.surface import Surface, windows
from roughfriction.material import Material

PAPER = Material()
H = 1e-6  # the paper's grid spacing: 128 points over 127 um
# Table 1 of the paper: name -> (sigma [m], psi [-])
TABLE_1 = {
    "G1": (0.01e-6, 1.32),
    "G2": (0.025e-6, 3.33),
    "G3": (0.05e-6, 6.62),
    "G4": (0.075e-6, 10.04),
    "G5": (0.1e-6, 13.20),
    "G6": (0.125e-6, 16.59),
    "G7": (0.15e-6, 19.76),
    "G8": (0.175e-6, 23.11),
    "G9": (0.2e-6, 26.17),
}


def test_rms_height_removes_the_mean():
    assert rms_height([[1.0, 3.0], [1.0, 3.0]]) == pytest.approx(1.0)
    with pytest.raises(InputError, match="finite"):
        rms_height([[1.0, np.nan]])


def test_moments_are_forward_differences_along_x_averaged_over_profiles():
    z = np.random.default_rng(3).normal(size=(6, 5))
    z_centred = z - z.mean()
    h = 2e-6
    first = [(z[i + 1, j] - z[i, j]) / h for i in range(5) for j in range(5)]
    second = [(z[i + 2, j] - 2 * z[i + 1, j] + z[i, j]) / h**2 for i in range(4) for j in range(5)]
    m0, m2, m4 = spectral_moments(z, h)
    assert m0 == pytest.approx(np.mean(z_centred**2), rel=1e-12)
    assert m2 == pytest.approx(np.mean(np.square(first)), rel=1e-12)
    assert m4 == pytest.approx(np.mean(np.square(second)), rel=1e-12)
    # MATLAB diff(Z, 1, 2) on Z = heights.' (rows = y) is the same scheme
    assert spectral_moments(z.T, h, axis=1) == pytest.approx((m0, m2, m4), rel=1e-12)


def test_moments_of_a_surface_varying_only_along_y_vanish_along_x():
    y = np.arange(8) * H
    z = np.tile(np.sin(2 * np.pi * y / (8 * H)), (8, 1)) * 1e-7  # z[i, j] depends on y_j only
    _, m2_x, _ = spectral_moments(z, H)
    _, m2_y, _ = spectral_moments(z, H, axis=1)
    assert m2_x == 0.0 and m2_y > 0


@pytest.mark.parametrize(
    ("heights", "spacing", "message"),
    [(np.zeros((2, 8)), H, "3 x 3"), (np.zeros(8), H, "2-D"), (np.zeros((4, 4)), 0.0, "spacing")],
)
def test_moment_input_errors(heights, spacing, message):
    with pytest.raises(InputError, match=message):
        spectral_moments(heights, spacing)


def test_closed_form_for_iid_heights_is_132_44_sigma_over_h():
    sigma = 0.1e-6
    m0, m2, m4 = sigma**2, 2 * sigma**2 / H**2, 6 * sigma**2 / H**4  # iid forward differences
    alpha = bandwidth_parameter(m0, m2, m4)
    assert alpha == pytest.approx(1.5, rel=1e-14)
    psi = plasticity_index(summit_height_std(m0, alpha), summit_radius(m4), PAPER)
    assert psi == pytest.approx(132.44 * sigma / H, rel=5e-5)


def test_plasticity_index_prefactor_for_the_paper_material():
    # 2 E' / (pi C S_y), theory.md §2
    assert plasticity_index(1.0, 1.0, PAPER) == pytest.approx(86.638, rel=1e-5)


def test_eq12_refuses_narrow_band_and_flat_inputs():
    with pytest.raises(InputError, match="0.8968"):
        summit_height_std(1e-14, 0.8968)
    with pytest.raises(InputError, match="flat"):
        bandwidth_parameter(1e-14, 0.0, 1.0)
    with pytest.raises(InputError, match="flat"):
        summit_radius(0.0)


@pytest.mark.parametrize(("name", "sigma", "psi_table"), [(k, *v) for k, v in TABLE_1.items()])
def test_table_1_mean_psi_over_seeds(name, sigma, psi_table):
    psi = [surface_statistics(gaussian_surface(sigma, seed=s), PAPER).psi for s in range(10)]
    assert np.mean(psi) == pytest.approx(psi_table, rel=0.02)
    assert np.mean(psi) == pytest.approx(132.44 * sigma / H, rel=0.01)  # 10 draws: sd ~0.2 %


def test_seeded_g5_field_psi_within_spec_band():
    stats = surface_statistics(gaussian_surface(0.1e-6, seed=0), PAPER)
    assert abs(stats.psi - 13.24) <= 0.25
    assert stats.alpha == pytest.approx(1.5, abs=0.03)


@pytest.mark.parametrize(("name", "sigma", "psi_table"), [(k, *v) for k, v in TABLE_1.items()])
def test_builtin_g_surfaces_match_table_1(name, sigma, psi_table):
    stats = surface_statistics(builtin_surface(name), PAPER)
    assert stats.psi == pytest.approx(psi_table, rel=0.0025)  # seeds were chosen for 0.25 %
    assert stats.rq == pytest.approx(sigma, rel=0.03)


def test_surface_statistics_fields_are_consistent_si_values():
    surface = gaussian_surface(0.05e-6, seed=2)
    stats = surface_statistics(surface, PAPER)
    assert isinstance(stats, SurfaceStatistics)
    values = stats.as_dict()
    assert list(values) == ["rq", "m0", "m2", "m4", "alpha", "sigma_s", "R", "psi"]
    assert values["rq"] == pytest.approx(math.sqrt(values["m0"]), rel=1e-12)
    assert values["R"] == pytest.approx(0.375 * math.sqrt(math.pi / values["m4"]), rel=1e-12)
    assert 1e-8 < values["sigma_s"] < values["rq"]


@pytest.mark.parametrize("offset", [0.0, 5e-6])
def test_zero_roughness_is_refused(offset):
    with pytest.raises(InputError, match="zero roughness"):
        surface_statistics(Surface(np.full((8, 8), offset), H, "flat"), PAPER)


# --- periodic seam and small-strain slope -------------------------------------------------------


def test_seam_ratio_of_a_ramp_is_its_rise_over_one_step():
    n = 12
    ramp = np.indices((n, n), dtype=float)[0] * 1e-8  # rises along x only
    # seam: n jumps of (n - 1) steps along x and n zero jumps along y; inside: n (n - 1) steps
    # of 1 along x and as many zeros along y
    assert periodic_seam_ratio(ramp) == pytest.approx(n - 1, rel=1e-12)


def test_seam_ratio_of_iid_heights_is_an_ordinary_step():
    for window in windows(builtin_surface("G5"), 16):
        assert periodic_seam_ratio(window.heights) < MAX_SEAM_RATIO / 2


def test_seam_ratio_refuses_flat_and_tiny_grids():
    with pytest.raises(InputError, match="flat"):
        periodic_seam_ratio(np.ones((4, 4)))
    with pytest.raises(InputError, match="2 x 2"):
        periodic_seam_ratio(np.ones((1, 4)))


def test_seam_warning_names_the_jump_and_the_step_only_when_large():
    n = 8
    ramp = Surface(np.indices((n, n), dtype=float)[0] * 1e-8, H, "ramp")
    warning = periodic_seam_warning(ramp)
    assert warning is not None and "\n" not in warning
    assert f"{periodic_seam_ratio(ramp.heights):.2g} x" in warning and "ramp" in warning
    assert periodic_seam_warning(windows(builtin_surface("G5"), 16)[0]) is None


@pytest.mark.parametrize("factor", [0.5, 2.0])
def test_small_strain_slope_warns_above_its_limit_only(factor):
    slope = factor * SMALL_STRAIN_MAX_SLOPE
    i, j = np.indices((8, 8), dtype=float)
    plane = Surface(slope * H * (0.6 * i + 0.8 * j), H, "tilted")  # |grad z| = slope
    value, warning = small_strain_slope(plane)
    assert value == pytest.approx(slope, rel=1e-12)
    assert (warning is not None) == (factor > 1)
    if warning:
        assert f"{slope:.2g}" in warning and f"{SMALL_STRAIN_MAX_SLOPE:g}" in warning
