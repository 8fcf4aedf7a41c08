"""Read measured height maps (NumPy, text matrix, x-y-z point lists, instrument files).

One reader per format, registered in :data:`READERS` (``registry``): ``npy``, the text tables
of ``text`` (matrix, x-y-z list, and the detecting "text" reader) and the instrument formats
of ``instrument`` (through SurfaceTopography). A reader returns a file's raw heights [m] on its
uniform grid (NaN where unmeasured) and its pixel sizes [m] (:func:`read_heights`); the shared
pipeline (``shared``) then lists every problem of the file at once (pixels, grid, missing
points, and RMS heights and slopes that betray a unit slip), each with its fix, makes the
pixels and the grid square, fills, detrends and builds the ``Surface`` (:func:`read_surface`),
noting on a warning what ``--crop`` dropped and ``--fill`` filled. :class:`ReaderOptions`
holds the options.
"""

from __future__ import annotations

from dataclasses import fields, replace
from pathlib import Path

import numpy as np
from roughfriction.errors import InputError
from roughfriction.geometry.generate import builtin_names, builtin_surface
from roughfriction.geometry.readers.options import (
    FILL_METHODS,
    ST400_MISSING_HEIGHT,
    ReaderOptions,
)
from roughfriction.geometry.readers.reader import RawHeights, Reader
from roughfriction.geometry.readers.registry import FORMATS, READERS, SUFFIXES, reader_for
from roughfriction.geometry.readers.shared import (
    MAX_RMS_HEIGHT,
    MAX_RMS_SLOPE,
    MIN_RMS_HEIGHT,
    MIN_RMS_SLOPE,
    square_pixels,
    surface_from_raw,
)
from roughfriction.geometry.readers.text import (
    MIN_POINT_LIST_COVER,
    ST400_HEIGHT_UNIT,
    ST400_LATERAL_UNIT,
    TEXT_SUFFIXES,
)
from roughfriction.geometry.readers.units import LENGTH_UNITS, length_unit_scale, parse_length
from roughfriction.geometry.surface import Surface

__all__ = [
    "ReaderOptions", "READERS", "FORMATS", "SUFFIXES", "Reader", "RawHeights", "reader_for",
    "read_raw", "read_heights", "read_surface", "load_surface", "square_pixels",
    "parse_length", "length_unit_scale", "LENGTH_UNITS", "FILL_METHODS", "TEXT_SUFFIXES",
    "ST400_HEIGHT_UNIT", "ST400_LATERAL_UNIT", "ST400_MISSING_HEIGHT", "MIN_POINT_LIST_COVER",
    "MAX_RMS_HEIGHT", "MAX_RMS_SLOPE", "MIN_RMS_HEIGHT", "MIN_RMS_SLOPE",
]


def read_raw(path, options: ReaderOptions | None = None) -> RawHeights:
    """A file's :class:`RawHeights`, read by the reader ``options.fmt`` names or, without it,
    by the one registered for the file's suffix."""
    path = Path(path)
    options = options or ReaderOptions()
    if not path.is_file():
        raise InputError(f"no such file: {path}")
    return reader_for(path, options.fmt).read(path, options)


def read_heights(path, options: ReaderOptions | None = None) -> tuple[np.ndarray, float, float]:
    """A file's heights on its full grid, before any crop, fill, detrend or resampling.

    Returns
    -------
    tuple
        Heights [m], shape (n_x, n_y), NaN where unmeasured; pixel sizes dx, dy [m].
    """
    raw = read_raw(path, options)
    return raw.heights, raw.dx, raw.dy


def read_surface(path, options: ReaderOptions | None = None) -> Surface:
    """Read a measured height map into a ``Surface`` named after the file stem.

    Formats (``options.fmt``, else the reader of the file's suffix in :data:`READERS`):

    * ``"npy"`` (.npy): heights in ``height_unit`` (default "m", as the shared data), axis 0 = x;
      needs ``size``.
    * ``"text"`` (.txt/.csv/.dat/.asc/.xyz): an x-y-z list if it has 3 columns of distinct
      points covering at least ``MIN_POINT_LIST_COVER`` of their grid, a matrix if it has other
      than 3 columns; otherwise refused (a matrix of 3 columns is too narrow for a height map).
    * ``"matrix"``: a whitespace- or comma-separated height matrix, row index = x; needs
      ``size`` and ``height_unit``.
    * ``"xyz"``: x, y, z points in any order on a uniform grid (blank lines and '#' comments
      ignored). The default units follow the NANOVEA ST400 export (the paper's instrument): x,
      y in mm (``lateral_unit``) and z in um (``height_unit``); z equal to ``missing_height``
      (the ST400's -1) or non-numeric is a missing point, as are grid points absent from the
      list.
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
    options : ReaderOptions, optional
        How to read it (default ``ReaderOptions()``).

    Returns
    -------
    Surface
        Heights [m] on the square grid, spacing h [m].
    """
    options = options or ReaderOptions()
    return surface_from_raw(Path(path), read_raw(path, options), options)


def load_surface(spec: str, options: ReaderOptions | None = None, **option_values) -> Surface:
    """A built-in surface by name, or a file read with :func:`read_surface`.

    Parameters
    ----------
    spec : str
        A built-in name (``geometry.generate.builtin_names()``) or a path.
    options : ReaderOptions, optional
        How to read a file; with a built-in name only the default options are accepted.
    **option_values
        Fields of :class:`ReaderOptions` replacing those of ``options``, e.g.
        ``load_surface("scan.npy", size="31um", height_unit="um")``.

    Returns
    -------
    Surface
    """
    options = replace(options or ReaderOptions(), **option_values)
    if spec in builtin_names():
        given = sorted(field.name for field in fields(ReaderOptions)
                       if getattr(options, field.name) != field.default)
        if given:
            raise InputError(
                f"reader options ({', '.join(given)}) apply to files, not to built-in {spec!r}"
            )
        return builtin_surface(spec)
    if not Path(spec).is_file():
        raise InputError(
            f"{spec!r} is neither a file nor a built-in surface ({', '.join(builtin_names())})"
        )
    return read_surface(spec, options)
