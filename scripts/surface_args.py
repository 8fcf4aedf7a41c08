"""The surface named on a command line: the reading of SURFACE and its reader options, shared by
the subcommands (``roughfriction.scripts.cli``) and the ``fem`` command
(``roughfriction.scripts.fem``) without either importing the other."""

from __future__ import annotations

import argparse
import math

from roughfriction.errors import InputError

#: The reader flags (argparse dest -> flag) that apply to files only, with their unset values.
READER_FLAGS = {"size": ("--size", None), "height_unit": ("--height-unit", None),
                "lateral_unit": ("--lateral-unit", None), "fill": ("--fill", None),
                "crop": ("--crop", False), "resample_pixels": ("--resample-pixels", False),
                "no_detrend": ("--no-detrend", False), "allow_flat": ("--allow-flat", False)}


def reader_flags(args) -> dict:
    """The values of :data:`READER_FLAGS` in parsed ``args`` (argparse dest -> value); a flag
    the parser does not define counts as unset."""
    return {dest: getattr(args, dest, unset) for dest, (_, unset) in READER_FLAGS.items()}


def reader_options(args):
    """The ``ReaderOptions`` of the reader flags in parsed ``args``."""
    from roughfriction.geometry.readers import ReaderOptions

    flags = reader_flags(args)
    return ReaderOptions(
        size=flags["size"],
        height_unit=flags["height_unit"],
        lateral_unit=flags["lateral_unit"],
        fill=flags["fill"],
        square="crop" if flags["crop"] else None,
        pixels="resample" if flags["resample_pixels"] else None,
        detrend=not flags["no_detrend"],
        allow_flat=flags["allow_flat"],
    )


def surface_from_args(args):
    """Load the surface named on the command line (file or built-in); reader flags given with
    a built-in name are refused by their flag names."""
    from roughfriction.geometry.generate import builtin_names
    from roughfriction.geometry.readers import load_surface

    if args.surface in builtin_names():
        flags = reader_flags(args)
        given = [flag for dest, (flag, unset) in READER_FLAGS.items() if flags[dest] != unset]
        if given:
            raise InputError(f"{', '.join(given)} apply to surface files, not to the built-in "
                             f"surface {args.surface!r}")
        return load_surface(args.surface)
    return load_surface(args.surface, reader_options(args))


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


#: Fewest surface cells per side of an FEM grid (``geometry.surface.validate_grid_points``).
MIN_CELLS = 4


def surface_cells(text: str) -> int:
    """argparse type of ``--n``: surface cells per side of the FEM grid, an integer >= 4 (on
    the periodic grid, N cells per side on N points)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"surface cells per side must be an integer, got "
                                         f"{text!r}") from None
    if value < MIN_CELLS:
        raise argparse.ArgumentTypeError(f"surface cells per side must be >= {MIN_CELLS}, got "
                                         f"{value}")
    return value
