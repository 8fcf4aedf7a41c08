"""Contact of one scale: a 3-D sinusoid z = Δ cos(2πx/λ) cos(2πy/λ) pressed by a rigid flat.

Paper Sect. 4.1, Eqs. 24–34 and 36–37; reconstructions as in docs/theory.md §4 and §6. Every
area is per λ² cell, which holds two peaks of tip radius R_p = λ² / (4π² Δ), so complete
contact means an area of λ² (theory.md §4.1).

Each public function is written for scalars with ``math`` (the multi-scale loops call it once per
scale) and also accepts NumPy arrays, which it broadcasts element by element.
"""

from __future__ import annotations

import functools
import math
import warnings

import numpy as np
from roughfriction.material import Material

# Eqs. 24-25 switch from the blend to the near-complete asymptote at p/p* = 0.8
# [S-fix] theory.md §4.2
JS_BLEND_LIMIT = 0.8
# Eq. 32 as reconstructed rises to a plateau and then falls: trusted up to x = Δ/Δ_c = 100
# (theory.md §4.5)
EP_PRESSURE_TRUSTED_X = 100.0


def _elementwise(scalar_function):
    """Let a scalar formula also take NumPy arrays (broadcast, applied element by element)."""
    vectorised = np.vectorize(scalar_function, otypes=[float])

    @functools.wraps(scalar_function)
    def broadcasting(*args):
        if all(isinstance(arg, (float, int, Material)) for arg in args):
            return scalar_function(*args)
        return vectorised(*args)

    return broadcasting


def _pressure_ratio(mean_pressure, complete_pressure):
    """p / p_complete capped at 1 [-]; a flat scale (p_complete = 0) is in complete contact."""
    if mean_pressure >= complete_pressure:
        return 1.0
    return mean_pressure / complete_pressure


@_elementwise
def complete_contact_pressure(amplitude, frequency, material):
    """Mean pressure that flattens an elastic sinusoid completely, p* [Pa] (Eq. 28).

    Parameters
    ----------
    amplitude : float or array_like
        Sinusoid amplitude Δ [m].
    frequency : float or array_like
        Spatial frequency f = 1/λ [m^-1].
    material : Material
        Supplies E' [Pa].

    Returns
    -------
    float or numpy.ndarray
        p* = √2 π E' Δ f [Pa] (the paper's OCR prints √(2π); theory.md §4.2).
    """
    return math.sqrt(2.0) * math.pi * material.E_star * amplitude * frequency  # Eq. 28


@_elementwise
def jgh_area_low_load(pressure_ratio, frequency):
    """Johnson–Greenwood–Higginson low-load contact area per λ² cell, Ā_1 [m^2] (Eq. 26).

    It equals the Hertz area of the cell's two peaks, each carrying p̄λ²/2 (theory.md §4.2 [R]).

    Parameters
    ----------
    pressure_ratio : float or array_like
        r = p̄ / p* [-].
    frequency : float or array_like
        f = 1/λ [m^-1].

    Returns
    -------
    float or numpy.ndarray
        Ā_1 = (π / f²) (3r / (8π))^(2/3) [m^2].
    """
    return math.pi / frequency**2 * (3.0 * pressure_ratio / (8.0 * math.pi)) ** (2.0 / 3.0)


@_elementwise
def jgh_area_near_complete(pressure_ratio, frequency):
    """JGH contact area per λ² cell near complete contact, Ā_2 [m^2] (Eq. 27).

    Parameters
    ----------
    pressure_ratio : float or array_like
        r = p̄ / p* [-] (or p̄ / p*_ep in Eq. 29, theory.md §8 #5).
    frequency : float or array_like
        f = 1/λ [m^-1].

    Returns
    -------
    float or numpy.ndarray
        Ā_2 = (1 / f²) [1 − 3 (1 − r) / (2π)] [m^2]; λ² at r = 1.
    """
    return (1.0 - 3.0 / (2.0 * math.pi) * (1.0 - pressure_ratio)) / frequency**2  # Eq. 27


@_elementwise
def elastic_contact_area(mean_pressure, amplitude, wavelength, material):
    """Elastic contact area per λ² cell, Jackson–Streator blend, Ā [m^2] (Eqs. 24–25).

    Parameters
    ----------
    mean_pressure : float or array_like
        Mean pressure on the cell p̄ [Pa].
    amplitude : float or array_like
        Δ [m].
    wavelength : float or array_like
        λ [m].
    material : Material
        Supplies E' [Pa].

    Returns
    -------
    float or numpy.ndarray
        Ā [m^2]: blend of Ā_1 and Ā_2 for r = p̄/p* < 0.8, Ā_2 for 0.8 ≤ r < 1 and λ² for r ≥ 1.
    """
    frequency = 1.0 / wavelength
    complete_pressure = complete_contact_pressure(amplitude, frequency, material)
    ratio = _pressure_ratio(mean_pressure, complete_pressure)
    if ratio >= 1.0:  # complete contact [I] theory.md §4.2
        return wavelength**2
    near_complete = jgh_area_near_complete(ratio, frequency)
    if ratio >= JS_BLEND_LIMIT:  # Eq. 25, threshold read as p/p* [S-fix] theory.md §4.2
        return near_complete
    low_load = jgh_area_low_load(ratio, frequency)
    return low_load * (1.0 - ratio**1.51) + near_complete * ratio**1.04  # Eq. 24


@_elementwise
def critical_amplitude(frequency, material):
    """Amplitude above which the sinusoid deforms plastically before complete contact, Δ_c [m].

    Parameters
    ----------
    frequency : float or array_like
        f = 1/λ [m^-1].
    material : Material
        Supplies E' [Pa], S_y [Pa], ν [-].

    Returns
    -------
    float or numpy.ndarray
        Δ_c = √2 S_y / (π E' f [3 exp(−2(1+ν)/3) + 2(1−2ν)/(1−ν)]) [m] (Eq. 33 as printed).
    """
    nu = material.nu
    bracket = 3.0 * math.exp(-2.0 * (1.0 + nu) / 3.0) + 2.0 * (1.0 - 2.0 * nu) / (1.0 - nu)
    denominator = math.pi * material.E_star * frequency * bracket
    return math.sqrt(2.0) * material.Sy / denominator  # Eq. 33


def poisson_coefficient_c_nu(material):
    """The paper's C_ν(ν) = 0.0017 exp(8.09 ν) − 0.0567 [-] (Eq. 34).

    Exposed for completeness but used nowhere: where C_ν enters was lost in the paper's text, and
    Eq. 33 as printed is dimensionally complete without it (theory.md §4.3, §8 #7).

    Parameters
    ----------
    material : Material
        Supplies ν [-].

    Returns
    -------
    float
        C_ν [-] (−0.0374 at ν = 0.3).
    """
    return 0.0017 * math.exp(8.09 * material.nu) - 0.0567  # Eq. 34


@_elementwise
def elastic_plastic_complete_contact_pressure(amplitude, frequency, material):
    """Mean pressure for complete contact of an elastic–plastic sinusoid, p*_ep [Pa] (Eq. 32).

    Eq. 32 is garbled in the paper; this is the reconstruction of theory.md [R] theory.md §4.5:
    p*_ep / p* = 0.992 x^(−1/X), X = (10/3) x^(−0.39) + (9/4) ν⁴ + 0.64, x = Δ/Δ_c. It is meant
    for x ≥ 1 and warns (RuntimeWarning) above x = 100, where the fit turns down.

    Parameters
    ----------
    amplitude : float or array_like
        Δ [m].
    frequency : float or array_like
        f = 1/λ [m^-1].
    material : Material
        Supplies E' [Pa], S_y [Pa], ν [-].

    Returns
    -------
    float or numpy.ndarray
        p*_ep [Pa]; 0.992 p* at Δ = Δ_c.
    """
    x = amplitude / critical_amplitude(frequency, material)
    if x > EP_PRESSURE_TRUSTED_X:
        warnings.warn(
            f"p*_ep (Eq. 32, reconstructed) is extrapolated at x = Δ/Δ_c = {x:.3g} > "
            f"{EP_PRESSURE_TRUSTED_X:g}",
            RuntimeWarning,
            stacklevel=3,
        )
    exponent = 10.0 / 3.0 * x**-0.39 + 2.25 * material.nu**4 + 0.64  # X of Eq. 32
    elastic_pressure = complete_contact_pressure(amplitude, frequency, material)
    return 0.992 * x ** (-1.0 / exponent) * elastic_pressure  # Eq. 32, [R] theory.md §4.5


@_elementwise
def regime_complete_contact_pressure(amplitude, frequency, material):
    """Complete-contact pressure of the regime Δ selects: p* if Δ ≤ Δ_c, else p*_ep [Pa].

    Parameters
    ----------
    amplitude : float or array_like
        Δ [m].
    frequency : float or array_like
        f = 1/λ [m^-1].
    material : Material
        Supplies E' [Pa], S_y [Pa], ν [-].

    Returns
    -------
    float or numpy.ndarray
        p* (Eq. 28) or p*_ep (Eq. 32) [Pa], by the rule of theory.md §4.3.
    """
    if amplitude <= critical_amplitude(frequency, material):
        return complete_contact_pressure(amplitude, frequency, material)
    return elastic_plastic_complete_contact_pressure(amplitude, frequency, material)


@_elementwise
def plasticity_parameter(amplitude, wavelength, material):
    """φ = E' Δ / (S_y λ) [-] (Eq. 37, also the argument of Eq. 31).

    Parameters
    ----------
    amplitude : float or array_like
        Δ [m].
    wavelength : float or array_like
        λ [m].
    material : Material
        Supplies E' [Pa], S_y [Pa].

    Returns
    -------
    float or numpy.ndarray
        φ [-].
    """
    return material.E_star * amplitude / (material.Sy * wavelength)  # Eq. 37


@_elementwise
def peak_radius(amplitude, wavelength):
    """Tip radius of each of the two peaks of a λ² cell, R_p = λ² / (4π² Δ) [m]
    ([R] theory.md §4.1).

    Parameters
    ----------
    amplitude : float or array_like
        Δ [m].
    wavelength : float or array_like
        λ [m].

    Returns
    -------
    float or numpy.ndarray
        R_p [m].
    """
    return wavelength**2 / (4.0 * math.pi**2 * amplitude)


@_elementwise
def kj_critical_area(amplitude, wavelength, material):
    """Contact area per λ² cell at yield inception of its two peaks, A_c [m^2] ([R] theory.md §4.4).

    A_c = 2 a_c with the Jackson–Green critical area of one peak a_c = π³ (C S_y R_p / (2E'))²,
    which equals C² λ² / (64 π φ²).

    Parameters
    ----------
    amplitude : float or array_like
        Δ [m].
    wavelength : float or array_like
        λ [m].
    material : Material
        Supplies E' [Pa], S_y [Pa], C [-].

    Returns
    -------
    float or numpy.ndarray
        A_c [m^2].
    """
    radius = peak_radius(amplitude, wavelength)
    return 2.0 * math.pi**3 * (material.C * material.Sy * radius / (2.0 * material.E_star)) ** 2


def critical_peak_pressure(material):
    """Mean contact pressure of a peak at yield inception, p_c = (2/3) C S_y [Pa]
    ([R] theory.md §4.4).

    Parameters
    ----------
    material : Material
        Supplies S_y [Pa], C [-] (Eq. 13).

    Returns
    -------
    float
        p_c [Pa] (Jackson–Green).
    """
    return 2.0 / 3.0 * material.C * material.Sy


@_elementwise
def kj_critical_pressure(amplitude, wavelength, material):
    """Mean cell pressure at yield inception of the peaks, p̄_c [Pa] ([R] theory.md §4.4).

    p̄_c = p_c A_c / λ² with the peak's critical mean contact pressure p_c = (2/3) C S_y.

    Parameters
    ----------
    amplitude : float or array_like
        Δ [m].
    wavelength : float or array_like
        λ [m].
    material : Material
        Supplies E' [Pa], S_y [Pa], C [-].

    Returns
    -------
    float or numpy.ndarray
        p̄_c [Pa].
    """
    critical_area = kj_critical_area(amplitude, wavelength, material)
    return critical_peak_pressure(material) * critical_area / wavelength**2


@_elementwise
def kj_contact_area(mean_pressure, amplitude, wavelength, material):
    """Krithivasan–Jackson elastic–plastic contact area per λ² cell, Ā_p [m^2] (Eqs. 30–31).

    Ā_p = 2 (A_c/2)^(1/(1+d)) (3 p̄ λ² / (4 C S_y))^(d/(1+d)), d = 3.8 φ^0.11, which equals
    A_c (p̄ / p̄_c)^(d/(1+d)): the Hertz area at yield inception (theory.md §4.4).

    Parameters
    ----------
    mean_pressure : float or array_like
        p̄ [Pa].
    amplitude : float or array_like
        Δ [m].
    wavelength : float or array_like
        λ [m].
    material : Material
        Supplies E' [Pa], S_y [Pa], C [-].

    Returns
    -------
    float or numpy.ndarray
        Ā_p [m^2].
    """
    exponent = 3.8 * plasticity_parameter(amplitude, wavelength, material) ** 0.11  # Eq. 31
    peak_load = mean_pressure * wavelength**2 / 2.0  # two peaks per cell share p̄λ² [N]
    load_over_critical_pressure = peak_load / critical_peak_pressure(material)  # 3p̄λ²/(4CS_y)
    critical_area = kj_critical_area(amplitude, wavelength, material)  # A_c: [R] theory.md §4.4
    return (
        2.0
        * (critical_area / 2.0) ** (1.0 / (1.0 + exponent))
        * load_over_critical_pressure ** (exponent / (1.0 + exponent))
    )  # Eq. 30


@_elementwise
def elastic_plastic_contact_area(mean_pressure, amplitude, wavelength, material):
    """Elastic–plastic contact area per λ² cell, Ā [m^2] (Eq. 29).

    Ā = Ā_p (1 − r_ep^1.51) + Ā_2(r_ep) r_ep^1.04 with r_ep = p̄ / p*_ep, Ā_2 evaluated at r_ep so
    that Ā reaches λ² at p̄ = p*_ep (theory.md §8 #5), λ² for r_ep ≥ 1, and never above λ².

    Parameters
    ----------
    mean_pressure : float or array_like
        p̄ [Pa].
    amplitude : float or array_like
        Δ [m].
    wavelength : float or array_like
        λ [m].
    material : Material
        Supplies E' [Pa], S_y [Pa], ν [-], C [-].

    Returns
    -------
    float or numpy.ndarray
        Ā [m^2].
    """
    frequency = 1.0 / wavelength
    complete_pressure = elastic_plastic_complete_contact_pressure(amplitude, frequency, material)
    ratio = _pressure_ratio(mean_pressure, complete_pressure)
    if ratio >= 1.0:  # complete contact
        return wavelength**2
    plastic_area = kj_contact_area(mean_pressure, amplitude, wavelength, material)
    near_complete = jgh_area_near_complete(ratio, frequency)  # [I] theory.md §4.4
    blend = plastic_area * (1.0 - ratio**1.51) + near_complete * ratio**1.04  # Eq. 29
    return min(blend, wavelength**2)


@_elementwise
def contact_area_per_cell(mean_pressure, amplitude, wavelength, material):
    """Contact area per λ² cell of one scale, elastic or elastic–plastic by Δ vs Δ_c, Ā [m^2].

    Parameters
    ----------
    mean_pressure : float or array_like
        p̄ [Pa].
    amplitude : float or array_like
        Δ [m].
    wavelength : float or array_like
        λ [m].
    material : Material
        Supplies E' [Pa], S_y [Pa], ν [-], C [-].

    Returns
    -------
    float or numpy.ndarray
        Ā [m^2]: Eqs. 24–25 if Δ ≤ Δ_c (Eq. 33), else Eq. 29.
    """
    if amplitude <= critical_amplitude(1.0 / wavelength, material):
        return elastic_contact_area(mean_pressure, amplitude, wavelength, material)
    return elastic_plastic_contact_area(mean_pressure, amplitude, wavelength, material)


@_elementwise
def junction_growth_fit(pressure_ratio, phi, shear_stress, material):
    """Junction growth of a sinusoid at sliding inception, A_s / A_0 [-] (Eq. 36, unclamped).

    Parameters
    ----------
    pressure_ratio : float or array_like
        r_ep = p̄ / p*_ep (p̄ / p* in the elastic regime) [-], > 0.
    phi : float or array_like
        φ = E' Δ / (S_y λ) [-] (Eq. 37).
    shear_stress : float or array_like
        Interfacial shear stress τ [Pa] (τ_c in the paper).
    material : Material
        Supplies S_y [Pa].

    Returns
    -------
    float or numpy.ndarray
        G = 2.6 {coth(15.2 √r) e^(−0.017φ−3) − 0.03 φ^(1/4) r⁴ + 0.1364} [(τ/S_y)² + 2.13] [-];
        it diverges as r → 0 and falls below 1 near r = 1 (theory.md §6).
    """
    coth = 1.0 / math.tanh(15.2 * math.sqrt(pressure_ratio))
    braces = coth * math.exp(-0.017 * phi - 3.0) - 0.03 * phi**0.25 * pressure_ratio**4 + 0.1364
    return 2.6 * braces * ((shear_stress / material.Sy) ** 2 + 2.13)  # Eq. 36


@_elementwise
def junction_growth_factor(mean_pressure, amplitude, wavelength, shear_stress, material):
    """Junction growth factor applied to one scale, G_eff = A_s / A_0 [-] (Eqs. 36–37, clamped).

    Clamps [I] theory.md §6: G_eff = 1 in complete contact (p̄ ≥ p*_ep), otherwise max(G, 1), so the
    fit's G < 1 near complete contact never shrinks the area.

    Parameters
    ----------
    mean_pressure : float or array_like
        p̄ [Pa].
    amplitude : float or array_like
        Δ [m].
    wavelength : float or array_like
        λ [m].
    shear_stress : float or array_like
        Interfacial shear stress τ [Pa].
    material : Material
        Supplies E' [Pa], S_y [Pa], ν [-].

    Returns
    -------
    float or numpy.ndarray
        G_eff ≥ 1 [-].
    """
    complete_pressure = regime_complete_contact_pressure(amplitude, 1.0 / wavelength, material)
    ratio = _pressure_ratio(mean_pressure, complete_pressure)
    if ratio >= 1.0:
        return 1.0
    phi = plasticity_parameter(amplitude, wavelength, material)
    return max(junction_growth_fit(ratio, phi, shear_stress, material), 1.0)
