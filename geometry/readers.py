"""Read measured height maps (NumPy, text matrix, x-y-z point lists, instrument files).

:func:`read_heights` returns a file's raw heights [m] on its uniform grid (NaN where unmeasured)
and its pixel sizes [m]; :func:`read_surface` then makes the pixels and the grid square, fills,
detrends, builds the ``Surface`` and refuses heights too steep to be in metres.
"""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import numpy as np
from roughfriction.errors import InputError
from roughfriction.geometry.generate import builtin_names, builtin_surface
from roughfriction.geometry.statistics import spectral_moments
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

# Largest RMS slope [-] accepted from a file; the shipped samples have 0.003 to 0.8 (the built-in
# 63M, never read from a file, 1.18), and heights in a wrong unit (um read as m) 1e3 and more.
MAX_RMS_SLOPE = 1.0

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


def _uniform_axis(coordinates: np.ndarray, label: str, path: Path) -> tuple[np.ndarray, float]:
    """Sorted unique coordinates and their spacing; InputError unless uniformly spaced."""
    values = np.unique(coordinates)
    if values.size < 2:
        raise InputError(f"{path.name}: only one distinct {label} value; not a 2-D map")
    steps = np.diff(values)
    spacing = (values[-1] - values[0]) / (values.size - 1)
    if np.max(np.abs(steps - spacing)) > 1e-3 * spacing:
        raise InputError(
            f"{path.name}: {label} values are not uniformly spaced (steps {steps.min():.6g} to "
            f"{steps.max():.6g}); resample the data onto a uniform grid first"
        )
    return values, spacing


def _grid_from_points(
    points: np.ndarray, path: Path, missing_height: float | None
) -> tuple[np.ndarray, float, float]:
    """Heights on the grid spanned by the unique x and y of an x-y-z list, and the x and y
    spacings (file units)."""
    if not np.all(np.isfinite(points[:, :2])):
        raise InputError(f"{path.name}: some x or y coordinates are not numbers")
    x_values, dx = _uniform_axis(points[:, 0], "x", path)
    y_values, dy = _uniform_axis(points[:, 1], "y", path)
    i = np.rint((points[:, 0] - x_values[0]) / dx).astype(int)
    j = np.rint((points[:, 1] - y_values[0]) / dy).astype(int)
    heights = np.full((x_values.size, y_values.size), np.nan)
    heights[i, j] = points[:, 2]
    if np.unique(i * y_values.size + j).size != len(points):
        raise InputError(f"{path.name}: some (x, y) points appear more than once")
    if missing_height is not None:
        heights[heights == missing_height] = np.nan
    return heights, dx, dy


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
    path = Path(path)
    if not path.is_file():
        raise InputError(f"no such file: {path}")
    if fmt is None:
        suffix = path.suffix.lower()
        fmt = "npy" if suffix == ".npy" else "text" if suffix in TEXT_SUFFIXES else "instrument"
    elif fmt not in FORMATS:
        raise InputError(f"unknown format {fmt!r}; known: {', '.join(FORMATS)}")
    table = _read_table(path) if fmt in ("text", "matrix", "xyz") else None
    if fmt == "text":
        fmt = "xyz" if table.shape[1] == 3 else "matrix"
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
        return _read_instrument(path)
    if fmt == "xyz":
        return _xyz_heights(path, table, height_unit, lateral_unit, missing_height)
    raw = _read_npy(path) if fmt == "npy" else table
    return _gridded_heights(path, raw, fmt, size, height_unit)


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


def _square_pixel_grid(
    path: Path, heights: np.ndarray, dx: float, dy: float, pixels: str | None
) -> tuple[np.ndarray, float]:
    """Heights [m] and spacing [m] on square pixels: as read, or resampled if asked."""
    if abs(dx - dy) <= 1e-3 * min(dx, dy):
        return heights, dx
    if pixels != "resample":
        raise InputError(
            f"{path.name}: pixels are not square ({dx:.6g} m x {dy:.6g} m); "
            "resample them onto square ones with --resample-pixels"
        )
    return square_pixels(heights, dx, dy)


def _refuse_missing(path: Path, heights: np.ndarray, fill: str | None) -> None:
    """Refuse missing (NaN or unmeasured) heights that ``fill`` cannot or may not replace:
    none measured, any missing without ``fill``, fewer than 3 measured for a plane."""
    measured = int(np.count_nonzero(np.isfinite(heights)))
    missing = heights.size - measured
    if not missing:
        return
    if not measured:
        raise InputError(f"{path.name}: no height is measured (all {heights.shape[0]} x "
                         f"{heights.shape[1]} points are NaN or unmeasured); nothing to fill "
                         "from: check the file")
    if fill is None:
        raise InputError(f"surface {path.stem!r}: {missing} missing (NaN or unmeasured) "
                         f"heights of {heights.size}; fill them with --fill=nearest or "
                         "--fill=plane")
    if fill == "plane" and measured < 3:
        raise InputError(f"{path.name}: --fill=plane needs at least 3 measured heights, got "
                         f"{measured}; use --fill=nearest")


def _refuse_steep(surface: Surface, path: Path) -> Surface:
    """``surface``, unless its RMS slope exceeds ``MAX_RMS_SLOPE`` (heights in a wrong unit)."""
    mean_square = sum(spectral_moments(surface.heights, surface.spacing, axis=a)[1] for a in (0, 1))
    slope = float(np.sqrt(mean_square))  # forward differences along x and y
    if slope > MAX_RMS_SLOPE:
        raise InputError(
            f"{path.name}: RMS slope {slope:.2g} > {MAX_RMS_SLOPE:g}: heights probably not in "
            "the unit assumed; give --height-unit (also to keep them as they are)"
        )
    return surface


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
      absent from the list.
    * ``"instrument"`` (x3p, sur, opd, al3d, di, ...): through the optional SurfaceTopography
      package (``pip install 'roughfriction[instruments]'``); units come from the file.

    Then, in this order: non-square pixels are refused unless ``pixels="resample"``; a
    non-square grid is refused unless ``square="crop"``; missing points are refused unless
    ``fill`` is given; the least-squares plane is removed if ``detrend``. Last, unless
    ``height_unit`` is given, a surface with an RMS slope above ``MAX_RMS_SLOPE`` is refused:
    its heights are probably in another unit than assumed.

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

    Returns
    -------
    Surface
        Heights [m] on the square grid, spacing h [m].
    """
    path = Path(path)
    if square not in (None, "crop"):
        raise InputError(f"unknown square option {square!r}; use 'crop' or None")
    if pixels not in (None, "resample"):
        raise InputError(f"unknown pixels option {pixels!r}; use 'resample' or None")
    heights, dx, dy = read_heights(
        path,
        size=size,
        height_unit=height_unit,
        lateral_unit=lateral_unit,
        fmt=fmt,
        missing_height=missing_height,
    )
    heights, spacing = _square_pixel_grid(path, heights, dx, dy, pixels)
    if heights.shape[0] != heights.shape[1]:
        if square != "crop":
            raise InputError(
                f"{path.name}: grid {heights.shape[0]} x {heights.shape[1]} is not square; "
                "use --crop to keep its largest centred square"
            )
        heights = crop_square(heights)
    _refuse_missing(path, heights, fill)
    if fill is not None:
        heights = fill_missing(heights, fill)
    if detrend:
        heights = detrend_plane(heights)
    surface = Surface(heights, spacing, path.stem)
    return surface if height_unit is not None else _refuse_steep(surface, path)


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
