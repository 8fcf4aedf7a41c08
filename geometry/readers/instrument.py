"""The instrument reader: profilometer and microscope formats (x3p, sur, opd, al3d, di, ...)
through the optional SurfaceTopography package (``pip install 'roughfriction[instruments]'``),
which reads each file's own height unit and pixel sizes."""

from __future__ import annotations

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

# The suffixes of the formats SurfaceTopography 1.18 reads (its readers' file extensions, and
# ".di" of Digital Instruments files), except those of the text and NumPy readers.
INSTRUMENT_SUFFIXES = (
    ".001", ".002", ".003", ".004", ".005", ".al3d", ".apx", ".bcr", ".bcrf", ".cur", ".datx",
    ".di", ".ezd", ".frt", ".gwy", ".h5", ".hfm", ".hgt", ".ibw", ".jpk", ".lext", ".mat", ".mi",
    ".nc", ".nid", ".oir", ".opd", ".opdx", ".plu", ".plux", ".poir", ".spm", ".stp", ".sur",
    ".tif", ".tiff", ".tom", ".top", ".vk3", ".vk4", ".vk6", ".vk7", ".x3p", ".xlsx", ".zip",
    ".zon",
)
# An instrument file carries its own units: no flag changes them.
INSTRUMENT_UNITS = UnitSource("the file's unit", "the file's pixel size", None, None, False)


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


def read_instrument(path: Path, options: ReaderOptions) -> RawHeights:
    """Heights [m] (NaN where undefined) and x, y pixel sizes [m] through SurfaceTopography."""
    refuse_size(path, "instrument", options)
    refuse_lateral_unit(path, options)
    if options.height_unit is not None:
        raise InputError(f"{path.name}: instrument files carry their own height unit")
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
    return RawHeights(heights, dx, dy, INSTRUMENT_UNITS)


INSTRUMENT = Reader("instrument", INSTRUMENT_SUFFIXES, read_instrument)
