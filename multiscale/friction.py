"""Static friction of stacked scales with junction growth (paper Sect. 4.2; theory.md §6).

Added assumptions [S]: (d') every scale carries the same total tangential load F_t; (e') F_t is
shared equally within a scale; (f') τ_i ≥ τ_{i−1}. A load loop (iteration a) repeats the scale
loop (iteration b) with the tangential load of the previous pass until F_t settles; the static
friction coefficient is μ_s = max_j F_t^(j) / F_n.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from roughfriction.errors import InputError
from roughfriction.material import Material
from roughfriction.multiscale.scales import Scales
from roughfriction.multiscale.sinusoid import junction_growth_factor
from roughfriction.multiscale.stacking import normal_contact, scale_contact_area

VARIANTS = ("A", "B")


@dataclass(frozen=True, eq=False)
class SlidingPass:
    """One pass of the scale loop (iteration b) at a given tangential load.

    Attributes
    ----------
    areas : numpy.ndarray
        Contact area at sliding inception after each scale, A_i [m^2].
    shear_stresses : numpy.ndarray
        Shear stress on each scale, τ_i [Pa].
    """

    areas: np.ndarray
    shear_stresses: np.ndarray


@dataclass(frozen=True, eq=False)
class FrictionResult:
    """Static friction predicted by the multi-scale model.

    The sliding areas and shear stresses are those of the last load iteration; per-scale arrays
    have index 0 for scale i = 1.

    Attributes
    ----------
    mu_s : float
        Static friction coefficient Ft_max / F_n [-].
    Ft_max : float
        Largest tangential load over the load iterations [N].
    normal_load : float
        F_n = F* A_n S_y [N].
    nominal_area : float
        A_n = L² [m^2].
    area_ratio_normal : float
        A_r / A_n under normal load only [-].
    area_ratio_sliding : float
        A_s / A_n at sliding inception [-].
    area_ratios_normal : numpy.ndarray
        A_i / A_n per scale under normal load only [-] (paper Fig. 17).
    area_ratios_sliding : numpy.ndarray
        A_i / A_n per scale at sliding inception [-] (paper Fig. 17).
    shear_stresses : numpy.ndarray
        τ_i per scale [Pa] (paper Fig. 18).
    history : numpy.ndarray
        F_t^(j) per load iteration j = 1, 2, … [N] (paper Fig. 19).
    iterations : int
        Load iterations done [-].
    converged : bool
        Whether |F_t^(j) − F_t^(j−1)| / F_t^(j) fell below the tolerance.
    """

    mu_s: float
    Ft_max: float
    normal_load: float
    nominal_area: float
    area_ratio_normal: float
    area_ratio_sliding: float
    area_ratios_normal: np.ndarray
    area_ratios_sliding: np.ndarray
    shear_stresses: np.ndarray
    history: np.ndarray
    iterations: int
    converged: bool


def sliding_pass(
    scales: Scales, normal_load, nominal_area, tangential_load, material: Material, variant="A"
) -> SlidingPass:
    """Contact areas at sliding inception, scale by scale (iteration b of theory.md §6).

    Parameters
    ----------
    scales : Scales
        The surface's scales.
    normal_load : float
        F_n [N].
    nominal_area : float
        A_n [m^2].
    tangential_load : float
        F_t of the previous load iteration [N] (sets τ_i).
    material : Material
        The material (τ_c [Pa] included).
    variant : {"A", "B"}
        Shear stress in Eq. 36: τ_c at every scale (A, the paper's Eq. 36) or min(τ_i, τ_c) (B).

    Returns
    -------
    SlidingPass
        A_i [m^2] and τ_i [Pa] per scale.
    """
    area = nominal_area
    shear_stress = tangential_load / nominal_area
    areas, shear_stresses = [], []
    scale_pairs = zip(scales.amplitude.tolist(), scales.wavelength.tolist(), strict=True)
    for amplitude, wavelength in scale_pairs:
        pressure = normal_load / area  # Eq. 23
        normal_area = scale_contact_area(pressure, area, amplitude, wavelength, material)
        shear_stress = max(tangential_load / normal_area, shear_stress)  # (e'), (f')
        growth_stress = material.tau_c if variant == "A" else min(shear_stress, material.tau_c)
        growth = junction_growth_factor(pressure, amplitude, wavelength, growth_stress, material)
        area = min(normal_area * growth, area)  # Eq. 36, then A_i <= A_{i-1}
        areas.append(area)
        shear_stresses.append(shear_stress)
    return SlidingPass(areas=np.array(areas), shear_stresses=np.array(shear_stresses))


def static_friction(
    scales: Scales,
    load_star,
    material: Material,
    *,
    variant="A",
    tolerance=1e-6,
    max_iterations=200,
) -> FrictionResult:
    """Static friction coefficient of a rough surface on a rigid flat (theory.md §6 algorithm).

    Parameters
    ----------
    scales : Scales
        The surface's scales (from ``scale_decomposition``).
    load_star : float
        F* = F_n / (A_n S_y) [-].
    material : Material
        The material (τ_c [Pa] is the critical interfacial shear strength).
    variant : {"A", "B"}
        "A" (default): Eq. 36 with τ_c at every scale, as printed; converges at j = 2.
        "B": Eq. 36 with min(τ_i, τ_c), so the load loop matters (theory.md §6, §8 #11).
    tolerance : float
        E_c on |F_t^(j) − F_t^(j−1)| / F_t^(j) [-] (theory.md §8 #13).
    max_iterations : int
        j_max, load iterations at most [-]; if reached, ``converged`` is False and a
        RuntimeWarning is issued.

    Returns
    -------
    FrictionResult
        μ_s = max_j F_t^(j) / F_n with F_t^(j) = τ_c A_s^(j) by (d') and (e').
    """
    if variant not in VARIANTS:
        raise InputError(f"variant must be one of {', '.join(VARIANTS)}, got {variant!r}")
    if not (tolerance > 0 and max_iterations >= 1):
        raise InputError(
            f"need tolerance > 0 and max_iterations >= 1, got {tolerance}, {max_iterations}"
        )
    normal = normal_contact(scales, load_star, material)  # validates F* and the roughness
    history = []
    tangential_load = 0.0  # F_t^(0) [I] theory.md §8 #13
    converged = False
    while not converged and len(history) < max_iterations:
        state = sliding_pass(
            scales, normal.normal_load, normal.nominal_area, tangential_load, material, variant
        )
        previous, tangential_load = tangential_load, material.tau_c * state.areas[-1]  # (d'), (e')
        history.append(tangential_load)
        converged = abs(tangential_load - previous) / tangential_load < tolerance
    if not converged:
        warnings.warn(
            f"static friction not converged after {max_iterations} load iterations "
            f"(F* = {load_star}, variant {variant})",
            RuntimeWarning,
            stacklevel=2,
        )
    ft_max = max(history)
    return FrictionResult(
        mu_s=ft_max / normal.normal_load,  # step (5)
        Ft_max=ft_max,
        normal_load=normal.normal_load,
        nominal_area=normal.nominal_area,
        area_ratio_normal=normal.area_ratio,
        area_ratio_sliding=state.areas[-1] / normal.nominal_area,
        area_ratios_normal=normal.area_ratios,
        area_ratios_sliding=state.areas / normal.nominal_area,
        shear_stresses=state.shear_stresses,
        history=np.array(history),
        iterations=len(history),
        converged=converged,
    )
