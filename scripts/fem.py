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
labelled unconverged, and an ``InputError`` with the reason is raised (the CLI exits non-zero);
mu_s is never reported from an unconverged state.

Files: every output path is checked on every rank before anything is solved (a bad one is one
``InputError`` on all ranks, not a rank left waiting); the default results name encodes what
defines the run (:func:`default_output`); an existing results or fields file is replaced only
with ``--overwrite``; results and fields are written under temporary names and renamed when
complete, so a killed run leaves the previous files as they were.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import re
import sys
import tomllib
from dataclasses import dataclass, fields
from pathlib import Path

from roughfriction.case import FemCase, Loading, MeshOptions, SolverOptions
from roughfriction.errors import ConvergenceError, InputError
from roughfriction.files import agreed, check_results_file, check_writable_directory
from roughfriction.geometry.surface import Surface, surface_on_fem_grid, validate_grid_points
from roughfriction.material import Material
from roughfriction.plausibility import material_from_table, material_record, result_warnings
from roughfriction.solver.results import CANDIDATE_GAP_SHARE
from roughfriction.studies.refinement import (
    DEFAULT_MAX_LEVEL,
    LADDERS,
    LadderLimits,
    LevelRun,
    ToleranceNotMet,
    level_memory_gb,
    run_ladder,
)

CONFIG_TABLES = {"mesh": MeshOptions, "solver": SolverOptions, "material": Material}
CONFIG_KEYS = {"load", "n", "elastic", "normal_only"}


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
                        "its mu_s with an error estimate (mu_s_coarse, mu_s_extrapolated, "
                        "mu_s_error; see docs/verification.md); the same as --tol with "
                        "--max-level 1, without a tolerance")
    parser.add_argument("--tol", type=_fraction, metavar="REL",
                        help="run meshes 1x, 2x, 4x, ... finer until the estimated relative "
                        "error of mu_s (normal-only: of A_r/A_n) is at most REL, e.g. 0.03; "
                        "order observed from the last three levels, assumed first order with "
                        "two; exit 3 with the best estimate when a limit stops it")
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
    """argparse type: a relative tolerance in (0, 1)."""
    value = _positive(text)
    if value >= 1.0:
        raise argparse.ArgumentTypeError(f"a relative error below 1 (e.g. 0.03), got {text}")
    return value


def _level(text: str) -> int:
    """argparse type: a level >= 1 (2^L times finer)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1 (an estimate needs two levels), got {text}")
    return value


def read_config(path: str | None) -> dict:
    """The case file as a dict (empty without one); unknown keys are refused."""
    if path is None:
        return {}
    try:
        with open(path, "rb") as file:
            config = tomllib.load(file)
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise InputError(f"cannot read case file {path}: {error}") from None
    unknown = set(config) - CONFIG_KEYS - set(CONFIG_TABLES)
    for table, kind in CONFIG_TABLES.items():
        known = {f.name for f in fields(kind)}
        unknown |= {f"{table}.{key}" for key in config.get(table, {}) if key not in known}
    if unknown:
        raise InputError(f"unknown keys in {path}: {', '.join(sorted(unknown))}")
    return config


def case_from_args(args, surface: Surface, comm=None) -> FemCase:
    """Build the FemCase from flags over the case file; with ``comm`` (the run's
    communicator), a case file that one rank cannot read stops every rank, and an ``--n``
    whose run would not fit in memory is refused before re-gridding."""
    if comm is not None:
        from roughfriction.solver.memory import check_memory
    config = (read_config(args.config) if comm is None
              else agreed(comm, lambda: read_config(args.config)))

    def setting(name):
        flag = getattr(args, name)
        return flag if flag is not None else config.get(name)

    load = setting("load")
    if load is None:
        raise InputError("the normal load is required: --load FSTAR (or load = ... in --config)")
    solver = dict(config.get("solver", {}))
    if setting("elastic") is not None:
        solver["elastic"] = bool(setting("elastic"))
    try:
        mesh = MeshOptions(**config.get("mesh", {}))
        n = setting("n")
        if n is not None:
            n = validate_grid_points(n)
            if comm is not None:
                check_memory(n * (2 if getattr(args, "refine", False) else 1), mesh, comm)
        material = material_from_table(config.get("material", {}))
        loading = Loading(float(load), normal_only=bool(setting("normal_only")))
        return FemCase(
            surface=meshed_surface(surface, n, getattr(args, "window", None), material, comm,
                                   measured=is_measured(args)),
            loading=loading,
            material=material,
            mesh=mesh,
            solver=SolverOptions(**solver),
        )
    except TypeError as error:
        raise InputError(f"bad case settings: {error}") from None


def is_measured(args) -> bool:
    """Whether the command's surface is a scan read from a file (not a built-in surface)."""
    from roughfriction.geometry.generate import builtin_names

    return args.surface not in builtin_names()


def meshed_surface(surface: Surface, n: int | None, window: str | None, material: Material,
                   comm=None, measured: bool = False) -> Surface:
    """The surface the FEM meshes on n x n cells: window ``window`` ('best' or 1, 2, ...) at
    the surface's own spacing (of a ``measured`` scan: detrended, its periodic seam checked),
    or the surface re-gridded (``surface_on_fem_grid``), which is noted on stderr (rank 0) with
    the psi (for ``material``) before and after. Then :func:`surface_notes` on stderr."""
    from roughfriction.studies.api import regrid_note
    from roughfriction.studies.paper import surface_window

    if window is None:
        meshed = surface_on_fem_grid(surface, n)
        notes = [f"note: {line}" for line in (regrid_note(surface, meshed, material),) if line]
    else:
        if n is None or n >= surface.n:
            raise InputError(f"--window needs --n below the surface's {surface.n} points per side")
        index = None if window == "best" else _window_index(window)
        meshed, notes = surface_window(surface, n, index, measured=measured), []
    notes += surface_notes(meshed, measured and window is None)
    if comm is None or comm.rank == 0:
        for line in notes:
            print(line, file=sys.stderr)
    return meshed


def _window_index(window: str) -> int:
    """The 0-based index of ``--window K`` (K = 1, 2, ...)."""
    try:
        index = int(window)
    except ValueError:
        raise InputError(f"--window takes 'best' or a window number, got {window!r}") from None
    if index < 1:
        raise InputError(f"--window counts from 1, got {index}")
    return index - 1


def surface_notes(meshed: Surface, whole_scan: bool) -> list[str]:
    """Warnings on the surface as meshed: an RMS slope beyond the small-strain FEM
    (``geometry.statistics.small_strain_slope``) and, for a ``whole_scan`` meshed as
    measured, a periodic seam that is a step of its own (a window says it itself)."""
    from roughfriction.geometry.statistics import periodic_seam_warning, small_strain_slope

    found = [small_strain_slope(meshed)[1], periodic_seam_warning(meshed) if whole_scan else None]
    return [f"warning: {line}" for line in found if line]


#: Folder of the default results files.
RESULTS_DIR = Path("results/fem")
#: Hex digits of the digest in a default results name.
DIGEST_LENGTH = 8


def run_labels(args) -> tuple[str, ...]:
    """What the command line adds to the case in the results name: the window (``window3``,
    ``windowbest``), ``refined`` (the run is the 2x finer mesh), the tolerance with its
    finest level (``tol0.03_L3``) and, for either, a ``uniform`` ladder."""
    window = getattr(args, "window", None)
    tolerance = getattr(args, "tol", None)
    refine = getattr(args, "refine", False)
    level = getattr(args, "max_level", None) or DEFAULT_MAX_LEVEL
    uniform = (refine or tolerance is not None) and getattr(args, "ladder", None) == "uniform"
    return ((f"window{window}",) if window is not None else ()) + (
        ("refined",) if refine else ()) + (
        (f"tol{tolerance:g}_L{level}",) if tolerance is not None else ()) + (
        ("uniform",) if uniform else ())


def request_digest(case: FemCase, labels: tuple[str, ...] = ()) -> str:
    """SHA-256 (hex) of what a ``fem`` command asks for: the case's inputs (surface heights
    and spacing, load, material, mesh and solver options) and ``labels`` (:func:`run_labels`)."""
    defined = json.dumps({"inputs": case.inputs(), "labels": list(labels)}, sort_keys=True)
    return hashlib.sha256(defined.encode()).hexdigest()


def default_output(case: FemCase, labels: tuple[str, ...] = ()) -> Path:
    """``results/fem/<surface>_F<load>_N<n>[_elastic][_normal][_<label>...]_<digest>.h5``.

    The stem is for reading; the digest (the first :data:`DIGEST_LENGTH` hex digits of
    :func:`request_digest`) tells apart runs the stem does not (another window or re-gridding,
    a case file, ``--refine``), so two different runs never share a name.
    """
    name = re.sub(r"[^A-Za-z0-9.+-]", "_", case.surface.name or "surface")
    options = [label for label, chosen in (("elastic", case.solver.elastic),
                                           ("normal", case.loading.normal_only)) if chosen]
    stem = "_".join([name, f"F{case.loading.load_star:g}", f"N{case.surface.n}", *options,
                     *labels])
    return RESULTS_DIR / f"{stem}_{request_digest(case, labels)[:DIGEST_LENGTH]}.h5"


@dataclass(frozen=True)
class FemOutputs:
    """Where a ``fem`` command writes, and what it was asked for.

    Attributes
    ----------
    results : pathlib.Path
        The results file (with ``--refine``: of the finer mesh).
    request : str
        :func:`request_digest` of the command: stored in the results file, so that the same
        command run again finds its result.
    coarse : pathlib.Path or None
        With ``--refine``: the coarse mesh's results file.
    fields : pathlib.Path or None
        The ``--xdmf`` directory (``fields.xdmf`` and ``fields.h5`` in it).
    """

    results: Path
    request: str
    coarse: Path | None = None
    fields: Path | None = None

    @classmethod
    def from_args(cls, args, case: FemCase) -> FemOutputs:
        """The outputs named by the command line (default results name: :func:`default_output`
        of ``case``, the case as meshed, whose folder is created; a folder named by the user
        must exist)."""
        labels = run_labels(args)
        if not args.output:
            RESULTS_DIR.mkdir(parents=True, exist_ok=True)
        results = Path(args.output) if args.output else default_output(case, labels)
        coarse = (results.with_name(f"{results.stem}_coarse{results.suffix}")
                  if args.refine else None)
        return cls(results, request_digest(case, labels), coarse,
                   Path(args.xdmf) if args.xdmf else None)

    def reusable(self, overwrite: bool) -> dict | None:
        """The stored summary when the results file holds this request, converged, from this
        physics (the command prints it instead of running); None when there is none to reuse or
        ``overwrite``. A results file of another request, of other physics or unconverged is
        refused (:class:`InputError`, naming which) unless ``overwrite``; so is any file
        when fields are asked for (``--xdmf``: the run is needed)."""
        from roughfriction.studies.physics import physics_stamp, physics_version
        from roughfriction.studies.results_file import stored_run

        if overwrite or not self.results.is_file() or self.fields is not None:
            return None
        try:
            stored = stored_run(self.results)
        except OSError:
            raise InputError(f"{self.results} exists and is not a results file: pass "
                             "--overwrite to replace it, or name another --output") from None
        physics = physics_version()
        if stored.request != self.request:
            why = "holds another case"
        elif stored.physics != physics:
            why = (f"is stale: computed by other physics "
                   f"({physics_stamp(stored.physics) or 'unknown'}, this code "
                   f"{physics_stamp(physics)})")
        elif not stored.converged or stored.summary.get("error_tolerance_met") is False:
            why = "holds this case unconverged or short of its tolerance"
        else:
            return stored.summary
        raise InputError(f"{self.results} {why}: pass --overwrite to recompute, or name "
                         "another --output")

    def check(self, overwrite: bool) -> None:
        """Refuse (:class:`InputError`) an output that cannot be written, or that exists when
        ``overwrite`` is false. Creates nothing."""
        existing = [path for path in (self.results, self.coarse) if path is not None]
        for path in existing:
            check_results_file(path)
        if self.fields is not None:
            check_writable_directory(self.fields)
            existing.append(self.fields / "fields.xdmf")
        present = [str(path) for path in existing if path.exists()]
        if present and not overwrite:
            raise InputError(f"{' and '.join(present)} already exist{'s' * (len(present) == 1)}"
                             ": pass --overwrite to replace, or name another --output/--xdmf")


def run_fem(args) -> dict:
    """Run the FEM case named by the command line; return the JSON summary.

    Raises
    ------
    InputError
        Bad input or an inverted mesh.
    ConvergenceError
        A run that did not converge (after writing the partial
        results); with ``--tol``, a tolerance not met (:class:`ToleranceNotMet`, after
        writing the finest level).
    """
    from mpi4py import MPI
    from roughfriction.geometry.statistics import surface_statistics
    from roughfriction.scripts.surface_args import surface_from_args
    from roughfriction.solver.block import write_block_msh
    from roughfriction.solver.run import run, with_blend_layers_needed

    comm = MPI.COMM_WORLD
    limits = ladder_limits(args, comm)
    case = case_from_args(args, agreed(comm, lambda: surface_from_args(args)), comm)
    outputs = FemOutputs.from_args(args, case)
    stored = None if args.msh else agreed(comm, lambda: outputs.reusable(args.overwrite))
    if stored is not None:
        if comm.rank == 0:
            print(f"reused: {outputs.results} holds this case, computed by this code "
                  "(--overwrite recomputes it)", file=sys.stderr)
        _print_warnings(stored, comm)
        return stored
    agreed(comm, lambda: outputs.check(args.overwrite))
    output = outputs.results
    meshed = {"psi_meshed": surface_statistics(case.surface, case.material).psi,
              "material": material_record(case.material)}
    if args.msh:
        meshed_case = with_blend_layers_needed(case, lambda note: None)  # the run says it
        write_block_msh(case.surface.heights, case.surface.spacing, meshed_case.mesh, args.msh,
                        comm)
    if limits is None:
        outcome = run(case, comm, counted_progress(case, comm), xdmf_directory=outputs.fields)
        summary = with_warnings({**outcome.result.summary(), **meshed}, case)
        _save(output, case, outcome, comm, {**meshed, "warnings": summary["warnings"]},
              outputs.request)
        _say_results(output, comm)
        _print_warnings(summary, comm)
        return summary
    return run_levels(case, outputs, limits, meshed, comm)


def ladder_limits(args, comm) -> LadderLimits | None:
    """The levels the command line asks for (``--tol`` and its limits; ``--refine``: levels 0
    and 1 without a tolerance), None for a single run. The memory limit is the smaller of
    ``--max-memory`` and what is available to ``comm``'s ranks."""
    from roughfriction.solver.memory import available_memory_gb

    tolerance = getattr(args, "tol", None)
    limited = [f"--{name.replace('_', '-')}" for name in ("max_level", "max_memory", "max_time")
               if getattr(args, name, None) is not None]
    if tolerance is None and not args.refine:
        if getattr(args, "ladder", None) is not None:
            raise InputError("--ladder applies to --tol or --refine")
        if limited:
            raise InputError(f"{', '.join(limited)} limit{'s' * (len(limited) == 1)} --tol: "
                             "give a tolerance")
        return None
    if args.refine and (tolerance is not None or limited):
        raise InputError("--refine is the two-level shortcut: give --tol (with its limits) or "
                         "--refine, not both")
    max_memory = min(args.max_memory or math.inf, available_memory_gb(comm))
    return LadderLimits(tolerance, 1 if args.refine else (args.max_level or DEFAULT_MAX_LEVEL),
                        max_memory, 60.0 * (args.max_time or math.inf),
                        ladder=getattr(args, "ladder", None) or LADDERS[0])


def run_levels(case: FemCase, outputs: FemOutputs, limits: LadderLimits, meshed: dict,
               comm) -> dict:
    """Run the case on finer and finer meshes (:func:`studies.refinement.run_ladder`, uniform
    or contact-adaptive as ``limits.ladder`` says): each
    level is written as soon as its estimate is known to ``outputs.results`` (``--refine``:
    level 0 to ``outputs.coarse``), the finest replacing the one before; fields (``--xdmf``)
    are those of level 0. Returns the finest level's summary with the estimate and the
    per-level columns; raises :class:`ToleranceNotMet` (exit 3, after writing) when a limit
    stopped the ladder short of the tolerance or of an estimate."""
    from roughfriction.solver.results import touched_nodes
    from roughfriction.solver.run import near_flat, run

    finest = {}  # the summary of the last level run
    done: list[dict] = []  # per level run: wall time [s], reduced dofs, cut steps

    def run_level(level: int, level_case: FemCase) -> LevelRun:
        if comm.rank == 0:
            print(level_header(level, level_case, limits, done, comm.size), file=sys.stderr)
        fem_run = run(level_case, comm, counted_progress(level_case, comm),
                      xdmf_directory=outputs.fields if level == 0 else None)
        summary = fem_run.result.summary()
        finest.update(summary)
        done.append({"wall_s": summary["wall_s"], "cut_steps": summary["cut_steps"],
                     "reduced_dofs": fem_run.result.sizes["reduced_dofs"]})
        path = outputs.coarse if outputs.coarse is not None and level == 0 else outputs.results
        request = outputs.request if path == outputs.results else ""  # the coarse answers none
        if not fem_run.result.converged:
            _save(path, level_case, fem_run, comm, meshed, request)  # raises ConvergenceError

        def save(ladder) -> None:
            extra = (meshed if path == outputs.coarse
                     else {**ladder_report(ladder.summary(), done), **meshed})
            flags = with_warnings({**summary, **extra}, level_case)["warnings"]
            _save(path, level_case, fem_run, comm, {**extra, "warnings": flags}, request)

        key = "area_ratio_normal" if level_case.loading.normal_only else "mu_s"
        sizes = fem_run.result.sizes
        return LevelRun(summary[key], sizes["reduced_dofs"], sizes["cells"], save,
                        touched_nodes(fem_run.maps), near_flat(level_case, fem_run))

    ladder = run_ladder(case, run_level, limits,
                        lambda level_case: level_memory_gb(level_case, comm.size))
    if not ladder.met:
        raise ToleranceNotMet(f"{ladder.shortfall()} (results in {outputs.results})")
    summary = with_warnings({**finest, **ladder_report(ladder.summary(), done), **meshed}, case)
    _say_results(outputs.results, comm)
    _print_warnings(summary, comm)
    if comm.rank == 0:
        print(f"note: {summary['error_estimate']}", file=sys.stderr)
    return summary


def level_header(level: int, level_case: FemCase, limits: LadderLimits, done: list[dict],
                 ranks: int) -> str:
    """The line before a level of the ladder: which of how many, its mesh factor, reduced
    dofs, estimated memory [GB] and (after level 0) predicted wall time [min], the last
    level's time scaled by the ratio of dofs."""
    from roughfriction.studies.refinement import LADDER_RATIO, level_dofs

    dofs = level_dofs(level_case)
    predicted = (f", ~{done[-1]['wall_s'] * dofs / done[-1]['reduced_dofs'] / 60:.2g} min"
                 if done else "")
    return (f"level {level} of at most {limits.max_level} ({LADDER_RATIO ** level}x mesh): "
            f"{dofs} reduced dofs, ~{level_memory_gb(level_case, ranks):.2g} GB{predicted}")


def ladder_report(ladder_summary: dict, done: list[dict]) -> dict:
    """The ladder's summary with the cut steps of every level (``levels.cut_steps`` and
    their sum ``cut_steps_all_levels``) and ``error_estimate``: what the estimate is and how
    far it has been shown to hold."""
    from roughfriction.studies.calibration import coverage_statement

    levels = {**ladder_summary["levels"], "cut_steps": [one["cut_steps"] for one in done]}
    return {**ladder_summary, "levels": levels,
            "cut_steps_all_levels": sum(one["cut_steps"] for one in done),
            "error_estimate": coverage_statement()}


def counted_progress(case: FemCase, comm):
    """The run's progress on stderr (rank 0), its steps numbered, the preload's share of F_n
    and time left, the sliding's slipping nodes (``solver.progress.CountedProgress``)."""
    from roughfriction.solver.progress import CountedProgress

    return CountedProgress(comm, case.normal_force)


def _save(output: Path, case: FemCase, fem_run, comm, extra: dict, request: str) -> None:
    """Write the run's results file (``extra``: added to its summary; ``request``: the
    command's :func:`request_digest`) and refuse an unconverged run
    (:func:`_check_converged`)."""
    from roughfriction.studies.results_file import save_run

    save_run(output, case, fem_run, comm, extra=extra, request=request)
    _check_converged(fem_run, output)


def _say_results(output: Path, comm) -> None:
    """Name the results file on stderr (rank 0), once the command's answer is in it."""
    if comm.rank == 0:
        print(f"results: {output}", file=sys.stderr)


def unresolved_warning(summary: dict) -> str | None:
    """A one-line warning for a run whose contact patches hold fewer than
    ``RELIABLE_CELLS_PER_PATCH`` grid cells of contact area each (summary ``reliable`` false),
    else None."""
    from roughfriction.solver.results import RELIABLE_CELLS_PER_PATCH

    if summary.get("reliable") is not False:
        return None
    return (f"the contact patches hold {summary['cells_per_patch']:.2g} grid cells of contact "
            f"area each (< {RELIABLE_CELLS_PER_PATCH}): they are not resolved, and the area and "
            "mu_s are mesh-dependent (docs/verification.md); --tol 0.03 refines the mesh until "
            "the estimated error of mu_s is 3 %, or read the result as unreliable")


def with_warnings(summary: dict, case: FemCase) -> dict:
    """``summary`` with ``warnings``: the result's flags (``plausibility.result_warnings``)
    and :func:`unresolved_warning`, one line each."""
    flags = result_warnings(case.loading.load_star, [summary.get("area_ratio_normal"),
                                                     summary.get("area_ratio_sliding")])
    return {**summary, "warnings": flags + [line for line in (unresolved_warning(summary),)
                                            if line]}


def _print_warnings(summary: dict, comm) -> None:
    """Print the summary's ``warnings`` on stderr (rank 0)."""
    if comm.rank == 0:
        for line in summary.get("warnings", []):
            print(f"warning: {line}", file=sys.stderr)


def _check_converged(outcome, output: Path) -> None:
    """Refuse an unconverged run (after its partial results were written to ``output``)."""
    if not outcome.result.converged:
        raise ConvergenceError(f"FEM run did not converge: {outcome.result.message} "
                         f"(partial results in {output})")
