"""Read measured height maps (NumPy, text matrix, x-y-z point lists, instrument files).

:func:`read_heights` returns a file's raw heights [m] on its uniform grid (NaN where unmeasured)
and its pixel sizes [m]; :func:`read_surface` then makes the pixels and the grid square, fills,
detrends and builds the ``Surface``. It first lists every problem of the file at once (pixels,
grid, missing points, and RMS heights and slopes that betray a unit slip), each with its fix,
and notes on a warning what ``--crop`` dropped and ``--fill`` filled.
"""

from __future__ import annotations

import inspect
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from roughfriction.errors import InputError
from roughfriction.geometry.generate import builtin_names, builtin_surface
from roughfriction.geometry.surface import (
    MIN_GRID_POINTS,
    Surface,
    crop_square,
    detrend_plane,
    fill_missing,
)

# Length units accepted in strings [m per unit]; both micro signs (U+00B5, U+03BC) are accepted.
LENGTH_UNITS = {
    "m": 1.0,
    "cm": 1e-2,
    "mm": 1e-3,
    "um": 1e-6,
    "\u00b5m": 1e-6,
    "\u03bcm": 1e-6,
    "micron": 1e-6,
    "nm": 1e-9,
    "pm": 1e-12,
}

# The NANOVEA ST400 text export: x, y in mm, z in um; an unmeasured point is written as z = -1
# (the export's heights are all positive), or as a non-numeric token such as "NM".
ST400_LATERAL_UNIT = "mm"
ST400_HEIGHT_UNIT = "um"
ST400_MISSING_HEIGHT = -1.0

TEXT_SUFFIXES = (".txt", ".csv", ".dat", ".asc", ".xyz")
FORMATS = ("npy", "matrix", "xyz", "instrument")

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
# Least share [-] of the grid spanned by its x and y that a 3-column text table must cover to be
# read as an x-y-z list when its format is detected.
MIN_POINT_LIST_COVER = 0.5
# The fix named for implausible units of an instrument file, which carries its own.
INSTRUMENT_UNITS_FIX = "check the file's units (an instrument file carries its own)"
# The methods of ``geometry.surface.fill_missing``.
FILL_METHODS = ("nearest", "plane")

_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_LENGTH = re.compile(rf"\s*({_NUMBER})\s*([^\d\s.+-][^\s]*)?\s*")
_SEPARATORS = re.compile(r"[,;\s]+")


def length_unit_scale(unit: str) -> float:
    """Metres per ``unit`` ("m", "mm", "um", "µm", "nm", ...)."""
    scale = LENGTH_UNITS.get(unit.strip())
    if scale is None:
        raise InputError(f"unknown length unit {unit!r}; known: {', '.join(LENGTH_UNITS)}")
    return scale


def parse_length(text: str) -> float:
    """A length with its unit, e.g. "127um", "127 µm", "0.127mm", "1.27e-4 m", "500nm".

    Parameters
    ----------
    text : str
        Number followed by a unit from ``LENGTH_UNITS``; a bare number is refused, so that a
        missing unit never silently becomes metres.

    Returns
    -------
    float
        The length [m].
    """
    match = _LENGTH.fullmatch(str(text))
    if match is None:
        raise InputError(f"cannot read a length from {text!r}; write a number and a unit: 127um")
    value, unit = match.groups()
    if unit is None:
        raise InputError(f"length {text!r} has no unit; add one, e.g. {value}um or {value}mm")
    return float(value) * length_unit_scale(unit)


def _size_in_metres(size) -> float:
    """Scan length [m] from a number (metres) or a string with a unit; must be > 0."""
    length = parse_length(size) if isinstance(size, str) else float(size)
    if not (np.isfinite(length) and length > 0):
        raise InputError(f"scan size must be > 0, got {size!r}")
    return length


def _read_table(path: Path) -> np.ndarray:
    """Numbers of a text table, one row per line, separated by commas, semicolons or blanks.

    Blank lines and lines starting with '#' or '%' are skipped, as are leading header lines
    without any number. Non-numeric entries after the header (e.g. "NM") become NaN.
    """
    lines = [line for line in path.read_text(errors="replace").splitlines() if line.strip()]
    rows = [_SEPARATORS.split(line.strip()) for line in lines if line.lstrip()[0] not in "#%"]
    while rows and not any(re.fullmatch(_NUMBER, token) for token in rows[0]):
        rows.pop(0)  # header line
    if not rows:
        raise InputError(f"{path.name}: no numbers found")
    width = len(rows[0])
    ragged = next((k for k, row in enumerate(rows) if len(row) != width), None)
    if ragged is not None:
        raise InputError(
            f"{path.name}: data row {ragged + 1} has {len(rows[ragged])} values, "
            f"the first has {width}"
        )
    return np.array([[_to_float(token) for token in row] for row in rows])


def _to_float(token: str) -> float:
    """The number in ``token``, or NaN when it is not one (a missing point)."""
    try:
        return float(token)
    except ValueError:
        return np.nan


def _grid_axis(coordinates: np.ndarray) -> tuple[np.ndarray, float]:
    """Sorted distinct coordinates and their mean spacing (NaN for fewer than two)."""
    values = np.unique(coordinates)
    spacing = (values[-1] - values[0]) / (values.size - 1) if values.size > 1 else np.nan
    return values, spacing


def _axis_problem(coordinates: np.ndarray, label: str) -> str | None:
    """Why ``coordinates`` are not the axis of a uniform grid, or None."""
    values, spacing = _grid_axis(coordinates)
    if values.size < 2:
        return f"only one distinct {label} value; not a 2-D map"
    steps = np.diff(values)
    if np.max(np.abs(steps - spacing)) > 1e-3 * spacing:
        return (f"{label} values are not uniformly spaced (steps {steps.min():.6g} to "
                f"{steps.max():.6g}); resample the data onto a uniform grid first")
    return None


def _grid_indices(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[int, int], float,
                                               float]:
    """Grid indices i, j of the x-y points of an x-y-z list on the grid spanned by their distinct
    x and y, its shape, and its x and y spacings (file units)."""
    x_values, dx = _grid_axis(points[:, 0])
    y_values, dy = _grid_axis(points[:, 1])
    i = np.rint((points[:, 0] - x_values[0]) / dx).astype(int)
    j = np.rint((points[:, 1] - y_values[0]) / dy).astype(int)
    return i, j, (x_values.size, y_values.size), dx, dy


def _point_grid_problem(points: np.ndarray) -> str | None:
    """Why the x and y columns of ``points`` are not distinct points of a uniform grid, or None."""
    if not np.all(np.isfinite(points[:, :2])):
        return "some x or y coordinates are not numbers"
    problem = _axis_problem(points[:, 0], "x") or _axis_problem(points[:, 1], "y")
    if problem:
        return problem
    i, j, shape, _, _ = _grid_indices(points)
    if np.unique(i * shape[1] + j).size != len(points):
        return "some (x, y) points appear more than once"
    return None


def _grid_from_points(
    points: np.ndarray, path: Path, missing_height: float | None
) -> tuple[np.ndarray, float, float]:
    """Heights on the grid spanned by the unique x and y of an x-y-z list, and the x and y
    spacings (file units)."""
    problem = _point_grid_problem(points)
    if problem:
        raise InputError(f"{path.name}: {problem}")
    i, j, shape, dx, dy = _grid_indices(points)
    heights = np.full(shape, np.nan)
    heights[i, j] = points[:, 2]
    if missing_height is not None:
        heights[heights == missing_height] = np.nan
    return heights, dx, dy


def _text_format(path: Path, table: np.ndarray) -> str:
    """"xyz" for a 3-column table whose rows are points covering most of a uniform grid,
    "matrix" for any other width; InputError for a 3-column table that is neither (a matrix of 3
    columns is too narrow for a height map)."""
    if table.shape[1] != 3:
        return "matrix"
    problem = _point_grid_problem(table)
    if problem is None:
        _, _, (n_x, n_y), _, _ = _grid_indices(table)
        if len(table) < MIN_POINT_LIST_COVER * n_x * n_y:
            problem = (f"its {len(table)} points cover {len(table)} of the {n_x} x {n_y} grid "
                       f"points their x and y span, less than {MIN_POINT_LIST_COVER:.0%}")
    if problem is None:
        return "xyz"
    raise InputError(
        f"{path.name}: 3 columns but not an x-y-z list ({problem}), nor a height matrix (at "
        f"least {MIN_GRID_POINTS} columns); write one x, y, z point per line on a uniform grid or "
        f"at least {MIN_GRID_POINTS} heights per row, or read it as points with fmt='xyz'"
    )


def _read_npy(path: Path) -> np.ndarray:
    """Heights array stored by ``numpy.save`` (file units)."""
    try:
        return np.load(path, allow_pickle=False)
    except (ValueError, OSError) as err:
        raise InputError(f"{path.name}: not a plain NumPy array file ({err})") from err


def _digital_surf_unmeasured(topography) -> np.ndarray | bool:
    """Where a Digital Surf (.sur) topography holds a non-measured point (else False).

    With ``special_points`` set, such files store those points as the integer zmin - 2 (the
    MountainsMap convention), which SurfaceTopography 1.18 returns as a height.
    """
    header = topography.info.get("raw_metadata") or {}
    if header.get("magic") != "DIGITAL SURF" or header.get("special_points") != 1:
        return False
    marker = (header["zmin"] - 2) * header["height_scale_factor"]  # file units
    return np.asarray(topography.heights()) == marker


def _read_instrument(path: Path) -> tuple[np.ndarray, float, float]:
    """Heights [m] (NaN where undefined) and x, y pixel sizes [m] through SurfaceTopography."""
    try:
        import SurfaceTopography
    except ImportError as err:
        raise InputError(
            f"reading {path.suffix or 'this'} files needs the optional SurfaceTopography "
            "package: pip install 'roughfriction[instruments]'"
        ) from err
    try:
        native = SurfaceTopography.read_topography(str(path))
        unmeasured = _digital_surf_unmeasured(native)
        topography = native.to_unit("m")
        heights = np.ma.filled(np.ma.asarray(topography.heights(), dtype=float), np.nan)
        sizes = np.asarray(topography.physical_sizes, dtype=float)
        points = np.asarray(topography.nb_grid_pts, dtype=float)
    except Exception as err:  # the readers raise many exception types for unreadable files
        reason = " ".join(str(err).split())[:300]  # one line
        raise InputError(f"{path.name}: SurfaceTopography cannot read it ({reason})") from err
    if heights.ndim != 2:
        raise InputError(f"{path.name}: holds a line scan, not a 2-D height map")
    heights[unmeasured] = np.nan
    dx, dy = sizes / points  # SurfaceTopography's physical size is n_points x pixel size
    return heights, dx, dy


def _xyz_heights(
    path: Path,
    table: np.ndarray,
    height_unit: str | None,
    lateral_unit: str | None,
    missing_height: float | None,
) -> tuple[np.ndarray, float, float]:
    """Heights [m] and x, y spacings [m] of an x-y-z point list (ST400 units unless overridden)."""
    if table.shape[1] != 3:
        raise InputError(f"{path.name}: an x-y-z list needs 3 columns, not {table.shape[1]}")
    grid, dx, dy = _grid_from_points(table, path, missing_height)
    lateral_scale = length_unit_scale(lateral_unit or ST400_LATERAL_UNIT)
    return (
        grid * length_unit_scale(height_unit or ST400_HEIGHT_UNIT),
        dx * lateral_scale,
        dy * lateral_scale,
    )


def _gridded_heights(
    path: Path, raw: np.ndarray, fmt: str, size, height_unit: str | None
) -> tuple[np.ndarray, float, float]:
    """Heights [m] and x, y spacings [m] (equal) of a bare height array (npy or text matrix),
    row index = x."""
    if size is None:
        raise InputError(
            f"{path.name}: a {fmt} file has no lateral scale; give the scan length from "
            "first to last point with --size, e.g. --size 127um"
        )
    if fmt == "matrix" and height_unit is None:
        raise InputError(
            f"{path.name}: a height matrix has no unit; give it with --height-unit, e.g. um"
        )
    if raw.ndim != 2:
        raise InputError(f"{path.name}: holds a {raw.ndim}-D array of shape {raw.shape}, not a "
                         "2-D height map (rows along x, columns along y)")
    if min(raw.shape) < MIN_GRID_POINTS:
        raise InputError(f"{path.name}: a {raw.shape[0]} x {raw.shape[1]} grid is too small for "
                         f"a height map (at least {MIN_GRID_POINTS} x {MIN_GRID_POINTS} points)")
    heights = raw.astype(float) * length_unit_scale(height_unit or "m")
    spacing = _size_in_metres(size) / (raw.shape[0] - 1)
    return heights, spacing, spacing


def read_heights(
    path,
    *,
    size=None,
    height_unit: str | None = None,
    lateral_unit: str | None = None,
    fmt: str | None = None,
    missing_height: float | None = ST400_MISSING_HEIGHT,
) -> tuple[np.ndarray, float, float]:
    """A file's heights on its full grid, before any crop, fill, detrend or resampling.

    Options and formats as in :func:`read_surface`.

    Returns
    -------
    tuple
        Heights [m], shape (n_x, n_y), NaN where unmeasured; pixel sizes dx, dy [m].
    """
    heights, dx, dy, _ = _read_file(Path(path), size, height_unit, lateral_unit, fmt,
                                    missing_height)
    return heights, dx, dy


def _read_file(
    path: Path,
    size,
    height_unit: str | None,
    lateral_unit: str | None,
    fmt: str | None,
    missing_height: float | None,
) -> tuple[np.ndarray, float, float, str]:
    """:func:`read_heights`, and the format the file was read as."""
    if not path.is_file():
        raise InputError(f"no such file: {path}")
    if fmt is None:
        suffix = path.suffix.lower()
        fmt = "npy" if suffix == ".npy" else "text" if suffix in TEXT_SUFFIXES else "instrument"
    elif fmt not in FORMATS:
        raise InputError(f"unknown format {fmt!r}; known: {', '.join(FORMATS)}")
    table = _read_table(path) if fmt in ("text", "matrix", "xyz") else None
    if fmt == "text":
        fmt = _text_format(path, table)
    if size is not None and fmt in ("xyz", "instrument"):
        raise InputError(f"{path.name}: {fmt} files carry their own lateral size; drop --size")
    if lateral_unit is not None and fmt != "xyz":
        raise InputError(
            f"{path.name}: --lateral-unit applies to x-y-z point lists only; "
            "give the size with its unit instead, e.g. --size 127um"
        )
    if fmt == "instrument":
        if height_unit is not None:
            raise InputError(f"{path.name}: instrument files carry their own height unit")
        return (*_read_instrument(path), fmt)
    if fmt == "xyz":
        return (*_xyz_heights(path, table, height_unit, lateral_unit, missing_height), fmt)
    raw = _read_npy(path) if fmt == "npy" else table
    return (*_gridded_heights(path, raw, fmt, size, height_unit), fmt)


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


@dataclass(frozen=True)
class _UnitSource:
    """Where a file's heights and lateral sizes got their units, as named in messages.

    Attributes
    ----------
    height : str
        The height unit and whether it was given or a default, e.g. "um (the xyz default)".
    lateral : str
        What set the lateral sizes, e.g. "x-y in mm (given)" or "pixels from --size 31mm".
    height_flag, lateral_flag : str or None
        The flag that changes each; None for an instrument file's own units.
    height_given : bool
        Whether the height unit was given (a given unit keeps a steep surface as it is).
    """

    height: str
    lateral: str
    height_flag: str | None
    lateral_flag: str | None
    height_given: bool


def _unit_source(fmt: str, size, height_unit: str | None, lateral_unit: str | None) -> _UnitSource:
    """The :class:`_UnitSource` of a file read as ``fmt`` with the reader options given."""
    if fmt == "instrument":
        return _UnitSource("the file's unit", "the file's pixel size", None, None, False)
    default_height = ST400_HEIGHT_UNIT if fmt == "xyz" else "m"
    height = f"{height_unit} (given)" if height_unit else f"{default_height} (the {fmt} default)"
    if fmt == "xyz":
        lateral = (f"x-y in {lateral_unit} (given)" if lateral_unit
                   else f"x-y in {ST400_LATERAL_UNIT} (the xyz default)")
        return _UnitSource(height, lateral, "--height-unit", "--lateral-unit", bool(height_unit))
    length = size if isinstance(size, str) else f"{size:g}m"
    return _UnitSource(height, f"pixels from --size {length}", "--height-unit", "--size",
                       bool(height_unit))


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


def _slope_fix(units: _UnitSource, name_height: bool) -> str:
    """What to check for an implausible RMS slope: the lateral flag, and the height flag if
    ``name_height``; an instrument file's own units otherwise."""
    flags = [flag for flag in (units.height_flag if name_height else None, units.lateral_flag)
             if flag]
    if not flags:
        return INSTRUMENT_UNITS_FIX
    return f"check {' and '.join(flags)}"


def _height_problems(rms_height: float, units: _UnitSource) -> list[str]:
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


def _slope_problems(slope: float, units: _UnitSource, allow_flat: bool,
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


def _unit_problems(heights: np.ndarray, dx: float, dy: float, units: _UnitSource,
                   allow_flat: bool) -> list[str]:
    """The unit slips that the RMS height and slope of a file's heights [m] on pixels dx, dy
    [m] betray, each with the flag that fixes it (see :func:`read_surface`)."""
    rms_height, slope = _measured_roughness(heights, dx, dy)
    problems = _height_problems(rms_height, units)
    heights_suspect = bool(problems) or not units.height_given
    return problems + _slope_problems(slope, units, allow_flat, heights_suspect)


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


def _problems_message(path: Path, problems: list[str]) -> str:
    """One line naming the file and each of its problems with its fix."""
    if len(problems) == 1:
        return f"{path.name}: {problems[0]}"
    listed = " ".join(f"({k}) {problem}." for k, problem in enumerate(problems, 1))
    return f"{path.name}: {len(problems)} problems: {listed}"


def _note_crop(path: Path, shape: tuple[int, int], side: int) -> None:
    """Warn how many points ``--crop`` dropped from a grid of ``shape`` to keep side x side."""
    dropped = 1.0 - side**2 / (shape[0] * shape[1])
    warnings.warn(f"{path.name}: --crop kept the centred {side} x {side} of {shape[0]} x "
                  f"{shape[1]} points (dropped {dropped:.0%})", UserWarning, stacklevel=2)


def _note_fill(path: Path, heights: np.ndarray, fill: str) -> None:
    """Warn how many missing heights ``--fill`` replaced, if any."""
    missing = int(np.count_nonzero(~np.isfinite(heights)))
    if missing:
        warnings.warn(f"{path.name}: --fill={fill} filled the missing heights: {missing} of "
                      f"{heights.size} ({missing / heights.size:.2%})", UserWarning, stacklevel=2)


def _check_options(square: str | None, pixels: str | None, fill: str | None) -> None:
    """Refuse unknown values of the crop, pixel and fill options of :func:`read_surface`."""
    if square not in (None, "crop"):
        raise InputError(f"unknown square option {square!r}; use 'crop' or None")
    if pixels not in (None, "resample"):
        raise InputError(f"unknown pixels option {pixels!r}; use 'resample' or None")
    if fill not in (None, *FILL_METHODS):
        raise InputError(f"unknown fill method {fill!r}: use 'nearest' or 'plane'")


def read_surface(
    path,
    *,
    size=None,
    height_unit: str | None = None,
    lateral_unit: str | None = None,
    fill: str | None = None,
    square: str | None = None,
    pixels: str | None = None,
    detrend: bool = True,
    fmt: str | None = None,
    missing_height: float | None = ST400_MISSING_HEIGHT,
    allow_flat: bool = False,
) -> Surface:
    """Read a measured height map into a ``Surface`` named after the file stem.

    Formats (``fmt``, detected from the extension and content when None):

    * ``"npy"`` (.npy): heights in ``height_unit`` (default "m", as the shared data), axis 0 = x;
      needs ``size``.
    * ``"matrix"`` (.txt/.csv/.dat/.asc with other than 3 columns): a whitespace- or
      comma-separated height matrix, row index = x; needs ``size`` and ``height_unit``.
    * ``"xyz"`` (3-column text): x, y, z points in any order on a uniform grid (blank lines and
      '#' comments ignored). The default units follow the NANOVEA ST400 export (the paper's
      instrument): x, y in mm (``lateral_unit``) and z in um (``height_unit``); z equal to
      ``missing_height`` (the ST400's -1) or non-numeric is a missing point, as are grid points
      absent from the list. Detected, a 3-column table must be distinct points covering at
      least ``MIN_POINT_LIST_COVER`` of their grid; otherwise it is refused (a matrix of 3
      columns is too narrow for a height map).
    * ``"instrument"`` (x3p, sur, opd, al3d, di, ...): through the optional SurfaceTopography
      package (``pip install 'roughfriction[instruments]'``); units come from the file.

    Before changing anything, every problem of the file is collected and refused in one
    InputError, each with its fix: non-square pixels without ``pixels="resample"``; a
    non-square grid (on square pixels) without ``square="crop"``; missing points (in that
    square) without ``fill``; and the unit slips betrayed by the measured points about their
    least-squares plane: an RMS height outside [``MIN_RMS_HEIGHT``, ``MAX_RMS_HEIGHT``] (no
    escape), an RMS slope below ``MIN_RMS_SLOPE`` (unless ``allow_flat``) or, unless
    ``height_unit`` is given, above ``MAX_RMS_SLOPE``. Then the pixels are resampled, the grid
    cropped and the missing points filled as asked (a UserWarning says how many points the crop
    dropped and the fill replaced), and the least-squares plane is removed if ``detrend``.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    size : float or str, optional
        Scan length from the first to the last point along x, (n_x - 1) h: metres as a number,
        or a string with a unit ("127um"). Only for npy and matrix files.
    height_unit : str, optional
        Unit of the heights in npy, matrix and xyz files ("m", "mm", "um", "nm", ...).
    lateral_unit : str, optional
        Unit of x and y in xyz files (default "mm").
    fill : {"nearest", "plane"}, optional
        How to fill missing points (see ``geometry.surface.fill_missing``).
    square : {"crop"}, optional
        Crop a non-square grid to its largest centred square.
    pixels : {"resample"}, optional
        Resample non-square pixels bilinearly onto square ones (:func:`square_pixels`).
    detrend : bool, optional
        Remove the least-squares plane (after filling).
    fmt : {"npy", "matrix", "xyz", "instrument"}, optional
        Force the format.
    missing_height : float or None, optional
        z value marking an unmeasured point in xyz files (file units); None: no marker.
    allow_flat : bool, optional
        Keep a surface whose RMS slope is below ``MIN_RMS_SLOPE`` (a very smooth surface
        measured with coarse pixels) instead of refusing it as a unit slip.

    Returns
    -------
    Surface
        Heights [m] on the square grid, spacing h [m].
    """
    path = Path(path)
    _check_options(square, pixels, fill)
    heights, dx, dy, read_as = _read_file(path, size, height_unit, lateral_unit, fmt,
                                          missing_height)
    units = _unit_source(read_as, size, height_unit, lateral_unit)
    unit_problems = _unit_problems(heights, dx, dy, units, allow_flat)
    heights, spacing, problems = _on_square_pixels(heights, dx, dy, pixels)
    squared, grid_problems = _on_square_grid(heights, square, not _pixels_are_square(dx, dy))
    cropped = squared.shape != heights.shape
    problems += grid_problems + _missing_problems(squared, fill, cropped) + unit_problems
    if problems:
        raise InputError(_problems_message(path, problems))
    if cropped:
        _note_crop(path, heights.shape, squared.shape[0])
    if fill is not None:
        _note_fill(path, squared, fill)
        squared = fill_missing(squared, fill)
    if detrend:
        squared = detrend_plane(squared)
    return Surface(squared, spacing, path.stem)


def load_surface(spec: str, **read_options) -> Surface:
    """A built-in surface by name, or a file read with :func:`read_surface`.

    Parameters
    ----------
    spec : str
        A built-in name (``geometry.generate.builtin_names()``) or a path.
    **read_options
        Options of :func:`read_surface`; with a built-in name only their default values are
        accepted (the CLI passes them all).

    Returns
    -------
    Surface
    """
    if spec in builtin_names():
        defaults = {
            name: parameter.default
            for name, parameter in inspect.signature(read_surface).parameters.items()
            if parameter.kind is inspect.Parameter.KEYWORD_ONLY
        }
        given = sorted(k for k, v in read_options.items() if k not in defaults or defaults[k] != v)
        if given:
            raise InputError(
                f"reader options ({', '.join(given)}) apply to files, not to built-in {spec!r}"
            )
        return builtin_surface(spec)
    if not Path(spec).is_file():
        raise InputError(
            f"{spec!r} is neither a file nor a built-in surface ({', '.join(builtin_names())})"
        )
    return read_surface(spec, **read_options)
