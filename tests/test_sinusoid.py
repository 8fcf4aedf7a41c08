"""Single-scale sinusoid contact (Eqs. 24–37; theory.md §4, §6 and checks §9–§9)."""

import math

import numpy as np
import pytest
from roughfriction.material import Material
from roughfriction.multiscale.sinusoid import (
    complete_contact_pressure,
    contact_area_per_cell,
    critical_amplitude,
    elastic_contact_area,
    elastic_plastic_complete_contact_pressure,
    elastic_plastic_contact_area,
    jgh_area_low_load,
    jgh_area_near_complete,
    junction_growth_factor,
    junction_growth_fit,
    kj_contact_area,
    kj_critical_area,
    kj_critical_pressure,
    peak_radius,
    plasticity_parameter,
    poisson_coefficient_c_nu,
    regime_complete_contact_pressure,
)

MATERIAL = Material()
MPA = 1e6
UM = 1e-6

# theory.md §9: the elastic single sinusoid
ELASTIC_WAVELENGTH = 127 * UM
ELASTIC_AMPLITUDE = 0.1 * UM
# theory.md §9: the elastic-plastic example
EP_WAVELENGTH = 10 * UM
EP_AMPLITUDE = 0.05 * UM


def hertz_area(load, radius, material):
    """Contact area pi a^2 [m^2] of a sphere of radius R [m] on a rigid flat under load P [N]."""
    return math.pi * (3.0 * load * radius / (4.0 * material.E_star)) ** (2.0 / 3.0)


def elastic_area_ratio(ratio):
    """Ā/λ² of the check sinusoid (theory.md §9) at p̄ = ratio p*."""
    f = 1.0 / ELASTIC_WAVELENGTH
    pressure = ratio * complete_contact_pressure(ELASTIC_AMPLITUDE, f, MATERIAL)
    area = elastic_contact_area(pressure, ELASTIC_AMPLITUDE, ELASTIC_WAVELENGTH, MATERIAL)
    return area / ELASTIC_WAVELENGTH**2


def test_complete_contact_pressure_and_critical_amplitude_of_the_elastic_example():
    f = 1.0 / ELASTIC_WAVELENGTH
    p_star = complete_contact_pressure(ELASTIC_AMPLITUDE, f, MATERIAL)
    assert p_star == pytest.approx(math.sqrt(2) * math.pi * MATERIAL.E_star * ELASTIC_AMPLITUDE * f)
    assert p_star / MPA == pytest.approx(768.86, abs=0.005)
    assert critical_amplitude(f, MATERIAL) / UM == pytest.approx(0.10821, abs=5e-6)


def test_low_load_asymptote_is_two_hertz_contacts():
    f = 1.0 / ELASTIC_WAVELENGTH
    p_star = complete_contact_pressure(ELASTIC_AMPLITUDE, f, MATERIAL)
    radius = peak_radius(ELASTIC_AMPLITUDE, ELASTIC_WAVELENGTH)
    for ratio in (1e-4, 0.01, 0.3):
        peak_load = ratio * p_star * ELASTIC_WAVELENGTH**2 / 2.0
        two_peaks = 2.0 * hertz_area(peak_load, radius, MATERIAL)
        assert jgh_area_low_load(ratio, f) == pytest.approx(two_peaks, rel=1e-12)
    assert jgh_area_low_load(0.01, f) / ELASTIC_WAVELENGTH**2 == pytest.approx(0.035351, abs=5e-7)


def test_js_blend_values():
    for ratio, expected in ((0.01, 0.03970), (0.1, 0.21103), (0.5, 0.68156)):
        assert elastic_area_ratio(ratio) == pytest.approx(expected, abs=5e-6)


def test_js_blend_is_continuous_at_the_switch():
    f = 1.0 / ELASTIC_WAVELENGTH
    r = 0.8
    left = jgh_area_low_load(r, f) * (1 - r**1.51) + jgh_area_near_complete(r, f) * r**1.04
    right = elastic_area_ratio(r) * ELASTIC_WAVELENGTH**2
    assert right == pytest.approx(jgh_area_near_complete(r, f), rel=1e-15)  # Eq. 25 from 0.8
    assert abs(left - right) < 5e-4 * ELASTIC_WAVELENGTH**2
    assert left / ELASTIC_WAVELENGTH**2 == pytest.approx(0.90492, abs=5e-6)
    assert right / ELASTIC_WAVELENGTH**2 == pytest.approx(0.90451, abs=5e-6)
    assert elastic_area_ratio(r * (1 - 1e-12)) == pytest.approx(left / ELASTIC_WAVELENGTH**2)


@pytest.mark.parametrize("ratio", [1.0, 1.5, 100.0])
def test_complete_contact_fills_the_cell(ratio):
    assert elastic_area_ratio(ratio) == 1.0


def test_flat_scale_is_in_complete_contact():
    area = contact_area_per_cell(1e6, 0.0, ELASTIC_WAVELENGTH, MATERIAL)
    assert area == ELASTIC_WAVELENGTH**2
    assert junction_growth_factor(1e6, 0.0, ELASTIC_WAVELENGTH, MATERIAL.tau_c, MATERIAL) == 1.0


def test_critical_amplitude_against_poisson_ratio():
    expected = {0.0: 0.12715, 0.1: 0.13986, 0.2: 0.15806, 0.3: 0.18726, 0.4: 0.24380}
    for nu, value in expected.items():
        material = Material(nu=nu)
        scaled = critical_amplitude(1.0, material) * material.E_star / material.Sy
        assert scaled == pytest.approx(value, abs=5e-6)
    f = 1.0 / EP_WAVELENGTH
    p_critical = complete_contact_pressure(critical_amplitude(f, MATERIAL), f, MATERIAL)
    assert p_critical / MATERIAL.Sy == pytest.approx(0.8320, abs=5e-5)


def test_c_nu_is_computed_at_the_paper_poisson_ratio():
    # Exposed, not used anywhere (theory.md §8 #7).
    assert poisson_coefficient_c_nu(MATERIAL) == pytest.approx(-0.0374, abs=5e-5)
    assert poisson_coefficient_c_nu(Material(nu=0.0)) == pytest.approx(0.0017 - 0.0567)


def test_elastic_plastic_complete_pressure_at_the_critical_amplitude():
    f = 1.0 / EP_WAVELENGTH
    delta_c = critical_amplitude(f, MATERIAL)
    ratio = elastic_plastic_complete_contact_pressure(delta_c, f, MATERIAL) / (
        complete_contact_pressure(delta_c, f, MATERIAL)
    )
    assert abs(ratio - 0.992) < 1e-9  # the fit's own constant
    assert abs(ratio - 1.0) < 0.01  # the paper: p*_ep = p* at Δ = Δ_c


def test_elastic_plastic_complete_pressure_table():
    f = 1.0 / EP_WAVELENGTH
    delta_c = critical_amplitude(f, MATERIAL)
    table = {  # x: (p*_ep / p*, p*_ep / S_y), theory.md §9
        1: (0.9920, 0.825), 2: (0.7989, 1.329), 5: (0.5126, 2.132), 10: (0.3166, 2.634),
        20: (0.1693, 2.817), 30: (0.1094, 2.731), 100: (0.0222, 1.844),
    }
    for x, (over_elastic, over_yield) in table.items():
        pressure = elastic_plastic_complete_contact_pressure(x * delta_c, f, MATERIAL)
        elastic = complete_contact_pressure(x * delta_c, f, MATERIAL)
        assert pressure / elastic == pytest.approx(over_elastic, abs=5e-5)
        assert pressure / MATERIAL.Sy == pytest.approx(over_yield, abs=5e-4)


def test_elastic_plastic_complete_pressure_warns_beyond_its_range():
    f = 1.0 / EP_WAVELENGTH
    delta_c = critical_amplitude(f, MATERIAL)
    with pytest.warns(RuntimeWarning, match="x = Δ/Δ_c = 101"):
        elastic_plastic_complete_contact_pressure(101 * delta_c, f, MATERIAL)


def test_critical_values_of_the_elastic_plastic_example():
    f = 1.0 / EP_WAVELENGTH
    phi = plasticity_parameter(EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL)
    assert phi == pytest.approx(1.09890, abs=5e-6)
    assert complete_contact_pressure(EP_AMPLITUDE, f, MATERIAL) / MPA == pytest.approx(
        4882.29, abs=0.005
    )
    delta_c = critical_amplitude(f, MATERIAL)
    assert delta_c / UM == pytest.approx(0.008520, abs=5e-7)
    assert EP_AMPLITUDE / delta_c == pytest.approx(5.8683, abs=5e-5)
    assert 3.8 * phi**0.11 == pytest.approx(3.83963, abs=5e-6)  # d, Eq. 31
    assert peak_radius(EP_AMPLITUDE, EP_WAVELENGTH) / UM == pytest.approx(50.661, abs=5e-4)
    critical_area = kj_critical_area(EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL)
    assert critical_area / EP_WAVELENGTH**2 == pytest.approx(0.021484, abs=5e-7)
    assert critical_area == pytest.approx(
        MATERIAL.C**2 * EP_WAVELENGTH**2 / (32 * math.pi * phi**2), rel=1e-12
    )
    p_c = kj_critical_pressure(EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL)
    assert p_c / MPA == pytest.approx(23.130, abs=5e-4)
    p_ep = regime_complete_contact_pressure(EP_AMPLITUDE, f, MATERIAL)
    assert p_ep / MPA == pytest.approx(2266.17, abs=0.005)


def test_kj_area_equals_hertz_at_yield_inception():
    f = 1.0 / EP_WAVELENGTH
    p_c = kj_critical_pressure(EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL)
    critical_area = kj_critical_area(EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL)
    plastic = kj_contact_area(p_c, EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL)
    elastic = jgh_area_low_load(p_c / complete_contact_pressure(EP_AMPLITUDE, f, MATERIAL), f)
    assert plastic == pytest.approx(critical_area, rel=1e-6)
    assert elastic == pytest.approx(critical_area, rel=1e-6)


def test_kj_area_is_a_power_law_from_yield_inception():
    p_c = kj_critical_pressure(EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL)
    critical_area = kj_critical_area(EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL)
    d = 3.8 * plasticity_parameter(EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL) ** 0.11
    for pressure in (1 * MPA, 300 * MPA, 4000 * MPA):
        expected = critical_area * (pressure / p_c) ** (d / (1 + d))
        area = kj_contact_area(pressure, EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL)
        assert area == pytest.approx(expected, rel=1e-12)


def test_elastic_plastic_area_values():
    expected = {10: 0.01291, 100: 0.08919, 500: 0.35138, 1000: 0.61564, 2000: 0.95599}
    for pressure, value in expected.items():
        area = contact_area_per_cell(pressure * MPA, EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL)
        assert area / EP_WAVELENGTH**2 == pytest.approx(value, abs=5e-6)


def test_elastic_plastic_area_reaches_the_cell_at_complete_contact():
    p_ep = regime_complete_contact_pressure(EP_AMPLITUDE, 1.0 / EP_WAVELENGTH, MATERIAL)
    cell = EP_WAVELENGTH**2
    below = elastic_plastic_contact_area(p_ep * (1 - 1e-9), EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL)
    assert below == pytest.approx(cell, rel=1e-7)
    for pressure in (p_ep, 2 * p_ep):
        assert elastic_plastic_contact_area(pressure, EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL) == cell


def test_branch_follows_the_critical_amplitude():
    f = 1.0 / EP_WAVELENGTH
    delta_c = critical_amplitude(f, MATERIAL)
    pressure = 50 * MPA
    for amplitude, branch in ((delta_c, elastic_contact_area),
                              (delta_c * (1 + 1e-9), elastic_plastic_contact_area)):
        area = contact_area_per_cell(pressure, amplitude, EP_WAVELENGTH, MATERIAL)
        assert area == branch(pressure, amplitude, EP_WAVELENGTH, MATERIAL)
    assert regime_complete_contact_pressure(delta_c, f, MATERIAL) == complete_contact_pressure(
        delta_c, f, MATERIAL
    )


def test_functions_broadcast_over_arrays():
    pressures = np.array([10.0, 100.0, 2000.0]) * MPA
    amplitudes = np.array([[ELASTIC_AMPLITUDE * 1e-2], [EP_AMPLITUDE]])
    areas = contact_area_per_cell(pressures, amplitudes, EP_WAVELENGTH, MATERIAL)
    assert areas.shape == (2, 3)
    for (row, column), area in np.ndenumerate(areas):
        expected = contact_area_per_cell(
            float(pressures[column]), float(amplitudes[row, 0]), EP_WAVELENGTH, MATERIAL
        )
        assert area == expected
    pressure = complete_contact_pressure(amplitudes, 1.0 / EP_WAVELENGTH, MATERIAL)
    assert pressure.shape == (2, 1)


def test_junction_growth_fit_table():
    tau_c = MATERIAL.tau_c
    table = {  # (tau, phi): G at r = 1e-4, 1e-2, 0.1, 0.5, 1 (theory.md §9)
        (tau_c, 1.0): (2.952, 1.219, 1.187, 1.175, 0.995),
        (tau_c, 10.0): (2.657, 1.170, 1.143, 1.121, 0.801),
        (0.0, 1.0): (2.552, 1.054, 1.026, 1.016, 0.860),
    }
    for (tau, phi), row in table.items():
        for ratio, expected in zip((1e-4, 1e-2, 0.1, 0.5, 1.0), row, strict=True):
            assert junction_growth_fit(ratio, phi, tau, MATERIAL) == pytest.approx(
                expected, abs=5e-4
            )


def test_junction_growth_fit_without_shear_is_near_one():
    ratios, phis = np.meshgrid(np.linspace(0.01, 0.5, 12), np.linspace(0.0, 10.0, 11))
    growth = junction_growth_fit(ratios, phis, 0.0, MATERIAL)
    assert growth.min() >= 0.95 and growth.max() <= 1.06


def test_junction_growth_factor_clamps():
    f = 1.0 / EP_WAVELENGTH
    tau_c = MATERIAL.tau_c
    p_ep = regime_complete_contact_pressure(EP_AMPLITUDE, f, MATERIAL)
    phi = plasticity_parameter(EP_AMPLITUDE, EP_WAVELENGTH, MATERIAL)

    def factor(pressure):
        return junction_growth_factor(pressure, EP_AMPLITUDE, EP_WAVELENGTH, tau_c, MATERIAL)

    assert factor(0.1 * p_ep) == junction_growth_fit(0.1, phi, tau_c, MATERIAL)
    assert factor(0.1 * p_ep) > 1.1
    near_complete = 0.9999 * p_ep
    assert junction_growth_fit(0.9999, phi, tau_c, MATERIAL) < 1.0  # the fit alone shrinks
    assert factor(near_complete) == 1.0
    assert factor(p_ep) == 1.0 and factor(3 * p_ep) == 1.0


def test_elastic_plastic_area_never_exceeds_the_cell():
    # At nu = 0.499, x = 8.4 the Eq. 29 blend overshoots λ² by ~1 % near r_ep = 0.9
    # (theory.md §4.4).
    material = Material(nu=0.499)
    f = 1.0 / EP_WAVELENGTH
    amplitude = 8.4 * critical_amplitude(f, material)
    ratio = 0.9
    pressure = ratio * regime_complete_contact_pressure(amplitude, f, material)
    plastic = kj_contact_area(pressure, amplitude, EP_WAVELENGTH, material)
    blend = plastic * (1 - ratio**1.51) + jgh_area_near_complete(ratio, f) * ratio**1.04
    assert blend > 1.01 * EP_WAVELENGTH**2
    area = elastic_plastic_contact_area(pressure, amplitude, EP_WAVELENGTH, material)
    assert area == EP_WAVELENGTH**2
