"""The surface named on a command line: the reading of SURFACE and its reader options, shared by
the subcommands (``roughfriction.scripts.cli``) and the ``fem`` command
(``roughfriction.scripts.fem``) without either importing the other."""

from __future__ import annotations


def surface_from_args(args):
    """Load the surface named on the command line (file or built-in)."""
    from roughfriction.geometry.readers import load_surface

    return load_surface(
        args.surface,
        size=args.size,
        height_unit=args.height_unit,
        lateral_unit=args.lateral_unit,
        fill=args.fill,
        square="crop" if args.crop else None,
        pixels="resample" if args.resample_pixels else None,
        detrend=not args.no_detrend,
    )
