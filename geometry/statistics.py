"""Spectral moments, summit statistics and the plasticity index (paper Eqs. 11-18, 21).

The discrete scheme (forward differences along x, h = L / (N - 1)) is the one that reproduces the
paper's Table 1 (docs/theory.md §2).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from roughfriction.errors import InputError
from roughfriction.geometry.surface import Surface
from roughfriction.material import Material

# McCool's summit-height coefficient in Eq. 12 [-]; Eq. 12 needs alpha above it.
SUMMIT_BANDWIDTH_LIMIT = 0.8968


def _finite_heights(heights) -> np.ndarray:
    """Heights as a float array; raise InputError when any is NaN/inf."""
    z = np.asarray(heights, dtype=float)
    if z.size == 0 or not np.all(np.isfinite(z)):
        raise InputError("heights must be a non-empty array of finite numbers (fill NaN/inf first)")
    return z


def rms_height(heights) -> float:
    """Root-mean-square height about the mean, R_q (Eq. 21).

    Parameters
    ----------
    heights : array_like
        Heights z [m], any shape, all finite.

    Returns
    -------
    float
        R_q = sqrt(mean((z - mean z)^2)) [m].
    """
    z = _finite_heights(heights)
    return float(np.sqrt(np.mean((z - z.mean()) ** 2)))  # Eq. 21


def spectral_moments(heights, spacing: float, *, axis: int = 0) -> tuple[float, float, float]:
    """Profile spectral moments m0, m2, m4 from finite differences (Eqs. 15-17).

    Forward differences along ``axis`` of every profile, squared and averaged over all profiles:
    ``m2 = mean((diff(z, 1, axis) / h)^2)``, ``m4 = mean((diff(z, 2, axis) / h^2)^2)``. The
    default axis 0 is x (``heights[i, j]`` lies at x = i h), i.e. profiles along x; this equals
    MATLAB's ``diff(Z, 1, 2) / h`` and ``diff(Z, 2, 2) / h^2`` on ``Z = heights.'`` (MATLAB's
    meshgrid layout, rows = y). h is the grid spacing L / (N - 1), 1 um for the paper's 128 points
    over 127 um. For isotropic surfaces the axis does not matter in expectation.

    Parameters
    ----------
    heights : array_like
        Heights z [m], shape (N, M), all finite; the mean is removed first.
    spacing : float
        Grid spacing h [m].
    axis : int, optional
        Direction of the profiles (0 = x, 1 = y).

    Returns
    -------
    tuple of float
        m0 [m^2] (height variance), m2 [-] (mean-square slope), m4 [m^-2] (mean-square
        curvature).
    """
    z = _finite_heights(heights)
    if z.ndim != 2 or min(z.shape) < 3:
        raise InputError(f"spectral moments need a 2-D grid of at least 3 x 3, got {z.shape}")
    if not (np.isfinite(spacing) and spacing > 0):
        raise InputError(f"grid spacing must be > 0, got {spacing}")
    z = z - z.mean()
    m0 = np.mean(z**2)  # Eq. 15
    m2 = np.mean((np.diff(z, 1, axis=axis) / spacing) ** 2)  # Eq. 16
    m4 = np.mean((np.diff(z, 2, axis=axis) / spacing**2) ** 2)  # Eq. 17
    return float(m0), float(m2), float(m4)


def bandwidth_parameter(m0: float, m2: float, m4: float) -> float:
    """Nayak's bandwidth parameter alpha = m0 m4 / m2^2 [-] (Eq. 14).

    Parameters
    ----------
    m0, m2, m4 : float
        Spectral moments [m^2], [-], [m^-2].
    """
    if not m2 > 0:
        raise InputError(f"mean-square slope m2 = {m2} must be > 0 (the surface is flat)")
    return m0 * m4 / m2**2  # Eq. 14


def summit_height_std(m0: float, alpha: float) -> float:
    """Standard deviation of summit heights, sigma_s (Eq. 12, McCool).

    Parameters
    ----------
    m0 : float
        Height variance [m^2].
    alpha : float
        Bandwidth parameter [-], > 0.8968.

    Returns
    -------
    float
        sigma_s = (1 - 0.8968 / alpha)^(1/2) m0^(1/2) [m].
    """
    if not alpha > SUMMIT_BANDWIDTH_LIMIT:
        raise InputError(
            f"bandwidth parameter alpha = {alpha:.4g} must exceed {SUMMIT_BANDWIDTH_LIMIT} "
            "for the summit-height std (Eq. 12); the surface is too narrow-band"
        )
    return math.sqrt((1.0 - SUMMIT_BANDWIDTH_LIMIT / alpha) * m0)  # Eq. 12


def summit_radius(m4: float) -> float:
    """Mean summit radius of curvature, R = 0.375 (pi / m4)^(1/2) [m] (Eq. 18).

    Parameters
    ----------
    m4 : float
        Mean-square curvature [m^-2], > 0.
    """
    if not m4 > 0:
        raise InputError(f"mean-square curvature m4 = {m4} must be > 0 (the surface is flat)")
    return 0.375 * math.sqrt(math.pi / m4)  # Eq. 18


def plasticity_index(sigma_s: float, R: float, material: Material) -> float:
    """Plasticity index psi = 2 E' / (pi C S_y) (sigma_s / R)^(1/2) [-] (Eq. 11).

    Parameters
    ----------
    sigma_s : float
        Summit-height standard deviation [m].
    R : float
        Summit radius [m].
    material : Material
        Supplies E' [Pa], C(nu) [-] (Eq. 13) and S_y [Pa].
    """
    return 2.0 * material.E_star / (math.pi * material.C * material.Sy) * math.sqrt(sigma_s / R)


@dataclass(frozen=True)
class SurfaceStatistics:
    """Roughness statistics of a surface (SI units).

    Attributes
    ----------
    rq : float
        RMS height [m] (Eq. 21).
    m0, m2, m4 : float
        Spectral moments [m^2], [-], [m^-2] (Eqs. 15-17).
    alpha : float
        Bandwidth parameter [-] (Eq. 14).
    sigma_s : float
        Summit-height standard deviation [m] (Eq. 12).
    R : float
        Summit radius [m] (Eq. 18).
    psi : float
        Plasticity index [-] (Eq. 11).
    """

    rq: float
    m0: float
    m2: float
    m4: float
    alpha: float
    sigma_s: float
    R: float
    psi: float

    def as_dict(self) -> dict[str, float]:
        """The fields as a plain dict of floats (for JSON results)."""
        return dataclasses.asdict(self)


def surface_statistics(surface: Surface, material: Material) -> SurfaceStatistics:
    """All statistics of Eqs. 11-18 and 21 for a surface, with the paper's discrete scheme.

    Parameters
    ----------
    surface : Surface
        Heights [m] and spacing h [m].
    material : Material
        The material for the plasticity index.

    Returns
    -------
    SurfaceStatistics
    """
    z = surface.heights
    rq = rms_height(z)
    if not rq > 1e-12 * np.max(np.abs(z)):
        raise InputError(f"surface {surface.name!r} has zero roughness (RMS height {rq:.3g} m)")
    m0, m2, m4 = spectral_moments(z, surface.spacing)
    alpha = bandwidth_parameter(m0, m2, m4)
    sigma_s = summit_height_std(m0, alpha)
    R = summit_radius(m4)
    return SurfaceStatistics(
        rq=rq,
        m0=m0,
        m2=m2,
        m4=m4,
        alpha=alpha,
        sigma_s=sigma_s,
        R=R,
        psi=plasticity_index(sigma_s, R, material),
    )
