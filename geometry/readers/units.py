"""Lengths with their unit, as the reader options write them ("127um", "0.127 mm", "500nm")."""

from __future__ import annotations

import re

import numpy as np
from roughfriction.errors import InputError

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

#: A decimal number as written in text files and options ("12", "-.5", "1.27e-4").
NUMBER_PATTERN = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_LENGTH = re.compile(rf"\s*({NUMBER_PATTERN})\s*([^\d\s.+-][^\s]*)?\s*")


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


def size_in_metres(size) -> float:
    """Scan length [m] from a number (metres) or a string with a unit; must be > 0."""
    length = parse_length(size) if isinstance(size, str) else float(size)
    if not (np.isfinite(length) and length > 0):
        raise InputError(f"scan size must be > 0, got {size!r}")
    return length
