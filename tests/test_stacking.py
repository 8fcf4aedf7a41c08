"""Normal contact of stacked scales (Eqs. 22–23; theory.md §5 and §9)."""

import math

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.surface import Surface
from roughfriction.material import Material
from roughfriction.multiscale.scales import Scales, scale_decomposition
from roughfriction.multiscale.sinusoid import complete_contact_pressure, contact_area_per_cell
from roughfriction.multiscale.stacking import normal_contact

MATERIAL = Material()
LENGTH = 127e-6  # [m]


def single_scale(amplitude, length=LENGTH):
    """The one-sinusoid 'surface' of theory.md §9: λ = L, Δ = amplitude [m]."""
    return Scales(
        wavelength=[length], frequency=[1.0 / length], amplitude=[amplitude],
        variance=[amplitude**2 / 4.0], length=length,
    )


def white_noise_scales(sigma, seed=5):
    """Scales of a 64 x 64 iid Gaussian field of standard deviation sigma [m], 1 um spacing."""
    heights = np.random.default_rng(seed).normal(0.0, sigma, (64, 64))
    return scale_decomposition(Surface(heights, 1e-6))


@pytest.mark.parametrize("ratio, expected", [(0.01, 0.03970), (0.1, 0.21103), (0.5, 0.68156)])
def test_single_sinusoid_area_is_the_per_cell_area(ratio, expected):
    amplitude = 0.1e-6
    p_star = complete_contact_pressure(amplitude, 1.0 / LENGTH, MATERIAL)
    contact = normal_contact(single_scale(amplitude), ratio * p_star / MATERIAL.Sy, MATERIAL)
    assert contact.area_ratio == pytest.approx(expected, abs=5e-6)
    assert contact.pressures[0] == pytest.approx(ratio * p_star, rel=1e-12)


@pytest.mark.parametrize("ratio", [1.0, 1.7])
def test_single_sinusoid_is_flattened_above_its_complete_contact_pressure(ratio):
    amplitude = 0.1e-6
    p_star = complete_contact_pressure(amplitude, 1.0 / LENGTH, MATERIAL)
    contact = normal_contact(single_scale(amplitude), ratio * p_star / MATERIAL.Sy, MATERIAL)
    assert contact.area_ratio == 1.0


def test_nominal_area_and_normal_load():
    contact = normal_contact(single_scale(0.1e-6), 0.155, MATERIAL)
    assert contact.nominal_area == LENGTH**2
    assert contact.normal_load == pytest.approx(0.155 * LENGTH**2 * MATERIAL.Sy, rel=1e-15)


def test_every_scale_carries_the_full_load_on_the_previous_area():
    scales = white_noise_scales(0.05e-6)
    contact = normal_contact(scales, 0.155, MATERIAL)
    previous = np.concatenate([[1.0], contact.area_ratios[:-1]]) * contact.nominal_area
    np.testing.assert_allclose(contact.pressures, contact.normal_load / previous, rtol=1e-14)
    cell_areas = contact_area_per_cell(contact.pressures, scales.amplitude, scales.wavelength,
                                       MATERIAL)
    factors = np.minimum(cell_areas * scales.frequency**2, 1.0)  # eta_i = f_i^2
    assert contact.area_ratio == pytest.approx(np.prod(factors), rel=1e-12)  # Eq. 22
    np.testing.assert_allclose(contact.area_ratios, np.cumprod(factors), rtol=1e-12)
    assert np.all(np.diff(contact.area_ratios) <= 0)  # assumption (d)
    assert contact.area_ratio == contact.area_ratios[-1]


def test_area_grows_with_load():
    scales = white_noise_scales(0.05e-6)
    ratios = [normal_contact(scales, load, MATERIAL).area_ratio for load in (0.05, 0.155, 0.62)]
    assert ratios[0] < ratios[1] < ratios[2] <= 1.0


@pytest.mark.parametrize("load_star", [0.0, -0.1, math.nan, math.inf])
def test_bad_load_raises_input_error(load_star):
    with pytest.raises(InputError, match="F\\*"):
        normal_contact(single_scale(0.1e-6), load_star, MATERIAL)


def test_zero_roughness_raises_input_error():
    with pytest.raises(InputError, match="zero roughness"):
        normal_contact(single_scale(0.0), 0.155, MATERIAL)
