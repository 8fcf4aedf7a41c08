"""Tests of geometry.generate: seeded Gaussian and self-affine surfaces, built-in table."""

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.generate import (
    BUILTIN_SURFACES,
    builtin_names,
    builtin_surface,
    gaussian_surface,
    self_affine_surface,
)
from roughfriction.geometry.statistics import rms_height
from roughfriction.multiscale.scales import scale_decomposition


def rms_gradient(surface):
    """sqrt(<(dz/dx)^2> + <(dz/dy)^2>) [-] with forward differences."""
    z = surface.heights / surface.spacing
    return np.sqrt(np.mean(np.diff(z, axis=0) ** 2) + np.mean(np.diff(z, axis=1) ** 2))


def radial_psd_slope(heights, spacing, q_band):
    """Least-squares slope of log C(q) against log q over q_band = (q_min, q_max) [rad/m]."""
    n = heights.shape[0]
    power = np.abs(np.fft.fft2(heights)) ** 2
    wavenumbers = 2 * np.pi * np.fft.fftfreq(n, d=spacing)
    q = np.hypot(*np.meshgrid(wavenumbers, wavenumbers, indexing="ij"))
    in_band = (q >= q_band[0]) & (q <= q_band[1])
    return np.polyfit(np.log(q[in_band]), np.log(power[in_band]), 1)[0]


# --- Gaussian -----------------------------------------------------------------------------------


def test_gaussian_surface_is_reproducible_by_seed_and_differs_across_seeds():
    a = gaussian_surface(0.1e-6, n=32, seed=7, name="a")
    np.testing.assert_array_equal(a.heights, gaussian_surface(0.1e-6, n=32, seed=7).heights)
    assert not np.allclose(a.heights, gaussian_surface(0.1e-6, n=32, seed=8).heights)
    assert a.name == "a" and a.n == 32 and a.spacing == 1e-6


def test_gaussian_surface_has_zero_mean_and_is_not_rescaled():
    surface = gaussian_surface(0.1e-6, seed=3)
    assert abs(surface.heights.mean()) < 1e-22
    rq = rms_height(surface.heights)
    assert rq == pytest.approx(0.1e-6, rel=0.03)  # 16384 samples: sd of Rq ~0.55 %
    assert rq != pytest.approx(0.1e-6, rel=1e-9)  # nominal sigma, not rescaled


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"rms": 0.0}, "zero roughness"),
        ({"rms": -1e-7}, "> 0"),
        ({"rms": 1e-7, "n": 2}, "integer >= 4"),
        ({"rms": 1e-7, "spacing": 0.0}, "spacing"),
    ],
)
def test_gaussian_surface_argument_errors(kwargs, message):
    with pytest.raises(InputError, match=message):
        gaussian_surface(**kwargs)


# --- self-affine --------------------------------------------------------------------------------


def test_self_affine_surface_is_reproducible_real_and_exactly_rescaled():
    a = self_affine_surface(0.204e-6, 0.8, seed=2)
    np.testing.assert_array_equal(a.heights, self_affine_surface(0.204e-6, 0.8, seed=2).heights)
    assert not np.allclose(a.heights, self_affine_surface(0.204e-6, 0.8, seed=3).heights)
    assert rms_height(a.heights) == pytest.approx(0.204e-6, rel=1e-12)
    assert abs(a.heights.mean()) < 1e-22


@pytest.mark.parametrize("hurst", [0.5, 0.8])
def test_self_affine_psd_slope_recovers_the_hurst_exponent(hurst):
    n, spacing = 256, 1e-6
    q_min = 2 * np.pi / (n * spacing)
    slopes = [
        radial_psd_slope(
            self_affine_surface(1e-7, hurst, n=n, spacing=spacing, seed=seed).heights,
            spacing,
            (2 * q_min, 64 * q_min),
        )
        for seed in range(4)
    ]
    assert -np.mean(slopes) / 2 - 1 == pytest.approx(hurst, abs=0.1)


def test_self_affine_cutoffs_shape_the_spectrum():
    n, spacing = 128, 1e-6
    surface = self_affine_surface(
        1e-7, 0.8, n=n, spacing=spacing, seed=1, long_cutoff=32e-6, short_cutoff=8e-6
    )
    power = np.abs(np.fft.fft2(surface.heights)) ** 2
    wavenumbers = 2 * np.pi * np.fft.fftfreq(n, d=spacing)
    q = np.hypot(*np.meshgrid(wavenumbers, wavenumbers, indexing="ij"))
    assert np.max(power[q > 2 * np.pi / 8e-6]) < 1e-20 * np.max(power)  # nothing above q_short
    # flat roll-off: below q_long the PSD slope is ~0, not -2(1 + H) = -3.6
    q_min = 2 * np.pi / (n * spacing)
    assert abs(radial_psd_slope(surface.heights, spacing, (q_min, 2 * np.pi / 32e-6))) < 1.5


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"hurst": 0.0}, "Hurst"),
        ({"hurst": 1.2}, "Hurst"),
        ({"hurst": 0.8, "short_cutoff": 200e-6}, "no Fourier mode"),
        ({"hurst": 0.8, "short_cutoff": 0.0}, "short cut-off"),
        ({"hurst": 0.8, "long_cutoff": 4e-6, "short_cutoff": 8e-6}, "must exceed"),
        ({"hurst": 0.8, "rms": 0.0}, "zero roughness"),
        ({"hurst": 0.8, "spacing": -1.0}, "spacing"),
    ],
)
def test_self_affine_argument_errors(kwargs, message):
    arguments = {"rms": 1e-7, **kwargs}
    with pytest.raises(InputError, match=message):
        self_affine_surface(**arguments)


# --- built-in surfaces --------------------------------------------------------------------------


def test_builtin_names_in_table_order():
    assert builtin_names() == [f"G{k}" for k in range(1, 10)] + ["2L", "8L", "63M", "G5-512"]
    assert list(BUILTIN_SURFACES) == builtin_names()


def test_the_large_benchmark_surface_has_g5s_statistics_on_512_points():
    large, g5 = builtin_surface("G5-512"), builtin_surface("G5")
    assert large.n == 512 and large.spacing == g5.spacing
    assert large.heights.std() == pytest.approx(g5.heights.std(), rel=0.02)


@pytest.mark.parametrize("name", ["G1", "G5", "G9", "2L", "8L", "63M"])
def test_builtin_surfaces_are_paper_grids_and_reproducible(name):
    surface = builtin_surface(name)
    assert surface.n == 128 and surface.spacing == 1e-6 and surface.name == name
    assert surface.scan_length == pytest.approx(127e-6)
    np.testing.assert_array_equal(surface.heights, builtin_surface(name).heights)


def test_builtin_g_surfaces_are_independent_realisations():
    seeds = [BUILTIN_SURFACES[f"G{k}"].seed for k in range(1, 10)]
    assert len(set(seeds)) == 9


@pytest.mark.parametrize(("name", "rq"), [("2L", 0.204e-6), ("8L", 0.254e-6), ("63M", 2.0e-6)])
def test_stand_ins_have_the_documented_rq(name, rq):
    assert rms_height(builtin_surface(name).heights) == pytest.approx(rq, rel=1e-12)
    assert "stand-in" in BUILTIN_SURFACES[name].description


def test_2l_stand_in_is_gentle_enough_to_mesh():
    assert rms_gradient(builtin_surface("2L")) < 0.1  # 0.088 for seed 2, Hurst 0.3


@pytest.mark.parametrize("name", ["2L", "8L"])
def test_stand_in_amplitude_over_wavelength_falls_with_wavelength(name):
    """The paper's Fig. 13 trend: Delta_i / lambda_i decreases as lambda_i increases."""
    scales = scale_decomposition(builtin_surface(name))
    ratio = scales.amplitude / scales.wavelength
    slope = np.polyfit(np.log(scales.wavelength), np.log(ratio), 1)[0]
    assert slope < -0.1  # shells: Delta ~ lambda^(H + 1/2), so the slope is H - 1/2 = -0.2


def test_unknown_builtin_lists_the_names():
    with pytest.raises(InputError, match="G1, G2.*2L, 8L, 63M"):
        builtin_surface("G10")
