"""An independent peer for elastic frictionless rough contact: tamaas's FFT boundary elements.

tamaas (Frérot, Anciaux, Rey & Molinari) solves the normal contact of a periodic surface with a
rigid flat on an elastic half-space by the Polonsky-Keer conjugate gradient with the
Westergaard (FFT) influence functions. Its contact area is a pixel count, first order in the
pixel size, so the peer's answer for a surface is its area extrapolated to zero pixel size on
the bilinear interpolant of the surface (the surface the FEM resolves) sampled finer and finer.
tamaas is a development dependency (``pip install tamaas``), imported where it is used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from roughfriction.geometry.surface import bilinear_refine
from roughfriction.studies.refinement import ErrorEstimate, richardson

#: Relative tolerance of the Polonsky-Keer iterations [-].
BEM_TOLERANCE = 1e-12
#: Refinement factors of the bilinear surface for the zero-pixel limit [-].
LIMIT_FACTORS = (4, 8, 16)


@dataclass(frozen=True)
class BemContact:
    """Elastic frictionless contact of a periodic surface with a rigid flat (tamaas).

    Attributes
    ----------
    area_ratio : float
        Pixels with positive pressure over all pixels [-].
    pressure : numpy.ndarray
        Contact pressure [Pa], shape (n, n).
    contact : numpy.ndarray
        Pixels in contact, bool, shape (n, n).
    """

    area_ratio: float
    pressure: np.ndarray
    contact: np.ndarray


def bem_contact(heights: np.ndarray, spacing: float, e_star: float,
                mean_pressure: float) -> BemContact:
    """Normal contact of a rigid flat with the elastic half-space under ``heights``.

    Parameters
    ----------
    heights : numpy.ndarray
        One period of the surface [m], shape (n, n), [i, j] at x = i h, y = j h.
    spacing : float
        Grid spacing h [m].
    e_star : float
        E' = E / (1 - nu^2) [Pa].
    mean_pressure : float
        Nominal pressure F_n / A_n [Pa].
    """
    import tamaas

    tamaas.set_log_level(tamaas.LogLevel.error)
    n = heights.shape[0]
    model = tamaas.Model(tamaas.model_type.basic_2d, [n * spacing, n * spacing], [n, n])
    model.E, model.nu = e_star, 0.0  # tamaas's E' is E / (1 - nu^2)
    surface = np.ascontiguousarray(heights - heights.max())
    tamaas.PolonskyKeerRey(model, surface, BEM_TOLERANCE).solve(mean_pressure)
    pressure = np.array(model.traction).reshape(n, n)
    contact = pressure > 0.0
    return BemContact(float(contact.mean()), pressure, contact)


def bem_area_limit(heights: np.ndarray, spacing: float, e_star: float, mean_pressure: float,
                   factors=LIMIT_FACTORS) -> ErrorEstimate:
    """The BEM contact area of the bilinear surface extrapolated to zero pixel size.

    The pixel areas on the surface sampled ``factors`` times finer (three factors, each twice
    the last) give the observed order and the Richardson limit (``studies.refinement``).

    Returns
    -------
    ErrorEstimate
        ``values`` the pixel areas [-], ``extrapolated`` the limit A/A_n [-], ``error`` the
        estimated error of the finest pixel area.
    """
    areas = [bem_contact(bilinear_refine(heights, factor), spacing / factor, e_star,
                         mean_pressure).area_ratio for factor in factors]
    return richardson(areas)


#: Perimeter correction of a pixel count, (pi - 1 + ln 2) / 24 [-] (Yastrebov, Anciaux &
#: Molinari, Tribol. Int. 2017).
PERIMETER_COEFFICIENT = (math.pi - 1.0 + math.log(2.0)) / 24.0


def perimeter_corrected_area(contact: np.ndarray) -> float:
    """A / A_n = (pixels in contact - c M) / pixels, with M the contact/no-contact switches along
    the rows and columns of the periodic grid and c = ``PERIMETER_COEFFICIENT`` [-]."""
    contact = np.asarray(contact, dtype=bool)
    switches = sum(int(np.count_nonzero(contact != np.roll(contact, 1, axis=axis)))
                   for axis in (0, 1))
    return (int(np.count_nonzero(contact)) - PERIMETER_COEFFICIENT * switches) / contact.size
