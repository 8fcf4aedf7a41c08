"""Rough surfaces as height maps on a square grid: the ``Surface`` type and grid operations.

Operations on height arrays (detrend, fill, crop, periodic closure) work on plain NumPy arrays
[m], NaN marking missing points; re-gridding (``resample``, ``spectral_interpolate``) maps a
``Surface`` to a new ``Surface``.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np
from roughfriction.errors import InputError
from scipy import interpolate, ndimage

#: Fewest grid points per side of a surface [-].
MIN_GRID_POINTS = 4


@dataclass(frozen=True, eq=False)
class Surface:
    """A height map on a square, uniformly spaced grid.

    Parameters
    ----------
    heights : numpy.ndarray
        Heights z [m], shape (n, n); ``heights[i, j]`` lies at x = i * spacing, y = j * spacing
        (axis 0 is x).
    spacing : float
        Grid spacing h [m], the same in x and y.
    name : str
        A label for plots and results (a built-in name or the file it was read from).
    """

    heights: np.ndarray
    spacing: float
    name: str = ""

    def __post_init__(self):
        z = np.array(self.heights, dtype=float)  # private copy: the surface is immutable
        if z.ndim != 2:
            raise InputError(f"surface {self.name!r}: heights must be a 2-D grid, got {z.ndim}-D")
        if z.shape[0] != z.shape[1]:
            raise InputError(
                f"surface {self.name!r}: grid is {z.shape[0]} x {z.shape[1]}, not square "
                "(crop it to a square first: crop_square, or --crop on the command line)"
            )
        if z.shape[0] < MIN_GRID_POINTS:
            raise InputError(f"surface {self.name!r}: a {z.shape[0]} x {z.shape[1]} grid is too "
                             f"small (at least {MIN_GRID_POINTS} x {MIN_GRID_POINTS} points)")
        n_bad = int(np.count_nonzero(~np.isfinite(z)))
        if n_bad:
            raise InputError(
                f"surface {self.name!r}: {n_bad} missing (NaN/inf) heights; fill them first "
                "(fill_missing, or --fill on the command line)"
            )
        if not (np.isfinite(self.spacing) and self.spacing > 0):
            raise InputError(f"surface {self.name!r}: grid spacing must be > 0, got {self.spacing}")
        z.setflags(write=False)
        object.__setattr__(self, "heights", z)
        object.__setattr__(self, "spacing", float(self.spacing))

    @property
    def n(self) -> int:
        """Number of grid points per side [-]."""
        return self.heights.shape[0]

    @property
    def scan_length(self) -> float:
        """Scan length from the first to the last point, L = (n - 1) h [m] (the paper's L)."""
        return (self.n - 1) * self.spacing

    @property
    def period(self) -> float:
        """Period of the periodically closed surface, n h [m] (the FEM block's side)."""
        return self.n * self.spacing

    @property
    def rms_slope(self) -> float:
        """RMS slope sqrt(m2_x + m2_y) from forward differences along x and y [-] (Eq. 16)."""
        z = self.heights
        mean_square = np.mean(np.diff(z, axis=0) ** 2) + np.mean(np.diff(z, axis=1) ** 2)
        return float(np.sqrt(mean_square)) / self.spacing

    def digest(self) -> str:
        """SHA-256 of the heights and spacing: keys caches of results computed from this surface."""
        h = hashlib.sha256()
        h.update(np.ascontiguousarray(self.heights, dtype="<f8").tobytes())
        h.update(np.float64(self.spacing).tobytes())
        return h.hexdigest()


# --- operations on height arrays ------------------------------------------------------------


def _as_grid(heights) -> np.ndarray:
    """Return ``heights`` as a float 2-D array; raise InputError for any other shape."""
    z = np.asarray(heights, dtype=float)
    if z.ndim != 2:
        raise InputError(f"heights must be a 2-D grid, got a {z.ndim}-D array of shape {z.shape}")
    return z


def _least_squares_plane(heights: np.ndarray) -> np.ndarray:
    """Least-squares plane through the finite points of ``heights``, evaluated on the whole grid.

    Parameters
    ----------
    heights : numpy.ndarray
        Heights [any length unit], shape (m, k); NaN/inf mark missing points.

    Returns
    -------
    numpy.ndarray
        Plane a + b i + c j [same unit], shape (m, k), fitted on grid indices i, j (a plane in
        index space is a plane in physical space, so the spacing is not needed).
    """
    z = _as_grid(heights)
    measured = np.isfinite(z)
    if np.count_nonzero(measured) < 3:
        raise InputError(f"a plane needs at least 3 measured heights, got {measured.sum()}")
    i, j = np.indices(z.shape, dtype=float)
    i -= i.mean()  # centred coordinates keep the normal equations well conditioned
    j -= j.mean()
    design = np.column_stack([np.ones(measured.sum()), i[measured], j[measured]])
    coefficients, *_ = np.linalg.lstsq(design, z[measured], rcond=None)
    return coefficients[0] + coefficients[1] * i + coefficients[2] * j


def detrend_plane(heights) -> np.ndarray:
    """Remove the least-squares plane (fitted on the finite points; missing points stay missing).

    Parameters
    ----------
    heights : array_like
        Heights [m], shape (m, k); NaN/inf mark missing points.

    Returns
    -------
    numpy.ndarray
        Heights minus the plane [m], shape (m, k); their mean over the finite points is zero.
    """
    z = _as_grid(heights)
    return z - _least_squares_plane(z)


def fill_missing(heights, method: str) -> np.ndarray:
    """Replace missing (NaN/inf) heights.

    Parameters
    ----------
    heights : array_like
        Heights [m], shape (m, k), with at least one finite point (three for ``"plane"``).
    method : {"nearest", "plane"}
        ``"nearest"``: the nearest measured height (Euclidean distance on the grid, ties broken
        by ``scipy.ndimage.distance_transform_edt``); ``"plane"``: the least-squares plane
        through the measured points evaluated there.

    Returns
    -------
    numpy.ndarray
        Heights [m] with every point finite; measured points are unchanged.
    """
    z = _as_grid(heights)
    missing = ~np.isfinite(z)
    if method == "nearest":
        if missing.all():
            raise InputError("cannot fill: no height is measured")
        nearest = ndimage.distance_transform_edt(
            missing, return_distances=False, return_indices=True
        )
        return z[tuple(nearest)]
    if method == "plane":
        return np.where(missing, _least_squares_plane(z), z)
    raise InputError(f"unknown fill method {method!r}: use 'nearest' or 'plane'")


def crop_square(heights) -> np.ndarray:
    """The largest centred square of a rectangular grid.

    Parameters
    ----------
    heights : array_like
        Heights [m], shape (m, k).

    Returns
    -------
    numpy.ndarray
        Heights [m], shape (s, s) with s = min(m, k); the excess is cut equally from both ends
        of the longer axis (one more point from the end when the excess is odd).
    """
    z = _as_grid(heights)
    side = min(z.shape)
    start_x = (z.shape[0] - side) // 2
    start_y = (z.shape[1] - side) // 2
    return z[start_x : start_x + side, start_y : start_y + side].copy()


def resample(surface: Surface, n: int) -> Surface:
    """Re-grid a surface to n x n points over the same scan length.

    Uses the bicubic interpolating spline ``scipy.interpolate.RectBivariateSpline`` (k = 3,
    s = 0; FITPACK's not-a-knot-type knots), which passes through the old points and is exact
    for polynomials up to degree 3 in each direction (so a linear ramp is kept exactly). It does
    not assume periodicity; see :func:`spectral_interpolate` for the periodic alternative.

    Parameters
    ----------
    surface : Surface
        The surface (scan length L = (n_old - 1) h [m]).
    n : int
        New number of points per side [-], >= 4.

    Returns
    -------
    Surface
        n x n heights [m] with spacing L / (n - 1) [m], same name.
    """
    n = validate_grid_points(n)
    old = np.arange(surface.n) * surface.spacing
    new = np.linspace(0.0, surface.scan_length, n)
    spline = interpolate.RectBivariateSpline(old, old, surface.heights, kx=3, ky=3, s=0)
    return Surface(spline(new, new), surface.scan_length / (n - 1), surface.name)


def _pad_spectrum(spectrum: np.ndarray, n_new: int, axis: int) -> np.ndarray:
    """Zero-pad a discrete Fourier spectrum along one axis from n_old to n_new >= n_old bins.

    Non-negative frequencies stay at the front, negative ones move to the back, and for even
    n_old the Nyquist bin is split into two equal halves at +n_old/2 and -n_old/2, which keeps the
    spectrum Hermitian (real field) and the interpolant the band-limited cosine.
    """
    spectrum = np.moveaxis(spectrum, axis, 0)
    n_old = spectrum.shape[0]
    n_nonnegative = (n_old + 1) // 2  # bins 0 .. below Nyquist
    n_negative = (n_old - 1) // 2
    padded = np.zeros((n_new,) + spectrum.shape[1:], dtype=complex)
    padded[:n_nonnegative] = spectrum[:n_nonnegative]
    padded[n_new - n_negative :] = spectrum[n_old - n_negative :]
    if n_old % 2 == 0:
        nyquist = spectrum[n_old // 2] / 2
        padded[n_old // 2] += nyquist
        padded[n_new - n_old // 2] += nyquist
    return np.moveaxis(padded, 0, axis)


def spectral_interpolate(surface: Surface, n: int) -> Surface:
    """Fourier (zero-padding) interpolation onto a finer periodic grid.

    The surface is treated as one period of a periodic function, period P = n_old h [m]; the
    result samples the band-limited trigonometric interpolant at spacing P / n. When n is a
    multiple of n_old the old points are reproduced exactly (to rounding). A non-periodic surface
    rings near its edges (Gibbs): detrend it first.

    Parameters
    ----------
    surface : Surface
        The surface, n_old x n_old heights [m].
    n : int
        New number of points per side [-], n >= n_old.

    Returns
    -------
    Surface
        n x n heights [m] with spacing n_old h / n [m], same name.
    """
    n = validate_grid_points(n)
    if n < surface.n:
        raise InputError(
            f"spectral interpolation refines a grid: n = {n} < {surface.n}; use resample to coarsen"
        )
    spectrum = np.fft.fft2(surface.heights)
    padded = _pad_spectrum(_pad_spectrum(spectrum, n, axis=0), n, axis=1)
    heights = np.fft.ifft2(padded).real * (n / surface.n) ** 2
    return Surface(heights, surface.period / n, surface.name)


def surface_on_fem_grid(surface: Surface, n: int | None) -> Surface:
    """The surface on N x N points: as is, resampled (coarser) or Fourier-interpolated (finer)."""
    if n is None or n == surface.n:
        return surface
    if n < 4:
        raise InputError(f"the FEM grid needs >= 4 surface cells per side, got {n}")
    return resample(surface, n) if n < surface.n else spectral_interpolate(surface, n)


def windows(surface: Surface, n: int) -> list[Surface]:
    """The non-overlapping n x n windows of a surface at its own spacing, row by row.

    A window keeps the surface's spacing, so for i.i.d. heights it has the surface's slopes and
    psi; re-gridding to n points (``resample``) would be a smoother surface instead. A window is
    not periodic: the FEM closes it periodically like any measured map.
    """
    n = validate_grid_points(n)
    per_side = surface.n // n
    if per_side < 1:
        raise InputError(f"surface {surface.name!r} has {surface.n} points per side: no "
                         f"{n} x {n} window")
    z = surface.heights
    return [Surface(z[i * n:(i + 1) * n, j * n:(j + 1) * n], surface.spacing, surface.name)
            for i in range(per_side) for j in range(per_side)]


def validate_grid_points(n) -> int:
    """Return ``n`` as an int after checking it is a number of points per side (integer >= 4)."""
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 4:
        raise InputError(f"number of grid points per side must be an integer >= 4, got {n!r}")
    return int(n)


def bilinear_refine(heights, factor: int) -> np.ndarray:
    """The periodic bilinear interpolant of a height grid, sampled ``factor`` times finer.

    The FEM resolves a surface as the bilinear interpolant through its grid points (the top
    faces of its hexahedra); sampling that interpolant on a finer grid gives a finer mesh of the
    same surface. Points (i, j) of the result lie at x = i h / factor, y = j h / factor.

    Parameters
    ----------
    heights : numpy.ndarray
        Heights [m], shape (n, n), one period of a periodic surface.
    factor : int
        Refinement factor [-], >= 1.

    Returns
    -------
    numpy.ndarray
        Heights [m], shape (factor n, factor n); every factor-th point is an original one.
    """
    z = _as_grid(heights)
    if isinstance(factor, bool) or not isinstance(factor, int | np.integer) or factor < 1:
        raise InputError(f"refinement factor must be an integer >= 1, got {factor!r}")
    t = np.arange(factor) / factor  # position inside a cell [-]
    for axis in (0, 1):
        following = np.roll(z, -1, axis=axis)
        shape = [1, 1, 1]
        shape[axis + 1] = factor
        # insert factor points per cell along the axis: (1 - t) z_i + t z_{i+1}
        expanded = (np.expand_dims(z, axis + 1) * (1.0 - t).reshape(shape)
                    + np.expand_dims(following, axis + 1) * t.reshape(shape))
        new_shape = list(z.shape)
        new_shape[axis] *= factor
        z = expanded.reshape(new_shape)
    return z


def bilinear_rms_height(heights) -> float:
    """RMS height about the mean of the periodic bilinear interpolant of a height grid, the
    surface the FEM meshes [m]: the same for every :func:`bilinear_refine` of it (lower than
    the grid points' R_q where neighbouring heights differ).

    With the 1D element integrals 1/3 (a node with itself) and 1/6 (with its neighbour), the
    mean square of the interpolant is the mean over nodes of 4/9 z^2 + 2/9 z (z_x + z_y)
    + 1/18 (z z_xy + z_x z_y), z_x, z_y, z_xy the heights one node on in x, y and both.

    Parameters
    ----------
    heights : numpy.ndarray
        Heights [m], shape (n, n), one period of a periodic surface.
    """
    z = _as_grid(heights)
    z = z - z.mean()  # the interpolant's mean is the nodes' mean
    z_x, z_y = np.roll(z, -1, axis=0), np.roll(z, -1, axis=1)
    z_xy = np.roll(z_x, -1, axis=1)
    mean_square = np.mean(4 / 9 * z**2 + 2 / 9 * z * (z_x + z_y) + 1 / 18 * (z * z_xy + z_x * z_y))
    return float(np.sqrt(mean_square))
