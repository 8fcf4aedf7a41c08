"""``python -m benchmarks COMMAND ...``, run from a checkout of the repository: the command line
of the benchmarks, whose work lives in the modules beside it (:mod:`benchmarks.multiscale`,
:mod:`benchmarks.fem`, :mod:`benchmarks.convergence`, :mod:`benchmarks.stress`,
:mod:`benchmarks.zone_cover`). Numbers go to ``results/bench/``; they are not timed tests.
Output (a table, or JSON with ``--json``), exit status and warnings as ``roughfriction``'s
(:mod:`roughfriction.scripts.cli`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from roughfriction.errors import InputError
from roughfriction.version import __version__

from benchmarks.batch import BENCH_DIR


def parse_case(text: str) -> tuple[str, float]:
    """'SURFACE:LOAD' (e.g. 'G5:0.155') as (surface, F*)."""
    surface, _, load = text.partition(":")
    try:
        return surface, float(load)
    except ValueError:
        raise InputError(f"a benchmark case is SURFACE:LOAD, e.g. G5:0.155, got {text!r}") from None


def add_bench_commands(parser: argparse.ArgumentParser) -> None:
    """The commands multiscale, fem, ladder, path, tol, error, stress, profile and zone under
    ``parser``."""
    from roughfriction.studies.paper import DEFAULT_FEM_N

    from benchmarks import convergence
    from benchmarks.fem import DEFAULT_SIZES as FEM_SIZES
    from benchmarks.fem import HEADLINE_CASES as FEM_CASES
    from benchmarks.tolerance import DEFAULT_TOLERANCE, TOLERANCE_CASES

    headline = [f"{surface}:{load:g}" for surface, load in FEM_CASES]
    kinds = parser.add_subparsers(dest="bench_command", metavar="COMMAND", required=True)
    multiscale = kinds.add_parser("multiscale", help="time the theory over Figs. 22-28's cases "
                                  f"-> {BENCH_DIR / 'multiscale.csv'}")
    multiscale.set_defaults(run=cmd_bench_multiscale)

    fem = kinds.add_parser("fem", help="FEM run time and memory per N, each run under mpirun "
                           f"-> {BENCH_DIR / 'fem.csv'}")
    fem.add_argument("--n", type=int, nargs="+", default=list(FEM_SIZES),
                     help=f"surface cells per side (default {' '.join(map(str, FEM_SIZES))})")
    fem.set_defaults(run=cmd_bench_fem)

    ladder = kinds.add_parser("ladder", help="levels 1x, 2x, ... of the error ladder "
                              "(roughfriction fem --tol), each ladder under mpirun: wall time, "
                              f"dofs and mu_s per level -> {BENCH_DIR / 'ladder.csv'}")
    ladder.add_argument("--n", type=int, nargs="+", default=[128],
                        help="surface cells per side (default 128)")
    ladder.add_argument("--max-level", type=int, default=1, metavar="L",
                        help="finest level, 2^L times finer (default 1)")
    ladder.add_argument("--ladder", nargs="+", choices=("adaptive", "uniform"),
                        default=["adaptive", "uniform"],
                        help="ladders to run (default both, the adaptive first)")
    ladder.add_argument("--window", type=int, nargs="+", metavar="K",
                        help="ladders of the surface's N x N windows K (1-based, as "
                        "roughfriction fem --window) instead of the whole surface re-gridded")
    ladder.add_argument("--csv", metavar="CSV", default=str(BENCH_DIR / "ladder.csv"),
                        help="the table (default %(default)s)")
    ladder.set_defaults(run=cmd_bench_ladder)

    path = kinds.add_parser("path", help="mu_s on the default load path against a finer one, "
                            f"each run under mpirun -> {BENCH_DIR / 'path.csv'}")
    path.add_argument("--n", type=int, default=64, help="surface cells per side (default 64)")
    path.set_defaults(run=cmd_bench_path)

    tolerance = kinds.add_parser("tol", help="roughfriction fem --tol per case, its wall time "
                                 "in plain elasticity solves of the same block timed just "
                                 f"before it -> {BENCH_DIR / 'tolerance.csv'}")
    tolerance.add_argument("--n", type=int, default=128,
                           help="surface cells per side (default 128)")
    tolerance.add_argument("--tol", type=float, default=DEFAULT_TOLERANCE,
                           help=f"relative tolerance (default {DEFAULT_TOLERANCE:g})")
    tolerance.set_defaults(run=cmd_bench_tolerance)
    tolerance_cases = [f"{surface}:{load:g}" for surface, load in TOLERANCE_CASES]
    for parser, cases in ((fem, headline), (ladder, headline[:1]), (path, headline),
                          (tolerance, tolerance_cases)):
        parser.add_argument("--ranks", type=int, default=2, help="MPI ranks (default 2)")
        parser.add_argument("--case", nargs="+", metavar="SURFACE:LOAD", default=cases,
                            help=f"surfaces and loads F* (default {' '.join(cases)})")

    error = kinds.add_parser("error", help="run time against error (run under mpirun) -> "
                             f"{BENCH_DIR / 'error.csv'}, error.png")
    error.add_argument("--quick", action="store_true",
                       help=f"{convergence.QUICK_N}^2 windows, levels {convergence.QUICK_LEVELS}; "
                       f"output to {BENCH_DIR / 'quick'}")
    error.add_argument("--n", type=int, metavar="N",
                       help=f"surface cells per side (default {convergence.BASE_N}, the "
                       "paper's surfaces on their own grid)")
    error.add_argument("--levels", type=int, nargs="+", metavar="K",
                       help=f"mesh levels, 0 the surface's grid (default {convergence.LEVELS})")
    error.add_argument("--knob-cases", nargs="*", metavar="CASE",
                       help="cases whose knobs are run (default "
                       f"{' '.join(repr(c) for c in convergence.KNOB_CASES)}; none: the levels "
                       "alone)")
    error.add_argument("--output", metavar="DIR", help="where error.csv and error.png go")
    error.add_argument("--runs", metavar="DIR", help="run cache directory")
    error.add_argument("--plan", action="store_true",
                       help="print the runs per N (cached, to compute) and exit")
    error.add_argument("--report", action="store_true",
                       help="write the tables and plot from the runs already in the cache, "
                       "computing nothing (the others are marked as not computed)")
    error.set_defaults(run=cmd_bench_error)

    matrix = kinds.add_parser("stress", help="the stress matrix (run under mpirun) -> "
                              f"{BENCH_DIR / 'stress.csv'}, stress.md")
    matrix.add_argument("--n", type=int, default=DEFAULT_FEM_N,
                        help=f"surface cells per side (default {DEFAULT_FEM_N})")
    matrix.add_argument("--output", metavar="DIR", default=str(BENCH_DIR),
                        help=f"where stress.csv and stress.md go (default {BENCH_DIR})")
    matrix.add_argument("--runs", metavar="DIR", help="run cache directory")
    matrix.add_argument("--plan", action="store_true",
                        help="print the runs (cached, to compute) and exit")
    matrix.add_argument("--rank-run", action="store_true",
                        help="only compute the rank-comparison run on this mpirun's ranks "
                             "(1, 2 or 4) into its own run cache under --output, for a later "
                             "stress run to read")
    matrix.set_defaults(run=cmd_bench_stress)
    profile = kinds.add_parser("profile", help="where one FEM run's time goes (run under "
                               "mpirun) -> " + str(BENCH_DIR / "profile_<case>.json"))
    profile.add_argument("surface", help="built-in surface (G1-G9 meshed as a window of their "
                         "own grid, the others re-gridded, as in the figures)")
    profile.add_argument("--load", type=float, required=True, help="F* = F_n / (A_n S_y)")
    profile.add_argument("--n", type=int, default=DEFAULT_FEM_N,
                         help=f"surface cells per side (default {DEFAULT_FEM_N})")
    profile.add_argument("--level", type=int, default=0, metavar="K",
                         help="profile level K of the case's uniform ladder, a mesh 2^K times "
                         "finer (default 0, the surface's grid)")
    profile.add_argument("--memory-csv", type=Path, metavar="CSV",
                         help="also put this version's memory rows into CSV (replacing its "
                         "earlier ones; the file's rows must be of the same case), e.g. "
                         "docs/bench/memory.csv with G5 --load 0.155 --n 64")
    profile.set_defaults(run=cmd_bench_profile)

    zone = kinds.add_parser("zone", help="how well zones built from a run's contact hold the "
                            "contact of a run on a mesh twice as fine -> "
                            f"{BENCH_DIR / 'zone_cover.csv'}")
    zone.add_argument("runs", nargs="+", metavar="RUN.h5",
                      help="pairs of results files: a run, then the same case on the 2x mesh")
    zone.add_argument("--margins", type=int, nargs="+", metavar="M", default=None,
                      help="zone margins in cells of the coarse grid (default 0-5)")
    zone.add_argument("--labels", nargs="+", metavar="TEXT",
                      help="one name per pair (default: surface, F* and the two grids)")
    zone.add_argument("--output", metavar="CSV", default=str(BENCH_DIR / "zone_cover.csv"),
                      help="the table (default %(default)s)")
    zone.set_defaults(run=cmd_bench_zone)
    for parser in (multiscale, fem, ladder, path, tolerance, error, matrix, profile, zone):
        parser.add_argument("--json", action="store_true", help="one JSON object on stdout")


def cmd_bench_multiscale(args) -> dict:
    """Theory timings (:func:`benchmarks.multiscale.bench_multiscale`)."""
    from benchmarks.multiscale import bench_multiscale

    return bench_multiscale()


def cmd_bench_fem(args) -> dict:
    """FEM benchmark rows (:mod:`benchmarks.fem`)."""
    from benchmarks.fem import benchmark_sizes

    cases = [parse_case(text) for text in args.case]
    return {"runs": benchmark_sizes(args.n, args.ranks, cases), "csv": str(BENCH_DIR / "fem.csv")}


def cmd_bench_ladder(args) -> dict:
    """Ladder benchmark rows (:func:`benchmarks.fem.benchmark_ladders`)."""
    from benchmarks.fem import benchmark_ladders

    if args.max_level < 1:
        raise InputError(f"--max-level must be at least 1, got {args.max_level}")
    cases = [parse_case(text) for text in args.case]
    rows = benchmark_ladders(args.n, args.ranks, args.max_level, args.ladder, cases,
                             args.window or (None,), Path(args.csv))
    return {"runs": rows, "csv": args.csv}


def cmd_bench_tolerance(args) -> dict:
    """``roughfriction fem --tol`` rows (:func:`benchmarks.tolerance.benchmark_tolerance`)."""
    from benchmarks.tolerance import benchmark_tolerance

    cases = [parse_case(text) for text in args.case]
    return {"runs": benchmark_tolerance(args.n, args.ranks, args.tol, cases),
            "csv": str(BENCH_DIR / "tolerance.csv")}


def cmd_bench_path(args) -> dict:
    """Load-path error rows (:func:`benchmarks.fem.path_errors`)."""
    from benchmarks.fem import path_errors

    cases = [parse_case(text) for text in args.case]
    return {"runs": path_errors(args.n, args.ranks, cases), "csv": str(BENCH_DIR / "path.csv")}


def cmd_bench_profile(args) -> dict:
    """Time per phase and Krylov iterations of one figure case
    (:func:`benchmarks.fem.profile_case`), as a table."""
    from mpi4py import MPI

    from benchmarks.fem import add_memory_column, profile_case

    if args.level < 0:
        raise InputError(f"--level must be 0 or more, got {args.level}")
    profile, path = profile_case(args.surface, args.load, args.n, MPI.COMM_WORLD, BENCH_DIR,
                                 args.level)
    if args.memory_csv is not None and MPI.COMM_WORLD.rank == 0:
        add_memory_column(args.memory_csv, profile, ".".join(__version__.split(".")[:2]))
    record = {key: profile[key] for key in ("wall_s", "newton_iterations", "cut_steps", "mu_s")}
    for phase, row in profile["phases"].items():
        record[f"{phase} [s]"] = row["seconds"]
        record[f"{phase} [share]"] = row["share"]
    for kind, row in profile["linear_solves"].items():
        record[f"{kind} solves / its / largest"] = (
            f"{row['solves']} / {row['krylov_iterations']} / {row['largest']}")
    memory = profile["memory"]
    record["peak memory [GB] / [kB per dof]"] = (
        f"{memory['peak_gb']:.3f} / {memory['peak_kb_per_dof']:.2f}")
    record["peak rose after (rank 0: stage call, GB)"] = "; ".join(
        f"{rise['stage']} {rise['call']}: {rise['peak_gb']:.3f}"
        for rise in memory["peak_rises_by_rank"][0])
    return record | {"json": str(path)}


def cmd_bench_zone(args) -> dict:
    """Zone coverage rows (:mod:`benchmarks.zone_cover`) of each pair of runs."""
    from roughfriction.studies.post import read_run

    from benchmarks.batch import run_physics
    from benchmarks.zone_cover import MARGINS, coverage_rows, write_rows

    if len(args.runs) % 2:
        raise InputError(f"zone takes pairs of runs (coarse, then 2x); got {len(args.runs)} "
                         "files")
    margins = MARGINS if args.margins is None else args.margins
    if any(margin < 0 for margin in margins):
        raise InputError(f"zone margins are cells >= 0, got {margins}")
    pairs = list(zip(args.runs[::2], args.runs[1::2], strict=True))
    labels = [None] * len(pairs) if args.labels is None else args.labels
    if len(labels) != len(pairs):
        raise InputError(f"--labels takes one name per pair of runs ({len(pairs)}), got "
                         f"{len(labels)}")
    rows = []
    for (coarse, fine), label in zip(pairs, labels, strict=True):
        physics = {run_physics(coarse), run_physics(fine)}
        if len(physics) > 1:
            raise InputError(f"{coarse} and {fine} were computed by different physics "
                             f"({' and '.join(sorted(physics))}): run them with the same code")
        stamp = physics.pop()
        rows += [row | {"physics": stamp}
                 for row in coverage_rows(read_run(coarse), read_run(fine), margins, label)]
    path = write_rows(rows, Path(args.output))
    return {"csv": str(path), "coverage": {key: [row[key] for row in rows] for key in rows[0]}}


def cmd_bench_error(args) -> dict:
    """Run time against error (:mod:`benchmarks.convergence`)."""
    from benchmarks import convergence
    from benchmarks.batch import batch_plan

    n, levels, output = convergence.BASE_N, convergence.LEVELS, BENCH_DIR
    if args.quick:
        n, levels, output = convergence.QUICK_N, convergence.QUICK_LEVELS, BENCH_DIR / "quick"
    knob_cases = convergence.KNOB_CASES if args.knob_cases is None else tuple(args.knob_cases)
    labels = [case.label for case in convergence.CASES]
    unknown = [label for label in knob_cases if label not in labels]
    if unknown:
        raise InputError(f"unknown case(s) {', '.join(map(repr, unknown))}; known: "
                         f"{', '.join(map(repr, labels))}")
    plan = convergence.ErrorPlan(n=args.n or n, levels=tuple(args.levels or levels),
                                 knob_cases=knob_cases)
    output = Path(args.output) if args.output else output
    if args.plan:
        return {"plan": batch_plan([fem for _, _, fem in convergence.benchmark_runs(plan)],
                                   args.runs)}
    from mpi4py import MPI

    rows = convergence.run_benchmark(plan, output, MPI.COMM_WORLD, args.runs,
                                     compute=not args.report)
    return {"rows": len(rows or []), "csv": str(output / "error.csv")}


def cmd_bench_stress(args) -> dict:
    """The stress matrix (:mod:`benchmarks.stress`); a silent failure or runs that
    disagree between rank counts or repeats are an error."""
    from benchmarks import stress
    from benchmarks.batch import batch_plan

    if args.rank_run:
        from mpi4py import MPI

        path = stress.compute_rank_run(args.n, Path(args.output), MPI.COMM_WORLD)
        return {"results": str(path) if path else None}
    runs = stress.default_runs(args.n)
    if args.plan:
        lines = batch_plan([run.case for run in runs if run.case
                            and run.kind not in stress.CHECK_KINDS], args.runs)
        lines += [f"and {sum(run.kind == kind for run in runs)} {kind} runs, each in its own "
                  "run cache" for kind in stress.CHECK_KINDS]
        lines += [f"not run: {run.surface} F*={run.load_star:g}: {run.error}"
                  for run in runs if run.case is None]
        return {"plan": lines}
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    rows = stress.run_stress(runs, args.n, stress.MATRIX_LOADS, Path(args.output), comm,
                             args.runs)
    found = comm.bcast(None if rows is None else (stress.outcome_counts(rows)[stress.SILENT],
                                                  stress.disagreements(rows)), root=0)
    silent, disagreements = found
    if silent or disagreements:
        raise InputError(f"{silent} SILENT FAILURE(S), {len(disagreements)} disagreement(s) "
                         f"of rank counts or repeats: see {Path(args.output) / 'stress.md'}")
    return {"rows": len(rows or []), "csv": str(Path(args.output) / "stress.csv")}


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m benchmarks`` parser (errors in one line, exit 2, as ``roughfriction``'s)."""
    from roughfriction.scripts.cli import OneLineParser, describe_commands

    parser = OneLineParser(prog="python -m benchmarks",
                           description="The benchmarks of roughfriction, run from a checkout of "
                           "its repository; numbers go to results/bench/ (docs/benchmarks.md).")
    add_bench_commands(parser)
    describe_commands(parser)
    return parser


def main(argv: list[str] | None = None) -> int:
    """``python -m benchmarks``; returns the exit status (``roughfriction.scripts.cli.main``)."""
    from roughfriction.scripts import cli

    return cli.main(argv, build_parser)
