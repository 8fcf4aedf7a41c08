"""Rough surfaces as height maps on a square grid: the ``Surface`` type."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

from geometry.errors import InputError


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
                "(crop it to a square first, e.g. the reader's square='crop')"
            )
        if z.shape[0] < 4:
            raise InputError(f"surface {self.name!r}: grid {z.shape} is too small (>= 4 x 4)")
        n_bad = int(np.count_nonzero(~np.isfinite(z)))
        if n_bad:
            raise InputError(
                f"surface {self.name!r}: {n_bad} missing (NaN/inf) heights; "
                "fill them explicitly (fill='nearest' or 'plane')"
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

    def digest(self) -> str:
        """SHA-256 of the heights and spacing: keys caches of results computed from this surface."""
        h = hashlib.sha256()
        h.update(np.ascontiguousarray(self.heights, dtype="<f8").tobytes())
        h.update(np.float64(self.spacing).tobytes())
        return h.hexdigest()
