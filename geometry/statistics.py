"""Spectral moments, summit statistics and the plasticity index (paper Eqs. 11-18, 21), and the
checks of a surface against the FEM's assumptions (periodic closure, small slopes).

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
# Largest periodic seam ratio [-] (:func:`periodic_seam_ratio`) closed without a warning. For
# i.i.d. heights the seam is an ordinary step (ratio 1, at most 1.7 over the 8 x 8 windows of
# G1-G9); 3 is an RMS jump no sample of ordinary steps reaches, while measured scans and their
# windows, whose long wavelengths do not close, reach 3 to 20.
MAX_SEAM_RATIO = 3.0
# Largest RMS slope [-] of the small-strain FEM without a warning: its kinematics and the
# vertical approach of the rigid flat drop terms of order |grad z|^2 / 2 (the true over the
# projected area, the tilt of the contact normals), 4.5 % at 0.3.
SMALL_STRAIN_MAX_SLOPE = 0.3


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


def _seam_and_inner_steps(heights) -> tuple[np.ndarray, np.ndarray]:
    """Height jumps [m] across the periodic seam (first row minus last, first column minus last)
    and the differences [m] between neighbours inside the grid, along x and y."""
    z = _finite_heights(heights)
    if z.ndim != 2 or min(z.shape) < 2:
        raise InputError(f"the periodic seam needs a 2-D grid of at least 2 x 2, got {z.shape}")
    jumps = np.concatenate([z[0] - z[-1], z[:, 0] - z[:, -1]])
    steps = np.concatenate([np.diff(z, axis=0).ravel(), np.diff(z, axis=1).ravel()])
    return jumps, steps


def _rms(values: np.ndarray) -> float:
    """Root mean square of ``values``."""
    return float(np.sqrt(np.mean(values**2)))


def periodic_seam_ratio(heights) -> float:
    """RMS height jump across the periodic seam over the RMS step between neighbours inside.

    The FEM closes a surface periodically (``solver.periodic``): its last row and column
    become neighbours of its first. The ratio is about 1 for a periodic or
    i.i.d. surface and large where the closure adds a step the surface does not have.

    Parameters
    ----------
    heights : array_like
        Heights [m], shape (n, m), all finite, not all equal.

    Returns
    -------
    float
        RMS of the n + m seam jumps over RMS of the 2 n m - n - m inner forward differences [-].
    """
    jumps, steps = _seam_and_inner_steps(heights)
    if not _rms(steps) > 0:
        raise InputError("the periodic seam of a flat surface has no scale (all heights equal)")
    return _rms(jumps) / _rms(steps)


def periodic_seam_warning(surface: Surface) -> str | None:
    """A one-line warning when the periodic seam of ``surface`` is a step of its own.

    Parameters
    ----------
    surface : Surface
        The surface the FEM closes periodically (e.g. a window of a measured scan).

    Returns
    -------
    str or None
        The seam's RMS and largest jump [m] against the RMS inner step [m], when
        :func:`periodic_seam_ratio` exceeds ``MAX_SEAM_RATIO``; else None.
    """
    ratio = periodic_seam_ratio(surface.heights)
    if ratio <= MAX_SEAM_RATIO:
        return None
    jumps, steps = _seam_and_inner_steps(surface.heights)
    return (f"{surface.name or 'surface'}: its periodic seam (last row and column against the "
            f"first) jumps by {_rms(jumps):.2g} m RMS, {np.max(np.abs(jumps)):.2g} m at most, "
            f"{ratio:.2g} x the RMS step {_rms(steps):.2g} m between neighbours (above "
            f"{MAX_SEAM_RATIO:g}): the FEM closes the surface periodically, so contact can sit "
            "on this seam; another window may close better")


def small_strain_slope(surface: Surface) -> tuple[float, str | None]:
    """The RMS slope of a surface, and a warning when it is beyond the small-strain FEM.

    Small-strain kinematics and a rigid flat approaching along z assume small surface
    gradients (the small-slope assumption of Johnson, Contact Mechanics, 1985, ch. 4): the
    neglected terms are of order |grad z|^2 / 2, 4.5 % of the contact area and normal at an RMS
    slope of ``SMALL_STRAIN_MAX_SLOPE`` = 0.3, 11 % at 0.47.

    Parameters
    ----------
    surface : Surface
        Heights [m] and spacing [m].

    Returns
    -------
    tuple
        ``Surface.rms_slope`` [-], and a one-line warning if it exceeds
        ``SMALL_STRAIN_MAX_SLOPE`` (else None).
    """
    slope = surface.rms_slope
    if slope <= SMALL_STRAIN_MAX_SLOPE:
        return slope, None
    return slope, (f"{surface.name or 'surface'}: RMS slope {slope:.2g} > "
                   f"{SMALL_STRAIN_MAX_SLOPE:g}, beyond the small-strain FEM: terms of order "
                   f"slope^2 / 2 = {slope**2 / 2:.0%} of the contact area and normal are "
                   "neglected")
