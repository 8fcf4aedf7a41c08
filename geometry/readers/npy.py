"""The NumPy reader: a 2-D array stored by ``numpy.save``, heights in ``height_unit`` (default
m, as the shared data), axis 0 along x; the scan length comes from ``size``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from roughfriction.errors import InputError
from roughfriction.geometry.readers.options import ReaderOptions
from roughfriction.geometry.readers.reader import RawHeights, Reader, refuse_lateral_unit
from roughfriction.geometry.readers.shared import grid_heights


def read_npy(path: Path, options: ReaderOptions) -> RawHeights:
    """Heights [m] and pixel sizes [m] of a ``numpy.save`` file (see the module)."""
    refuse_lateral_unit(path, options)
    try:
        raw = np.load(path, allow_pickle=False)
    except (ValueError, OSError) as err:
        raise InputError(f"{path.name}: not a plain NumPy array file ({err})") from err
    return grid_heights(path, raw, "npy", options)


NPY = Reader("npy", (".npy",), read_npy)
