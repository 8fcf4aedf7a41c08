"""The ``fem`` command: deterministic FEM of a rough surface pressed and slid by a rigid flat.

    mpirun -n 2 roughfriction fem G5 --load 0.155 --n 32 --json

Grid: ``--n N`` is the number of surface cells per side of the FEM block (its top has N x N
cells on (N + 1)^2 nodes, the last row and column closing the surface periodically, as in the
paper). N equal to the surface's points uses the heights as they are; a smaller N re-grids the
surface over its scan length with a bicubic spline (``geometry.surface.resample``); a larger N
refines it by Fourier interpolation (``geometry.surface.spectral_interpolate``, the paper's
spectral interpolation). Coarsening changes the surface (fewer, wider-spaced points: lower
slopes), so results at different N are different surfaces, not a mesh-convergence study: the
command says so on stderr with the psi of both. ``--window K`` meshes instead an N x N window of
the surface at its own spacing (``best``: the window whose psi is nearest the whole surface's),
the right choice for i.i.d. heights, whose windows have the surface's psi.

Error on request: ``--tol REL`` runs the same (bilinear) surface on meshes 1x, 2x, 4x, ...
finer (``studies.refinement.run_ladder``) until the estimated relative error of mu_s is at most
REL; ``--max-level``, ``--max-memory`` and ``--max-time`` bound it, and when they stop it short
the finest level is written with its estimate and the command exits 3 with one line. ``--refine``
is the same ladder through 2x without a tolerance. ``--ladder adaptive`` (default) refines each
level where the level before was in contact (``geometry.adaptive``), ``--ladder uniform``
everywhere.

A run writes every step and its inputs to an HDF5 file (``--output``, on rank 0) and returns the
JSON summary. If the preload or the sliding does not converge, the partial results are written,
labelled unconverged, and a ``ConvergenceError`` with the reason is raised (the CLI exits 3);
mu_s is never reported from an unconverged state.

This module is the command's argument parsing and naming only: the case, its guards and its
notes are ``studies.fem_input``'s (as for ``studies.api.fem_case`` and ``load_case``), the run,
its outputs, the reuse of a stored result and the ladder ``studies.fem_request``'s (as for
``studies.api.run_fem``).

Files: every output path is checked on every rank before anything is solved (a bad one is one
``InputError`` on all ranks, not a rank left waiting); the default results name encodes what
defines the run (:func:`default_output`); an existing results or fields file is replaced only
with ``--overwrite``; results and fields are written under temporary names and renamed when
complete, so a killed run leaves the previous files as they were.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path

from roughfriction.case import FemCase
from roughfriction.errors import InputError
from roughfriction.files import agreed
from roughfriction.solver.results import CANDIDATE_GAP_SHARE
from roughfriction.studies.fem_input import InputNames, case_from_config, read_config
from roughfriction.studies.fem_request import (
    FemOutputs,
    check_max_level,
    check_tolerance,
    finest_factor,
    ladder_labels,
    request_digest,
    requested_ladder,
    run_request,
)
from roughfriction.studies.refinement import DEFAULT_MAX_LEVEL, LADDERS, LadderLimits

#: How the command's refusals name its inputs.
COMMAND_NAMES = InputNames(load="--load FSTAR", n="--n", window="--window", case_file="--config",
                           overwrite="--overwrite", output="--output", fields="--xdmf")


def add_fem_arguments(parser: argparse.ArgumentParser) -> None:
    """The FEM options (the surface argument and reader options are added by the caller)."""
    parser.add_argument("--load", type=float, metavar="FSTAR",
                        help="dimensionless normal load F* = F_n / (A_n S_y)")
    from roughfriction.scripts.surface_args import surface_cells

    parser.add_argument("--n", type=surface_cells, metavar="N",
                        help="surface cells per side of the FEM grid (default: the surface's "
                        "points per side)")
    parser.add_argument("--window", metavar="K",
                        help="with --n below the surface's points: mesh the K-th N x N window of "
                        "the surface at its own spacing (1, 2, ... row by row, or 'best': psi "
                        "nearest the whole surface's) instead of re-gridding it")
    parser.add_argument("--elastic", action="store_true", default=None,
                        help="linear elastic solid (no plasticity)")
    parser.add_argument("--normal-only", action="store_true", default=None,
                        help="preload only (mu_s is null)")
    parser.add_argument("--refine", action="store_true",
                        help="also run a 2x finer mesh of the same (bilinear) surface and report "
                        "its mu_s with its certified error (mu_s_coarse, mu_s_error; see "
                        "docs/verification.md); the same as --tol with --max-level 1, without "
                        "a tolerance")
    parser.add_argument("--tol", type=_fraction, metavar="REL",
                        help="run meshes 1x, 2x, 4x, ... finer until the certified relative "
                        "error of mu_s (normal-only: of A_r/A_n) is at most REL, e.g. 0.03: "
                        "from the last two levels' difference and the finest level's contact "
                        "resolution; exit 3 with the best value when a limit stops it")
    parser.add_argument("--ladder", choices=LADDERS,
                        help="with --tol or --refine: each level refines the contact of the one "
                        "before 2x (adaptive, the default: the cells around its nodes in "
                        "contact after the preload or at inception, plus one cell, and at its "
                        f"nodes within {CANDIDATE_GAP_SHARE:g} Rq of the flat) or the whole "
                        "surface (uniform)")
    parser.add_argument("--max-level", type=_level, metavar="L",
                        help=f"with --tol: finest mesh 2^L times finer (default "
                        f"{DEFAULT_MAX_LEVEL})")
    parser.add_argument("--max-memory", type=_positive, metavar="GB",
                        help="with --tol: largest estimated memory of a level, all ranks "
                        "together (default: what is available)")
    parser.add_argument("--max-time", type=_positive, metavar="MIN",
                        help="with --tol: wall time of all levels together, in minutes (a level "
                        "is not started when it is predicted to overrun)")
    parser.add_argument("--xdmf", metavar="DIR",
                        help="write fields to DIR/fields.xdmf (and DIR/fields.h5)")
    parser.add_argument("--msh", metavar="PATH", help="write the block as a gmsh mesh file (.msh)")
    parser.add_argument("--output", metavar="FILE",
                        help="HDF5 results file (default results/fem/<surface>_F<load>_N<n>"
                        "[_<options>]_<digest>.h5, the digest of everything that defines the "
                        "run: surface heights, window or re-gridding, case file, --refine)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace existing results and fields files (else refused)")
    parser.add_argument("--config", metavar="TOML",
                        help="case file: load, n, elastic, normal_only and tables [mesh], "
                        "[solver], [material] (SI units); flags override it")
    parser.add_argument("--json", action="store_true", help="one JSON object on stdout")


def _positive(text: str) -> float:
    """argparse type: a finite number > 0."""
    from roughfriction.scripts.surface_args import positive_float

    return positive_float(text)


def _fraction(text: str) -> float:
    """argparse type: a relative tolerance in (0, 1) (``fem_request.check_tolerance``)."""
    return _argument(check_tolerance, _positive(text))


def _level(text: str) -> int:
    """argparse type: a level >= 1, 2^L times finer (``fem_request.check_max_level``)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    return _argument(check_max_level, value)


def _argument(check, value):
    """``check(value)``, its InputError as argparse's error of the argument."""
    try:
        return check(value)
    except InputError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def case_from_args(args, surface, comm=None, limits: LadderLimits | None = None) -> FemCase:
    """The FemCase of the command line: its flags over its case file
    (``fem_input.case_from_config``), the surface's notes and warnings on stderr (rank 0).
    With ``comm`` (the run's communicator), a case file that one rank cannot read stops every
    rank, and the memory gate counts its ranks and the finest level ``limits`` is sure to run
    (``fem_request.finest_factor``)."""
    config = (read_config(args.config) if comm is None
              else agreed(comm, lambda: read_config(args.config)))
    case, meshed = case_from_config(
        config, surface, load=args.load, n=args.n, window=getattr(args, "window", None),
        elastic=args.elastic, normal_only=args.normal_only, measured=is_measured(args),
        comm=comm, finest_factor=finest_factor(limits), names=COMMAND_NAMES)
    if comm is None or comm.rank == 0:
        for line in meshed.lines():
            print(line, file=sys.stderr)
    return case


def is_measured(args) -> bool:
    """Whether the command's surface is a scan read from a file (not a built-in surface)."""
    from roughfriction.geometry.generate import builtin_names

    return args.surface not in builtin_names()


#: Folder of the default results files.
RESULTS_DIR = Path("results/fem")
#: Hex digits of the digest in a default results name.
DIGEST_LENGTH = 8


def run_labels(args) -> tuple[str, ...]:
    """What the command line adds to the case in the results name and the request digest: the
    window (``window3``, ``windowbest``), then the ladder's (``fem_request.ladder_labels``:
    ``refined``, ``tol0.03_L3``, ``uniform``)."""
    window = getattr(args, "window", None)
    return ((f"window{window}",) if window is not None else ()) + ladder_labels(
        ladder_limits(args))


def default_output(case: FemCase, labels: tuple[str, ...] = ()) -> Path:
    """``results/fem/<surface>_F<load>_N<n>[_elastic][_normal][_<label>...]_<digest>.h5``.

    The stem is for reading; the digest (the first :data:`DIGEST_LENGTH` hex digits of
    ``fem_request.request_digest``) tells apart runs the stem does not (another window or
    re-gridding, a case file, ``--refine``), so two different runs never share a name.
    """
    name = re.sub(r"[^A-Za-z0-9.+-]", "_", case.surface.name or "surface")
    options = [label for label, chosen in (("elastic", case.solver.elastic),
                                           ("normal", case.loading.normal_only)) if chosen]
    stem = "_".join([name, f"F{case.loading.load_star:g}", f"N{case.surface.n}", *options,
                     *labels])
    return RESULTS_DIR / f"{stem}_{request_digest(case, labels)[:DIGEST_LENGTH]}.h5"


def outputs_from_args(args, case: FemCase) -> FemOutputs:
    """The outputs named by the command line (default results name: :func:`default_output`
    of ``case``, the case as meshed, whose folder is created; a folder named by the user
    must exist); with ``--refine`` level 0 goes to ``<results>_coarse.h5``."""
    labels = run_labels(args)
    if not args.output:
        RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    results = Path(args.output) if args.output else default_output(case, labels)
    coarse = (results.with_name(f"{results.stem}_coarse{results.suffix}")
              if args.refine else None)
    return FemOutputs(results, request_digest(case, labels), coarse,
                      Path(args.xdmf) if args.xdmf else None,
                      Path(args.msh) if args.msh else None, COMMAND_NAMES)


def run_fem(args) -> dict:
    """Run the FEM case named by the command line (``fem_request.run_request``); return the
    JSON summary.

    Raises
    ------
    InputError
        Bad input or an inverted mesh.
    ConvergenceError
        A run that did not converge (after writing the partial results); with ``--tol``, a
        tolerance not met (``ToleranceNotMet``, after writing the finest level).
    """
    from mpi4py import MPI
    from roughfriction.scripts.surface_args import surface_from_args

    comm = MPI.COMM_WORLD
    limits = requested_ladder(None, ladder_limits(args), comm)
    case = case_from_args(args, agreed(comm, lambda: surface_from_args(args)), comm, limits)
    return run_request(case, outputs_from_args(args, case), limits, comm, args.overwrite)


def ladder_limits(args) -> LadderLimits | None:
    """The levels the command line asks for (``--tol`` and its limits; ``--refine``: levels 0
    and 1 without a tolerance), None for a single run; refused: ladder flags without a
    ladder, and ``--refine`` with ``--tol`` or its limits."""
    tolerance, refine = getattr(args, "tol", None), getattr(args, "refine", False)
    limited = [f"--{name.replace('_', '-')}" for name in ("max_level", "max_memory", "max_time")
               if getattr(args, name, None) is not None]
    if tolerance is None and not refine:
        if getattr(args, "ladder", None) is not None:
            raise InputError("--ladder applies to --tol or --refine")
        if limited:
            raise InputError(f"{', '.join(limited)} limit{'s' * (len(limited) == 1)} --tol: "
                             "give a tolerance")
        return None
    if refine and (tolerance is not None or limited):
        raise InputError("--refine is the two-level shortcut: give --tol (with its limits) or "
                         "--refine, not both")
    return LadderLimits(tolerance, 1 if refine else (args.max_level or DEFAULT_MAX_LEVEL),
                        args.max_memory or math.inf, 60.0 * (args.max_time or math.inf),
                        ladder=getattr(args, "ladder", None) or LADDERS[0])
