"""The text-table readers: a height matrix ("matrix") or an x-y-z point list ("xyz", the NANOVEA
ST400 export), and the "text" reader of the text suffixes that tells one from the other.

A table is one row per line, numbers separated by commas, semicolons or blanks; blank lines,
'#' or '%' comments and leading header lines without a number are skipped, and a non-numeric
entry (e.g. "NM") is a missing point. A matrix has row index = x and needs ``size`` and
``height_unit``. An x-y-z list holds points in any order on a uniform grid, in the ST400's
units unless given (x, y in mm, z in um); z equal to ``missing_height`` (the ST400's -1) and
grid points absent from the list are missing.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from roughfriction.errors import InputError
from roughfriction.geometry.readers.options import ReaderOptions
from roughfriction.geometry.readers.reader import (
    RawHeights,
    Reader,
    UnitSource,
    refuse_lateral_unit,
    refuse_size,
)
from roughfriction.geometry.readers.shared import grid_heights
from roughfriction.geometry.readers.units import NUMBER_PATTERN, length_unit_scale
from roughfriction.geometry.surface import MIN_GRID_POINTS

# The NANOVEA ST400 text export: x, y in mm, z in um (its unmeasured marker is the options'
# ``ST400_MISSING_HEIGHT``).
ST400_LATERAL_UNIT = "mm"
ST400_HEIGHT_UNIT = "um"

TEXT_SUFFIXES = (".txt", ".csv", ".dat", ".asc", ".xyz")
# Least share [-] of the grid spanned by its x and y that a 3-column text table must cover to be
# read as an x-y-z list when its format is detected.
MIN_POINT_LIST_COVER = 0.5

_SEPARATORS = re.compile(r"[,;\s]+")


# --- tables -------------------------------------------------------------------------------------


def read_table(path: Path) -> np.ndarray:
    """Numbers of a text table, one row per line, separated by commas, semicolons or blanks.

    Blank lines and lines starting with '#' or '%' are skipped, as are leading header lines
    without any number. Non-numeric entries after the header (e.g. "NM") become NaN.
    """
    lines = [line for line in path.read_text(errors="replace").splitlines() if line.strip()]
    rows = [_SEPARATORS.split(line.strip()) for line in lines if line.lstrip()[0] not in "#%"]
    while rows and not any(re.fullmatch(NUMBER_PATTERN, token) for token in rows[0]):
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


# --- x-y-z point lists on a uniform grid --------------------------------------------------------


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


def _xyz_units(options: ReaderOptions) -> UnitSource:
    """The :class:`UnitSource` of an x-y-z list: the units given, or the ST400's."""
    height = (f"{options.height_unit} (given)" if options.height_unit
              else f"{ST400_HEIGHT_UNIT} (the xyz default)")
    lateral = (f"x-y in {options.lateral_unit} (given)" if options.lateral_unit
               else f"x-y in {ST400_LATERAL_UNIT} (the xyz default)")
    return UnitSource(height, lateral, "--height-unit", "--lateral-unit",
                      bool(options.height_unit))


def _xyz_heights(path: Path, table: np.ndarray, options: ReaderOptions) -> RawHeights:
    """Heights [m] and x, y spacings [m] of an x-y-z point list (ST400 units unless given)."""
    refuse_size(path, "xyz", options)
    if table.shape[1] != 3:
        raise InputError(f"{path.name}: an x-y-z list needs 3 columns, not {table.shape[1]}")
    grid, dx, dy = _grid_from_points(table, path, options.missing_height)
    lateral_scale = length_unit_scale(options.lateral_unit or ST400_LATERAL_UNIT)
    height_scale = length_unit_scale(options.height_unit or ST400_HEIGHT_UNIT)
    return RawHeights(grid * height_scale, dx * lateral_scale, dy * lateral_scale,
                      _xyz_units(options))


def _matrix_heights(path: Path, table: np.ndarray, options: ReaderOptions) -> RawHeights:
    """Heights [m] and pixel sizes [m] of a height matrix (row index = x)."""
    refuse_lateral_unit(path, options)
    return grid_heights(path, table, "matrix", options)


# --- telling a matrix from a point list ---------------------------------------------------------


def _is_point_list(path: Path, table: np.ndarray) -> bool:
    """True for a 3-column table whose rows are points covering most of a uniform grid, False
    for any other width; InputError for a 3-column table that is neither (a matrix of 3
    columns is too narrow for a height map)."""
    if table.shape[1] != 3:
        return False
    problem = _point_grid_problem(table)
    if problem is None:
        _, _, (n_x, n_y), _, _ = _grid_indices(table)
        if len(table) < MIN_POINT_LIST_COVER * n_x * n_y:
            problem = (f"its {len(table)} points cover {len(table)} of the {n_x} x {n_y} grid "
                       f"points their x and y span, less than {MIN_POINT_LIST_COVER:.0%}")
    if problem is None:
        return True
    raise InputError(
        f"{path.name}: 3 columns but not an x-y-z list ({problem}), nor a height matrix (at "
        f"least {MIN_GRID_POINTS} columns); write one x, y, z point per line on a uniform grid or "
        f"at least {MIN_GRID_POINTS} heights per row, or read it as points with fmt='xyz'"
    )


# --- the readers --------------------------------------------------------------------------------


def read_text(path: Path, options: ReaderOptions) -> RawHeights:
    """A text table read as an x-y-z list or a height matrix, as its content says."""
    table = read_table(path)
    read = _xyz_heights if _is_point_list(path, table) else _matrix_heights
    return read(path, table, options)


def read_matrix(path: Path, options: ReaderOptions) -> RawHeights:
    """A text table read as a height matrix."""
    return _matrix_heights(path, read_table(path), options)


def read_xyz(path: Path, options: ReaderOptions) -> RawHeights:
    """A text table read as an x-y-z point list."""
    return _xyz_heights(path, read_table(path), options)


TEXT = Reader("text", TEXT_SUFFIXES, read_text)
MATRIX = Reader("matrix", (), read_matrix)
XYZ = Reader("xyz", (), read_xyz)
