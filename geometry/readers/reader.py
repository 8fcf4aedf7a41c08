"""What a reader is and returns: a :class:`Reader` (a format's name, its file suffixes and the
function reading it) gives a file's :class:`RawHeights`, heights [m] and pixel sizes [m] with
the :class:`UnitSource` that names their units in messages; the shared pipeline
(``readers.shared``) does the rest."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from roughfriction.errors import InputError
from roughfriction.geometry.readers.options import ReaderOptions


@dataclass(frozen=True)
class UnitSource:
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


@dataclass(frozen=True, eq=False)
class RawHeights:
    """A file's heights as read, before any resampling, crop, fill or detrend.

    Attributes
    ----------
    heights : numpy.ndarray
        Heights [m], shape (n_x, n_y), axis 0 along x, NaN where unmeasured.
    dx, dy : float
        Pixel sizes [m] along x and y.
    units : UnitSource
        Where the units came from (for the messages of implausible heights and slopes).
    """

    heights: np.ndarray
    dx: float
    dy: float
    units: UnitSource


@dataclass(frozen=True)
class Reader:
    """One height-map format.

    Attributes
    ----------
    name : str
        The format's name, the value of ``ReaderOptions.fmt`` that forces it.
    suffixes : tuple of str
        Lower-case file suffixes (".npy") it is chosen for; empty for a format that is only
        forced (or detected by another reader).
    read : callable
        ``read(path, options) -> RawHeights``; InputError (one line, naming the file) for a
        file it cannot read or an option that does not apply to it.
    """

    name: str
    suffixes: tuple[str, ...]
    read: Callable[[Path, ReaderOptions], RawHeights]


def refuse_size(path: Path, fmt: str, options: ReaderOptions) -> None:
    """Refuse ``size`` for a format that carries its own lateral size."""
    if options.size is not None:
        raise InputError(f"{path.name}: {fmt} files carry their own lateral size; drop --size")


def refuse_lateral_unit(path: Path, options: ReaderOptions) -> None:
    """Refuse ``lateral_unit`` for a format other than x-y-z point lists."""
    if options.lateral_unit is not None:
        raise InputError(
            f"{path.name}: --lateral-unit applies to x-y-z point lists only; "
            "give the size with its unit instead, e.g. --size 127um"
        )
