"""Scale decomposition (Eq. 35* of theory.md §3; checks of theory.md §9)."""

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.surface import Surface
from roughfriction.multiscale.scales import Scales, scale_decomposition, shell_variances

N = 128
SPACING = 1e-6  # [m]: 128 points over the paper's 127 um scan
AMPLITUDE = 0.1e-6  # [m]
X = np.arange(N) * SPACING  # [m]
PERIOD = N * SPACING  # [m]: the FFT period, on which a sampled harmonic is exact


def harmonic(i):
    """cos(2π i x / (N h)) on the grid [-]."""
    return np.cos(2.0 * np.pi * i * X / PERIOD)


@pytest.mark.parametrize("i", [1, 5])
def test_product_sinusoid_gives_back_its_amplitude_on_its_own_scale(i):
    heights = AMPLITUDE * np.outer(harmonic(i), harmonic(i))
    scales = scale_decomposition(Surface(heights, SPACING))
    assert abs(scales.amplitude[i - 1] / AMPLITUDE - 1.0) < 1e-14
    assert np.delete(scales.amplitude, i - 1).max() < 1e-14 * AMPLITUDE


@pytest.mark.parametrize("i", [1, 5])
def test_one_dimensional_cosine_reads_root_two_times_its_amplitude(i):
    heights = AMPLITUDE * np.outer(harmonic(i), np.ones(N))
    scales = scale_decomposition(Surface(heights, SPACING))
    assert scales.amplitude[i - 1] == pytest.approx(np.sqrt(2.0) * AMPLITUDE, rel=1e-14)


def test_shells_partition_the_variance_parseval():
    offset = 5e-6  # [m]
    heights = np.random.default_rng(3).normal(0.0, AMPLITUDE, (N, N)) + offset
    variances = shell_variances(heights)
    assert variances.shape == (N // 2 + 1,)
    assert np.sqrt(variances[0]) < 1e-15 * offset  # the mean is removed (to round-off)
    m0 = np.mean((heights - heights.mean()) ** 2)
    assert variances.sum() == pytest.approx(m0, rel=1e-13)
    scales = scale_decomposition(Surface(heights, SPACING))  # Nyquist shell excluded
    assert scales.variance.sum() + variances[-1] == pytest.approx(m0, rel=1e-13)


def test_white_noise_shell_variance_grows_with_the_shell_mode_count():
    # Shell i holds 8i modes, each of mean power sigma^2/N^2: E[V_i] = 8 i sigma^2 / N^2, i.e.
    # E[Delta_i^2] = 32 sigma^2 i / N^2 (theory.md §9). Averaged over 20 fields, the coarse and fine
    # halves each carry a standard error below 0.6 %.
    sigma = AMPLITUDE
    rng = np.random.default_rng(11)
    fields = [Surface(rng.normal(0.0, sigma, (N, N)), SPACING) for _ in range(20)]
    mean_square = np.mean([scale_decomposition(f).amplitude ** 2 for f in fields], axis=0)
    expected = 32.0 * sigma**2 * np.arange(1, N // 2) / N**2
    half = len(expected) // 2
    assert mean_square[:half].sum() / expected[:half].sum() == pytest.approx(1.0, abs=0.03)
    assert mean_square[half:].sum() / expected[half:].sum() == pytest.approx(1.0, abs=0.03)


def test_wavelengths_follow_the_scan_length_by_default():
    surface = Surface(np.random.default_rng(0).normal(0.0, AMPLITUDE, (N, N)), SPACING)
    scales = scale_decomposition(surface)
    length = (N - 1) * SPACING
    assert scales.length == length
    assert len(scales.wavelength) == N // 2 - 1
    i = np.arange(1, N // 2)
    np.testing.assert_allclose(scales.wavelength, length / i, rtol=1e-15)
    np.testing.assert_allclose(scales.frequency, i / length, rtol=1e-15)
    np.testing.assert_allclose(scales.amplitude, 2.0 * np.sqrt(scales.variance), rtol=1e-15)


def test_length_and_scale_count_are_options():
    surface = Surface(np.random.default_rng(0).normal(0.0, AMPLITUDE, (N, N)), SPACING)
    default = scale_decomposition(surface)
    scales = scale_decomposition(surface, length=PERIOD, i_max=10)
    assert len(scales.amplitude) == 10
    assert scales.wavelength[0] == PERIOD
    np.testing.assert_array_equal(scales.amplitude, default.amplitude[:10])
    with_nyquist = scale_decomposition(surface, i_max=N // 2)
    assert len(with_nyquist.amplitude) == N // 2


def test_scales_are_read_only():
    surface = Surface(np.random.default_rng(0).normal(0.0, AMPLITUDE, (8, 8)), SPACING)
    scales = scale_decomposition(surface)
    assert isinstance(scales, Scales)
    with pytest.raises(ValueError):
        scales.amplitude[0] = 1.0


@pytest.mark.parametrize(
    "options", [{"i_max": 0}, {"i_max": N // 2 + 1}, {"length": 0.0}, {"length": np.nan}]
)
def test_bad_options_raise_input_error(options):
    surface = Surface(np.random.default_rng(0).normal(0.0, AMPLITUDE, (N, N)), SPACING)
    with pytest.raises(InputError):
        scale_decomposition(surface, **options)


def test_flat_surface_raises_input_error():
    with pytest.raises(InputError, match="zero roughness"):
        scale_decomposition(Surface(np.full((16, 16), 3e-6), SPACING))


def test_non_square_heights_raise_input_error():
    with pytest.raises(InputError):
        shell_variances(np.zeros((4, 6)))
