"""Decomposition of a surface into stacked sinusoid scales (paper Sect. 4.2; theory.md §3).

Scale i has wavelength λ_i = L/i and an equivalent amplitude Δ_i = 2 √V_i, where V_i is the
height variance in the square shell max(|k|, |l|) = i of the two-sided, N²-normalised 2-D
spectrum (Eq. 35* [R]/[I] theory.md §3: Eq. 35 is missing from the paper's text).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from roughfriction.errors import InputError
from roughfriction.geometry.surface import Surface


@dataclass(frozen=True, eq=False)
class Scales:
    """Sinusoid scales of a surface; index 0 is scale i = 1 (the longest wavelength).

    Attributes
    ----------
    wavelength : numpy.ndarray
        λ_i = L/i [m].
    frequency : numpy.ndarray
        f_i = i/L [m^-1].
    amplitude : numpy.ndarray
        Equivalent amplitude Δ_i = 2 √V_i [m].
    variance : numpy.ndarray
        Shell variance V_i [m^2].
    length : float
        Scan length L [m].
    """

    wavelength: np.ndarray
    frequency: np.ndarray
    amplitude: np.ndarray
    variance: np.ndarray
    length: float

    def __post_init__(self):
        for name in ("wavelength", "frequency", "amplitude", "variance"):
            values = np.array(getattr(self, name), dtype=float)  # private, read-only copy
            values.setflags(write=False)
            object.__setattr__(self, name, values)


def shell_variances(heights):
    """Height variance per square shell of the 2-D spectrum, V_s [m^2] (Eq. 35* [R] theory.md §3).

    Parameters
    ----------
    heights : array_like
        Square height map z [m], shape (N, N); its mean is removed first.

    Returns
    -------
    numpy.ndarray
        V_s for shells s = 0 … N//2 [m^2]: the sum of |fft2(z)/N²|² over the modes with
        max(|k|, |l|) = s (signed indices). V_0 = 0 (mean removed); for even N the last shell is
        the Nyquist shell. The shells partition all modes, so ΣV_s = ⟨(z − z̄)²⟩ (Parseval).
    """
    z = np.asarray(heights, dtype=float)
    if z.ndim != 2 or z.shape[0] != z.shape[1]:
        raise InputError(f"heights must be a square 2-D grid, got shape {z.shape}")
    n = z.shape[0]
    power = np.abs(np.fft.fft2(z - z.mean()) / n**2) ** 2
    index = np.abs(np.rint(np.fft.fftfreq(n, d=1.0 / n))).astype(int)  # |k| of each bin
    shell = np.maximum.outer(index, index)
    return np.bincount(shell.ravel(), weights=power.ravel(), minlength=n // 2 + 1)


def scale_decomposition(surface: Surface, *, length=None, i_max=None) -> Scales:
    """Wavelengths and equivalent amplitudes of the scales of a surface (paper Sect. 4.2).

    Parameters
    ----------
    surface : Surface
        The height map [m].
    length : float, optional
        L [m] in λ_i = L/i; default the scan length (N − 1) h, as the paper (theory.md §8 #2). The
        FFT period N h is the alternative.
    i_max : int, optional
        Number of scales; default (N − 1)//2 (N/2 − 1 for even N: the Nyquist shell, whose
        self-conjugate bins would read as twice the amplitude, is excluded; theory.md §8 #10).
        At most N//2.

    Returns
    -------
    Scales
        λ_i = L/i, f_i = i/L, V_i, Δ_i = 2 √V_i for i = 1 … i_max.
    """
    if np.ptp(surface.heights) == 0.0:
        raise InputError(f"surface {surface.name!r} is flat (zero roughness): nothing to decompose")
    scan_length = surface.scan_length if length is None else float(length)
    if not (np.isfinite(scan_length) and scan_length > 0):
        raise InputError(f"scan length must be a finite number > 0 m, got {length}")
    n_shells = surface.n // 2
    count = (surface.n - 1) // 2 if i_max is None else int(i_max)
    if not 1 <= count <= n_shells:
        raise InputError(
            f"i_max must lie in 1 … {n_shells} for a {surface.n}-point grid, got {i_max}"
        )
    index = np.arange(1, count + 1)
    variance = shell_variances(surface.heights)[1 : count + 1]
    return Scales(
        wavelength=scan_length / index,
        frequency=index / scan_length,
        amplitude=2.0 * np.sqrt(variance),  # Eq. 35* [R] theory.md §3
        variance=variance,
        length=scan_length,
    )
