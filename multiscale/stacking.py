"""Normal contact of stacked scales, Jackson–Streator multi-scale model (Eqs. 22–23; theory.md §5).

Assumptions (a)–(d) of JS [S]: smaller asperities sit on larger ones; every scale carries the
full normal load; the load is shared equally within a scale; A_i ≤ A_{i−1}.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from roughfriction.errors import InputError
from roughfriction.material import Material
from roughfriction.multiscale.scales import Scales
from roughfriction.multiscale.sinusoid import contact_area_per_cell


@dataclass(frozen=True, eq=False)
class NormalContact:
    """Real contact area under normal load only.

    Attributes
    ----------
    area_ratio : float
        A_r / A_n after the last scale [-].
    area_ratios : numpy.ndarray
        A_i / A_n after each scale i = 1 … i_max [-].
    pressures : numpy.ndarray
        Mean pressure on scale i, p̄_i = F_n / A_{i−1} [Pa].
    nominal_area : float
        A_n = L² [m^2].
    normal_load : float
        F_n = F* A_n S_y [N].
    """

    area_ratio: float
    area_ratios: np.ndarray
    pressures: np.ndarray
    nominal_area: float
    normal_load: float


def validate_contact_inputs(scales: Scales, load_star) -> None:
    """Raise InputError unless F* is finite and > 0 and some scale has a non-zero amplitude.

    Parameters
    ----------
    scales : Scales
        The surface's scales.
    load_star : float
        F* = F_n / (A_n S_y) [-].
    """
    if not (math.isfinite(load_star) and load_star > 0):
        raise InputError(f"dimensionless load F* must be a finite number > 0, got {load_star}")
    if not np.any(scales.amplitude > 0):
        raise InputError("surface has zero roughness (all scale amplitudes are 0)")


def nominal_area(scales: Scales) -> float:
    """Nominal contact area A_n = L² [m^2] of the scanned square."""
    return scales.length**2


def scale_contact_area(mean_pressure, previous_area, amplitude, wavelength, material) -> float:
    """Contact area after one more scale, A_i = min(Ā_i η_i A_{i−1}, A_{i−1}) [m^2] (Eq. 22).

    Parameters
    ----------
    mean_pressure : float
        p̄_i = F_n / A_{i−1} [Pa] (Eq. 23).
    previous_area : float
        A_{i−1} [m^2].
    amplitude : float
        Δ_i [m].
    wavelength : float
        λ_i [m].
    material : Material
        The material.

    Returns
    -------
    float
        A_i [m^2]; η_i = f_i² cells per unit area pairs with the per-cell Ā (theory.md §8 #3 [I]),
        and the min is JS assumption (d).
    """
    cells = previous_area / wavelength**2  # η_i A_{i-1}
    cell_area = contact_area_per_cell(mean_pressure, amplitude, wavelength, material)
    return min(cell_area * cells, previous_area)  # Eq. 22


def normal_contact(scales: Scales, load_star, material: Material) -> NormalContact:
    """Real contact area of the stacked scales under a normal load (Eqs. 22–23).

    Parameters
    ----------
    scales : Scales
        The surface's scales (from ``scale_decomposition``).
    load_star : float
        F* = F_n / (A_n S_y) [-].
    material : Material
        The material.

    Returns
    -------
    NormalContact
        Area ratios and pressures per scale, A_n = L² and F_n = F* A_n S_y.
    """
    validate_contact_inputs(scales, load_star)
    area_nominal = nominal_area(scales)
    load = load_star * area_nominal * material.Sy
    area = area_nominal
    areas, pressures = [], []
    scale_pairs = zip(scales.amplitude.tolist(), scales.wavelength.tolist(), strict=True)
    for amplitude, wavelength in scale_pairs:
        pressure = load / area  # Eq. 23
        area = scale_contact_area(pressure, area, amplitude, wavelength, material)
        areas.append(area)
        pressures.append(pressure)
    return NormalContact(
        area_ratio=area / area_nominal,
        area_ratios=np.array(areas) / area_nominal,
        pressures=np.array(pressures),
        nominal_area=area_nominal,
        normal_load=load,
    )
