"""How to read a height-map file: the frozen :class:`ReaderOptions` of ``read_surface``."""

from __future__ import annotations

from dataclasses import dataclass

from roughfriction.errors import InputError
from roughfriction.geometry.readers.units import length_unit_scale, size_in_metres

#: The methods of ``geometry.surface.fill_missing``.
FILL_METHODS = ("nearest", "plane")
#: The z value of an unmeasured point in the NANOVEA ST400 text export (its heights are all
#: positive); the default marker of x-y-z lists.
ST400_MISSING_HEIGHT = -1.0


@dataclass(frozen=True)
class ReaderOptions:
    """The options of reading a height-map file, checked when made (InputError, one line).

    Parameters
    ----------
    size : float or str, optional
        Scan length from the first to the last point along x, (n_x - 1) h: metres as a number,
        or a string with a unit ("127um"). Only for npy and matrix files, which need it.
    height_unit : str, optional
        Unit of the heights in npy, matrix and xyz files ("m", "mm", "um", "nm", ...); default
        m for npy, um for xyz (the ST400's), needed for matrix files. Given, it also keeps
        heights whose RMS slope exceeds ``MAX_RMS_SLOPE``.
    lateral_unit : str, optional
        Unit of x and y in xyz files (default "mm", the ST400's).
    fill : {"nearest", "plane"}, optional
        How to fill missing points (see ``geometry.surface.fill_missing``).
    square : {"crop"}, optional
        Crop a non-square grid to its largest centred square.
    pixels : {"resample"}, optional
        Resample non-square pixels bilinearly onto square ones (``square_pixels``).
    detrend : bool, optional
        Remove the least-squares plane (after filling).
    fmt : str, optional
        Force the format: the name of a reader of ``READERS`` ("npy", "text", "matrix", "xyz",
        "instrument"), checked when the file is read; None chooses the reader by the file's
        suffix.
    missing_height : float or None, optional
        z value marking an unmeasured point in xyz files (file units); None: no marker.
    allow_flat : bool, optional
        Keep a surface whose RMS slope is below ``MIN_RMS_SLOPE`` (a very smooth surface
        measured with coarse pixels) instead of refusing it as a unit slip.
    """

    size: float | str | None = None
    height_unit: str | None = None
    lateral_unit: str | None = None
    fill: str | None = None
    square: str | None = None
    pixels: str | None = None
    detrend: bool = True
    fmt: str | None = None
    missing_height: float | None = ST400_MISSING_HEIGHT
    allow_flat: bool = False

    def __post_init__(self):
        if self.square not in (None, "crop"):
            raise InputError(f"unknown square option {self.square!r}; use 'crop' or None")
        if self.pixels not in (None, "resample"):
            raise InputError(f"unknown pixels option {self.pixels!r}; use 'resample' or None")
        if self.fill not in (None, *FILL_METHODS):
            raise InputError(f"unknown fill method {self.fill!r}: use 'nearest' or 'plane'")
        if self.size is not None:
            size_in_metres(self.size)
        for unit in (self.height_unit, self.lateral_unit):
            if unit is not None:
                length_unit_scale(unit)
