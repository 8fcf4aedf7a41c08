"""Tests of geometry.surface: the Surface type and the operations on height arrays."""

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.surface import (
    Surface,
    bilinear_refine,
    bilinear_rms_height,
    crop_square,
    detrend_plane,
    fill_missing,
    resample,
    spectral_interpolate,
    validate_grid_points,
)


def rough(shape, seed=0):
    return np.random.default_rng(seed).normal(0.0, 1e-7, size=shape)


def tilted_plane(shape):
    i, j = np.indices(shape, dtype=float)
    return 3e-6 + 2e-8 * i - 5e-8 * j


# --- Surface validation -------------------------------------------------------------------------


def test_rms_slope_of_a_plane_is_its_gradient():
    """Forward differences of a plane are exact: the RMS slope is |grad z| [-]."""
    spacing = 2e-6
    i, j = np.indices((8, 8), dtype=float)
    surface = Surface(spacing * (0.3 * i - 0.4 * j), spacing)
    assert surface.rms_slope == pytest.approx(0.5)




@pytest.mark.parametrize(
    ("heights", "message"),
    [
        (np.zeros(16), "2-D"),
        (np.zeros((8, 6)), "not square"),
        (np.zeros((3, 3)), "too small"),
        (np.where(np.eye(8) > 0, np.nan, 0.0), "8 missing"),
        (np.where(np.eye(8) > 0, np.inf, 0.0), "missing"),
    ],
)
def test_surface_refuses_bad_grids_with_helpful_message(heights, message):
    with pytest.raises(InputError, match=message):
        Surface(heights, 1e-6, "bad")


@pytest.mark.parametrize("spacing", [0.0, -1e-6, np.nan])
def test_surface_refuses_non_positive_spacing(spacing):
    with pytest.raises(InputError, match="spacing"):
        Surface(np.zeros((8, 8)), spacing)


def test_surface_geometry_and_immutability():
    surface = Surface(rough((128, 128)), 1e-6, "s")
    assert surface.scan_length == pytest.approx(127e-6)
    assert surface.period == pytest.approx(128e-6)
    with pytest.raises(ValueError):
        surface.heights[0, 0] = 1.0


# --- detrend and fill ---------------------------------------------------------------------------


def test_detrend_removes_an_exact_plane():
    plane = tilted_plane((20, 30))
    assert np.max(np.abs(detrend_plane(plane))) < 1e-12 * np.max(np.abs(plane))


def test_detrend_removes_a_plane_added_to_roughness_and_keeps_nan():
    z = rough((20, 30))
    with_nan = z + tilted_plane(z.shape)
    with_nan[4, 7] = np.nan
    clean = z.copy()
    clean[4, 7] = np.nan
    got = detrend_plane(with_nan)
    assert np.isnan(got[4, 7])
    np.testing.assert_allclose(got, detrend_plane(clean), rtol=0, atol=1e-18, equal_nan=True)
    assert abs(np.nanmean(got)) < 1e-20


def test_detrend_needs_three_points():
    z = np.full((5, 5), np.nan)
    z[0, :2] = 1.0
    with pytest.raises(InputError, match="at least 3"):
        detrend_plane(z)


def test_fill_nearest_copies_the_nearest_measured_height():
    z = np.arange(25.0).reshape(5, 5)
    z[2, 2] = z[0, 4] = np.nan
    filled = fill_missing(z, "nearest")
    assert filled[2, 2] in (7.0, 11.0, 13.0, 17.0)  # one of the four nearest neighbours
    assert filled[0, 4] in (3.0, 9.0)
    mask = np.isfinite(z)
    np.testing.assert_array_equal(filled[mask], z[mask])


def test_fill_plane_uses_the_least_squares_plane():
    z = tilted_plane((6, 6))
    expected = z[1, 3]
    z[1, 3] = np.nan
    assert fill_missing(z, "plane")[1, 3] == pytest.approx(expected, rel=1e-12)


def test_fill_errors():
    with pytest.raises(InputError, match="unknown fill method 'cubic'"):
        fill_missing(np.zeros((4, 4)), "cubic")
    with pytest.raises(InputError, match="no height"):
        fill_missing(np.full((4, 4), np.nan), "nearest")
    with pytest.raises(InputError, match="2-D"):
        fill_missing(np.zeros(4), "nearest")


# --- crop and periodic closure ------------------------------------------------------------------


def test_crop_square_is_centred():
    z = np.arange(5 * 8).reshape(5, 8)
    cropped = crop_square(z)
    assert cropped.shape == (5, 5)
    np.testing.assert_array_equal(cropped, z[:, 1:6])
    np.testing.assert_array_equal(crop_square(z.T), z.T[1:6, :])


def test_resample_keeps_a_linear_ramp_exact_over_the_same_scan_length():
    surface = Surface(tilted_plane((16, 16)), 2e-6, "ramp")
    fine = resample(surface, 41)
    assert fine.n == 41 and fine.name == "ramp"
    assert fine.scan_length == pytest.approx(surface.scan_length, rel=1e-14)
    x = np.linspace(0.0, 15.0, 41)  # positions in old grid indices
    expected = 3e-6 + 2e-8 * x[:, None] - 5e-8 * x[None, :]
    np.testing.assert_allclose(fine.heights, expected, rtol=0, atol=1e-18)


def test_resample_onto_the_same_grid_returns_the_data():
    surface = Surface(rough((12, 12)), 1e-6)
    np.testing.assert_allclose(resample(surface, 12).heights, surface.heights, atol=1e-20)


# --- spectral interpolation ---------------------------------------------------------------------


@pytest.mark.parametrize(("n_old", "factor"), [(16, 2), (16, 3), (15, 2), (128, 4)])
def test_spectral_interpolation_is_exact_at_the_old_points(n_old, factor):
    surface = Surface(rough((n_old, n_old), seed=n_old), 1e-6)
    fine = spectral_interpolate(surface, factor * n_old)
    assert fine.spacing == pytest.approx(1e-6 / factor)
    np.testing.assert_allclose(fine.heights[::factor, ::factor], surface.heights, atol=1e-20)


@pytest.mark.parametrize(("n_old", "n_new"), [(16, 50), (15, 64), (32, 32)])
def test_spectral_interpolation_reproduces_a_band_limited_sinusoid(n_old, n_new):
    spacing = 1e-6
    period = n_old * spacing

    def field(x, y):
        z = 1e-7 * np.cos(2 * np.pi * 3 * x / period + 0.3) * np.sin(2 * np.pi * 5 * y / period)
        if n_old % 2 == 0:  # the Nyquist cosine, split symmetrically between +/- n/2
            z = z + 5e-8 * np.cos(np.pi * x / spacing)
        return z

    x_old = np.arange(n_old) * spacing
    surface = Surface(field(*np.meshgrid(x_old, x_old, indexing="ij")), spacing)
    fine = spectral_interpolate(surface, n_new)
    x_new = np.arange(n_new) * fine.spacing
    expected = field(*np.meshgrid(x_new, x_new, indexing="ij"))
    assert np.max(np.abs(fine.heights - expected)) < 1e-12 * 1e-7


def test_spectral_interpolation_refuses_to_coarsen():
    with pytest.raises(InputError, match="resample"):
        spectral_interpolate(Surface(rough((16, 16)), 1e-6), 8)


@pytest.mark.parametrize("n", [3, 10.0, True, "64"])
def test_grid_points_must_be_an_integer_of_at_least_four(n):
    with pytest.raises(InputError, match="integer >= 4"):
        validate_grid_points(n)


def test_the_bilinear_surface_s_rms_height_is_the_same_on_every_refinement_of_it():
    z = rough((8, 8), seed=4)
    rms = bilinear_rms_height(z)
    assert bilinear_rms_height(bilinear_refine(z, 3)) == pytest.approx(rms, rel=1e-12)
    assert np.std(bilinear_refine(z, 64)) == pytest.approx(rms, rel=1e-3)  # point samples
    assert rms < np.std(z)
    # a checkerboard of +-1: the interpolant (1 - 2x)(1 - 2y) in each cell, RMS 1/3
    checkerboard = np.where(np.add.outer(np.arange(4), np.arange(4)) % 2, 1.0, -1.0)
    assert bilinear_rms_height(checkerboard) == pytest.approx(1 / 3, rel=1e-12)
