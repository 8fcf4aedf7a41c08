"""What every format shares once its reader has the raw heights: bare height grids scaled by
the scan length, square pixels and grids, missing points, the plausibility of the RMS heights
and slopes (a unit slip), the one-line message listing every problem, and the pipeline
:func:`surface_from_raw` that turns a file's :class:`RawHeights` into a ``Surface``."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
from roughfriction.errors import InputError
from roughfriction.geometry.readers.options import ReaderOptions
from roughfriction.geometry.readers.reader import RawHeights, UnitSource
from roughfriction.geometry.readers.units import length_unit_scale, size_in_metres
from roughfriction.geometry.surface import (
    MIN_GRID_POINTS,
    Surface,
    crop_square,
    detrend_plane,
    fill_missing,
)

# Largest RMS slope [-] accepted from a file unless its height unit is given; the shipped samples
# have 0.003 to 0.8 (the built-in 63M, never read from a file, 1.18), and heights in a wrong unit
# (um read as m) 1e3 and more.
MAX_RMS_SLOPE = 1.0
# Smallest RMS slope [-] accepted from a file unless ``allow_flat``: 30 x below the flattest
# shipped sample (sur-2, 0.003; G1 has 0.02), above it a smooth scan on coarse pixels (2.5 nm RMS
# on 5 um, 2e-4); a factor-1000 slip (mm for um) takes any surface whose true RMS slope is below
# 0.1 under it.
MIN_RMS_SLOPE = 1e-4
# Range of RMS heights [m] (about the least-squares plane) of a measured metal surface: below
# 0.1 nm is less than one atomic step, above 1 mm a form rather than a roughness; the shipped
# samples have 6.6 nm to 11.6 um, the built-in surfaces 10 nm to 2 um. No escape: outside it
# the heights are in another unit than assumed.
MIN_RMS_HEIGHT = 1e-10
MAX_RMS_HEIGHT = 1e-3
# The fix named for implausible units of an instrument file, which carries its own.
INSTRUMENT_UNITS_FIX = "check the file's units (an instrument file carries its own)"


# --- bare height grids (npy, text matrix) -------------------------------------------------------


def _grid_units(fmt: str, options: ReaderOptions) -> UnitSource:
    """The :class:`UnitSource` of a bare grid: heights in ``height_unit`` (default m), pixels
    from ``size``."""
    height = (f"{options.height_unit} (given)" if options.height_unit
              else f"m (the {fmt} default)")
    size = options.size
    length = size if isinstance(size, str) else f"{size:g}m"
    return UnitSource(height, f"pixels from --size {length}", "--height-unit", "--size",
                      bool(options.height_unit))


def grid_heights(path: Path, raw: np.ndarray, fmt: str, options: ReaderOptions) -> RawHeights:
    """Heights [m] and x, y spacings [m] (equal) of a bare height array, row index = x:
    heights in ``options.height_unit`` (needed for a matrix, default m otherwise), spacing
    ``options.size`` / (n_x - 1)."""
    if options.size is None:
        raise InputError(
            f"{path.name}: a {fmt} file has no lateral scale; give the scan length from "
            "first to last point with --size, e.g. --size 127um"
        )
    if fmt == "matrix" and options.height_unit is None:
        raise InputError(
            f"{path.name}: a height matrix has no unit; give it with --height-unit, e.g. um"
        )
    if raw.ndim != 2:
        raise InputError(f"{path.name}: holds a {raw.ndim}-D array of shape {raw.shape}, not a "
                         "2-D height map (rows along x, columns along y)")
    if min(raw.shape) < MIN_GRID_POINTS:
        raise InputError(f"{path.name}: a {raw.shape[0]} x {raw.shape[1]} grid is too small for "
                         f"a height map (at least {MIN_GRID_POINTS} x {MIN_GRID_POINTS} points)")
    heights = raw.astype(float) * length_unit_scale(options.height_unit or "m")
    spacing = size_in_metres(options.size) / (raw.shape[0] - 1)
    return RawHeights(heights, spacing, spacing, _grid_units(fmt, options))


# --- square pixels ------------------------------------------------------------------------------


def _resample_axis(heights: np.ndarray, step: float, new_step: float, axis: int) -> np.ndarray:
    """Linear interpolation along one axis from pixels of ``step`` [m] to ``new_step`` [m].

    Pixels are areas: old pixel i is centred at (i + 1/2) ``step``, new pixel k at
    (k + 1/2) ``new_step``, and n ``step`` / ``new_step`` (rounded) new ones cover the same
    length. New centres outside the outer old ones (less than half a pixel) take the edge value;
    a zero weight never picks up a neighbour's NaN.
    """
    n = heights.shape[axis]
    n_new = max(2, round(n * step / new_step))
    t = np.clip((np.arange(n_new) + 0.5) * (new_step / step) - 0.5, 0.0, n - 1)
    left = np.minimum(np.floor(t).astype(int), n - 2)
    weight = np.expand_dims(t - left, 1 - axis)
    z0, z1 = np.take(heights, left, axis=axis), np.take(heights, left + 1, axis=axis)
    return np.where(weight == 0, z0, np.where(weight == 1, z1, (1 - weight) * z0 + weight * z1))


def square_pixels(heights, dx: float, dy: float) -> tuple[np.ndarray, float]:
    """Bilinear resampling onto square pixels of side min(dx, dy), same physical size.

    Parameters
    ----------
    heights : array_like
        Heights [m], shape (n_x, n_y), NaN where missing (it spreads to the new pixels next to it).
    dx, dy : float
        Pixel sizes [m] along x (axis 0) and y.

    Returns
    -------
    tuple
        Heights [m], shape (round(n_x dx / h), round(n_y dy / h)), and h = min(dx, dy) [m].
    """
    z = np.asarray(heights, dtype=float)
    if z.ndim != 2 or min(z.shape) < 2:
        raise InputError(f"resampling needs a 2-D grid of at least 2 x 2, got shape {z.shape}")
    h = min(dx, dy)
    return _resample_axis(_resample_axis(z, dx, h, 0), dy, h, 1), h


def _pixels_are_square(dx: float, dy: float) -> bool:
    """Whether pixels of dx x dy [m] are square (to 0.1 %)."""
    return abs(dx - dy) <= 1e-3 * min(dx, dy)


def _on_square_pixels(heights: np.ndarray, dx: float, dy: float,
                      pixels: str | None) -> tuple[np.ndarray, float, list[str]]:
    """Heights [m] and spacing [m] on square pixels (resampled when they are not), and the
    problem if they are not and resampling was not asked for."""
    if _pixels_are_square(dx, dy):
        return heights, dx, []
    problems = [] if pixels == "resample" else [
        f"pixels are not square ({dx:.6g} m x {dy:.6g} m); resample them onto square ones "
        "with --resample-pixels"]
    return (*square_pixels(heights, dx, dy), problems)


# --- square grid and missing points -------------------------------------------------------------


def _on_square_grid(heights: np.ndarray, square: str | None,
                    resampled: bool) -> tuple[np.ndarray, list[str]]:
    """Heights [m] on the largest centred square of the grid, and the problem if the grid is not
    square and cropping was not asked for."""
    if heights.shape[0] == heights.shape[1]:
        return heights, []
    on_pixels = " (on square pixels)" if resampled else ""
    problems = [] if square == "crop" else [
        f"grid {heights.shape[0]} x {heights.shape[1]}{on_pixels} is not square; use --crop to "
        "keep its largest centred square"]
    return crop_square(heights), problems


def _missing_problems(heights: np.ndarray, fill: str | None, cropped: bool) -> list[str]:
    """Missing (NaN or unmeasured) heights that ``fill`` cannot or may not replace: none
    measured, any missing without ``fill``, fewer than 3 measured for a plane."""
    measured = int(np.count_nonzero(np.isfinite(heights)))
    missing = heights.size - measured
    if not missing:
        return []
    if not measured:
        return [f"no height is measured (all {heights.shape[0]} x {heights.shape[1]} points are "
                "NaN or unmeasured); nothing to fill from: check the file"]
    if fill is None:
        where = " in the cropped square" if cropped else ""
        return [f"{missing} missing (NaN or unmeasured) heights of {heights.size}{where}; fill "
                "them with --fill=nearest or --fill=plane"]
    if fill == "plane" and measured < 3:
        return [f"--fill=plane needs at least 3 measured heights, got {measured}; use "
                "--fill=nearest"]
    return []


# --- plausibility of the RMS height and slope (unit slips) --------------------------------------


def _rms_step(heights: np.ndarray, axis: int) -> float:
    """RMS difference between measured neighbours along ``axis`` [m] (NaN if there are none)."""
    steps = np.diff(heights, axis=axis)
    steps = steps[np.isfinite(steps)]
    return float(np.sqrt(np.mean(steps**2))) if steps.size else np.nan


def _measured_roughness(heights: np.ndarray, dx: float, dy: float) -> tuple[float, float]:
    """RMS height [m] and RMS slope [-] (forward differences along x and y, as
    ``Surface.rms_slope``) of the measured points about their least-squares plane; NaN where
    fewer than 3 points, or no neighbours, are measured."""
    if np.count_nonzero(np.isfinite(heights)) < 3:
        return np.nan, np.nan
    z = detrend_plane(heights)
    rms_height = float(np.sqrt(np.nanmean(z**2)))
    return rms_height, float(np.hypot(_rms_step(z, 0) / dx, _rms_step(z, 1) / dy))


def _slope_fix(units: UnitSource, name_height: bool) -> str:
    """What to check for an implausible RMS slope: the lateral flag, and the height flag if
    ``name_height``; an instrument file's own units otherwise."""
    flags = [flag for flag in (units.height_flag if name_height else None, units.lateral_flag)
             if flag]
    if not flags:
        return INSTRUMENT_UNITS_FIX
    return f"check {' and '.join(flags)}"


def _height_problems(rms_height: float, units: UnitSource) -> list[str]:
    """The unit slip an RMS height [m] outside [MIN_RMS_HEIGHT, MAX_RMS_HEIGHT] betrays."""
    fix = (f"give the heights' unit with {units.height_flag}" if units.height_flag
           else INSTRUMENT_UNITS_FIX)
    if rms_height < MIN_RMS_HEIGHT:
        return [f"RMS height {rms_height:.2g} m < {MIN_RMS_HEIGHT:g} m with heights in "
                f"{units.height}: less than an atomic step; {fix}"]
    if rms_height > MAX_RMS_HEIGHT:
        return [f"RMS height {rms_height:.2g} m > {MAX_RMS_HEIGHT:g} m with heights in "
                f"{units.height}: a form, not a roughness; {fix}"]
    return []


def _slope_problems(slope: float, units: UnitSource, allow_flat: bool,
                    heights_suspect: bool) -> list[str]:
    """The unit slip an RMS slope [-] below MIN_RMS_SLOPE (unless ``allow_flat``) or, with the
    height unit not given, above MAX_RMS_SLOPE betrays; the height flag is named for a flat
    one only if ``heights_suspect``."""
    read_as = f"with heights in {units.height} and {units.lateral}"
    if slope < MIN_RMS_SLOPE and not allow_flat:
        return [f"RMS slope {slope:.2g} < {MIN_RMS_SLOPE:g} {read_as}: heights too small or "
                f"lateral sizes too large for their units; {_slope_fix(units, heights_suspect)} "
                "(--allow-flat keeps a surface this flat)"]
    if slope > MAX_RMS_SLOPE and not units.height_given:
        keep = (f" (a given {units.height_flag} keeps the heights as they are)"
                if units.height_flag else "")
        return [f"RMS slope {slope:.2g} > {MAX_RMS_SLOPE:g} {read_as}: heights too large or "
                f"lateral sizes too small for their units; {_slope_fix(units, True)}{keep}"]
    return []


def unit_problems(raw: RawHeights, allow_flat: bool) -> list[str]:
    """The unit slips that the RMS height and slope of a file's raw heights betray, each with
    the flag that fixes it (see ``read_surface``)."""
    rms_height, slope = _measured_roughness(raw.heights, raw.dx, raw.dy)
    problems = _height_problems(rms_height, raw.units)
    heights_suspect = bool(problems) or not raw.units.height_given
    return problems + _slope_problems(slope, raw.units, allow_flat, heights_suspect)


# --- messages and notes -------------------------------------------------------------------------


def problems_message(path: Path, problems: list[str]) -> str:
    """One line naming the file and each of its problems with its fix."""
    if len(problems) == 1:
        return f"{path.name}: {problems[0]}"
    listed = " ".join(f"({k}) {problem}." for k, problem in enumerate(problems, 1))
    return f"{path.name}: {len(problems)} problems: {listed}"


def _note_crop(path: Path, shape: tuple[int, int], side: int) -> None:
    """Warn how many points ``--crop`` dropped from a grid of ``shape`` to keep side x side."""
    dropped = 1.0 - side**2 / (shape[0] * shape[1])
    warnings.warn(f"{path.name}: --crop kept the centred {side} x {side} of {shape[0]} x "
                  f"{shape[1]} points (dropped {dropped:.0%})", UserWarning, stacklevel=3)


def _note_fill(path: Path, heights: np.ndarray, fill: str) -> None:
    """Warn how many missing heights ``--fill`` replaced, if any."""
    missing = int(np.count_nonzero(~np.isfinite(heights)))
    if missing:
        warnings.warn(f"{path.name}: --fill={fill} filled the missing heights: {missing} of "
                      f"{heights.size} ({missing / heights.size:.2%})", UserWarning, stacklevel=3)


# --- the pipeline -------------------------------------------------------------------------------


def surface_from_raw(path: Path, raw: RawHeights, options: ReaderOptions) -> Surface:
    """The ``Surface`` (named after the file stem) of a file's raw heights, as ``options`` ask.

    Every problem is collected first and refused in one InputError (:func:`problems_message`):
    non-square pixels without ``pixels="resample"``, a non-square grid (on square pixels)
    without ``square="crop"``, missing points (in that square) without ``fill``, and the unit
    slips of :func:`unit_problems`. Then the pixels are resampled, the grid cropped and the
    missing points filled (a UserWarning says how many points the crop dropped and the fill
    replaced), and the least-squares plane is removed if ``options.detrend``.
    """
    slips = unit_problems(raw, options.allow_flat)
    heights, spacing, problems = _on_square_pixels(raw.heights, raw.dx, raw.dy, options.pixels)
    squared, grid_problems = _on_square_grid(heights, options.square,
                                             not _pixels_are_square(raw.dx, raw.dy))
    cropped = squared.shape != heights.shape
    problems += grid_problems + _missing_problems(squared, options.fill, cropped) + slips
    if problems:
        raise InputError(problems_message(path, problems))
    if cropped:
        _note_crop(path, heights.shape, squared.shape[0])
    if options.fill is not None:
        _note_fill(path, squared, options.fill)
        squared = fill_missing(squared, options.fill)
    if options.detrend:
        squared = detrend_plane(squared)
    return Surface(squared, spacing, path.stem)
