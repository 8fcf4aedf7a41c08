"""Benchmarks: numbers (time, iterations, result) written to ``results/bench/``, not timed tests."""

from __future__ import annotations

import platform
import time
from pathlib import Path

import numpy as np
from roughfriction.geometry.generate import builtin_surface
from roughfriction.material import Material
from roughfriction.multiscale.friction import static_friction
from roughfriction.multiscale.scales import scale_decomposition
from roughfriction.scripts.figures import write_table
from roughfriction.studies.paper import (
    GAUSSIAN_SURFACES,
    LOAD_SWEEP,
    LOAD_SWEEP_SURFACES,
    PSI_SWEEP_LOADS,
)

BENCH_DIR = Path("results/bench")


def _median_seconds(function, repeats: int) -> tuple[float, object]:
    """Median wall time [s] of ``repeats`` calls, and the last return value."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        value = function()
        times.append(time.perf_counter() - start)
    return float(np.median(times)), value


def bench_multiscale(repeats: int = 7) -> dict:
    """Time the FFT decomposition and each multi-scale evaluation of Figs. 22–28.

    Writes ``results/bench/multiscale.csv`` (one row per surface and load: median time of
    ``repeats`` evaluations [ms], load iterations, mu_s) and returns a summary: median and
    maximum time per evaluation and the time of all theory curves of Figs. 22–28 (9 surfaces x 4
    loads and 3 surfaces x 10 loads, FFTs included, one pass).
    """
    material = Material()
    cases = [(s, f) for s in GAUSSIAN_SURFACES for f in PSI_SWEEP_LOADS]
    cases += [(s, f) for s in LOAD_SWEEP_SURFACES for f in LOAD_SWEEP]
    surfaces = {name: builtin_surface(name) for name, _ in cases}

    fft_s, _ = _median_seconds(lambda: scale_decomposition(surfaces["G5"]), repeats)
    scales = {name: scale_decomposition(s) for name, s in surfaces.items()}
    rows = {"surface": [], "load_star": [], "time_ms": [], "iterations": [], "mu_s": []}
    for name, load in cases:
        seconds, result = _median_seconds(
            lambda n=name, f=load: static_friction(scales[n], f, material), repeats
        )
        for key, value in zip(rows, (name, load, 1e3 * seconds, result.iterations, result.mu_s),
                              strict=True):
            rows[key].append(value)

    start = time.perf_counter()
    for name, load in cases:
        static_friction(scale_decomposition(surfaces[name]), load, material)
    all_curves_s = time.perf_counter() - start

    BENCH_DIR.mkdir(parents=True, exist_ok=True)
    write_table(BENCH_DIR / "multiscale.csv", {k: np.array(v) for k, v in rows.items()})
    times = np.array(rows["time_ms"])
    return {
        "machine": f"{platform.processor() or platform.machine()}, {platform.python_version()}",
        "evaluations": len(cases),
        "fft_decomposition_ms": 1e3 * fft_s,
        "evaluation_median_ms": float(np.median(times)),
        "evaluation_max_ms": float(times.max()),
        "all_curves_s": all_curves_s,
        "csv": str(BENCH_DIR / "multiscale.csv"),
    }


def add_bench_commands(bench) -> None:
    """``roughfriction bench multiscale|fem|path|error|stress|profile`` under the ``bench``
    sub-parser."""
    from roughfriction.scripts.bench_fem import DEFAULT_SIZES as FEM_SIZES
    from roughfriction.scripts.bench_fem import HEADLINE_CASES as FEM_CASES
    from roughfriction.studies import convergence
    from roughfriction.studies.paper import DEFAULT_FEM_N

    headline = [f"{surface}:{load:g}" for surface, load in FEM_CASES]
    kinds = bench.add_subparsers(dest="bench_command", required=True)
    multiscale = kinds.add_parser("multiscale", help="time the theory over Figs. 22-28's cases "
                                  f"-> {BENCH_DIR / 'multiscale.csv'}")
    multiscale.set_defaults(run=lambda args: bench_multiscale())

    fem = kinds.add_parser("fem", help="FEM run time and memory per N, each run under mpirun "
                           f"-> {BENCH_DIR / 'fem.csv'}")
    fem.add_argument("--n", type=int, nargs="+", default=list(FEM_SIZES),
                     help=f"surface cells per side (default {' '.join(map(str, FEM_SIZES))})")
    fem.set_defaults(run=cmd_bench_fem)

    path = kinds.add_parser("path", help="mu_s on the default load path against a finer one, "
                            f"each run under mpirun -> {BENCH_DIR / 'path.csv'}")
    path.add_argument("--n", type=int, default=64, help="surface cells per side (default 64)")
    path.set_defaults(run=cmd_bench_path)
    for parser in (fem, path):
        parser.add_argument("--ranks", type=int, default=2, help="MPI ranks (default 2)")
        parser.add_argument("--case", nargs="+", metavar="SURFACE:LOAD", default=headline,
                            help=f"surfaces and loads F* (default the headline cases: "
                                 f"{' '.join(headline)})")

    error = kinds.add_parser("error", help="run time against error (run under mpirun) -> "
                             f"{BENCH_DIR / 'error.csv'}, error.png")
    error.add_argument("--quick", action="store_true",
                       help=f"sizes {convergence.QUICK_SIZES}, knobs at N = "
                       f"{convergence.QUICK_BASE_N}; output to {BENCH_DIR / 'quick'}")
    error.add_argument("--sizes", type=int, nargs="+", metavar="N",
                       help=f"resolutions of the sweep (default {convergence.SIZES})")
    error.add_argument("--base-n", type=int, metavar="N",
                       help=f"resolution of the knob variants (default {convergence.BASE_N})")
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
    matrix.set_defaults(run=cmd_bench_stress)
    profile = kinds.add_parser("profile", help="where one FEM run's time goes (run under "
                               "mpirun) -> " + str(BENCH_DIR / "profile_<case>.json"))
    profile.add_argument("surface", help="built-in surface (G1-G9 meshed as a window of their "
                         "own grid, the others re-gridded, as in the figures)")
    profile.add_argument("--load", type=float, required=True, help="F* = F_n / (A_n S_y)")
    profile.add_argument("--n", type=int, default=DEFAULT_FEM_N,
                         help=f"surface cells per side (default {DEFAULT_FEM_N})")
    profile.set_defaults(run=cmd_bench_profile)
    for parser in (multiscale, fem, path, error, matrix, profile):
        parser.add_argument("--json", action="store_true", help="one JSON object on stdout")


def cmd_bench_fem(args) -> dict:
    """FEM benchmark rows (:mod:`roughfriction.scripts.bench_fem`)."""
    from roughfriction.scripts.bench_fem import BENCH_DIR as FEM_DIR
    from roughfriction.scripts.bench_fem import benchmark_sizes, parse_case

    cases = [parse_case(text) for text in args.case]
    return {"runs": benchmark_sizes(args.n, args.ranks, cases), "csv": str(FEM_DIR / "fem.csv")}


def cmd_bench_path(args) -> dict:
    """Load-path error rows (:func:`roughfriction.scripts.bench_fem.path_errors`)."""
    from roughfriction.scripts.bench_fem import BENCH_DIR as FEM_DIR
    from roughfriction.scripts.bench_fem import parse_case, path_errors

    cases = [parse_case(text) for text in args.case]
    return {"runs": path_errors(args.n, args.ranks, cases), "csv": str(FEM_DIR / "path.csv")}


def cmd_bench_profile(args) -> dict:
    """Time per phase and Krylov iterations of one figure case (:mod:`studies.profile`),
    written as JSON to ``results/bench/profile_<surface>_F<load>_N<n>_<ranks>ranks.json``."""
    import json

    from mpi4py import MPI
    from roughfriction.errors import ConvergenceError
    from roughfriction.files import atomic_write
    from roughfriction.scripts.bench_fem import case_stem
    from roughfriction.solver.run import stderr_progress
    from roughfriction.studies.paper import fem_case
    from roughfriction.studies.profile import profile_run

    comm = MPI.COMM_WORLD
    case = fem_case(args.surface, args.load, args.n)
    fem, profile = profile_run(case, comm, stderr_progress(comm))
    summary = fem.result.summary()
    fem.equilibrium.destroy()
    profile |= {"case": {"surface": args.surface, "load_star": args.load, "n": args.n,
                         "ranks": comm.size},
                **{key: summary[key] for key in ("mu_s", "newton_iterations", "steps",
                                                 "cut_steps", "converged")}}
    path = BENCH_DIR / f"profile_{case_stem(args.surface, args.load, args.n, comm.size)}.json"
    if comm.rank == 0:
        atomic_write(path, lambda tmp: Path(tmp).write_text(json.dumps(profile, indent=1)))
    if not summary["converged"]:
        raise ConvergenceError(f"{fem.result.message} (profile written to {path})")
    record = {key: profile[key] for key in ("wall_s", "newton_iterations", "cut_steps", "mu_s")}
    for phase, row in profile["phases"].items():
        record[f"{phase} [s]"] = row["seconds"]
        record[f"{phase} [share]"] = row["share"]
    for kind, row in profile["linear_solves"].items():
        record[f"{kind} solves / its / largest"] = (
            f"{row['solves']} / {row['krylov_iterations']} / {row['largest']}")
    return record | {"json": str(path)}


def cmd_bench_error(args) -> dict:
    """Run time against error (:mod:`roughfriction.studies.convergence`)."""
    from roughfriction.studies import convergence
    from roughfriction.studies.batch import batch_plan

    sizes, base_n, output = convergence.SIZES, convergence.BASE_N, BENCH_DIR
    if args.quick:
        sizes, base_n, output = (convergence.QUICK_SIZES, convergence.QUICK_BASE_N,
                                 BENCH_DIR / "quick")
    plan = convergence.ErrorPlan(sizes=tuple(args.sizes or sizes), base_n=args.base_n or base_n)
    output = Path(args.output) if args.output else output
    if args.plan:
        return {"plan": batch_plan([fem for _, _, fem in convergence.benchmark_runs(plan)],
                                   args.runs)}
    from mpi4py import MPI

    rows = convergence.run_benchmark(plan, output, MPI.COMM_WORLD, args.runs,
                                     compute=not args.report)
    return {"rows": len(rows or []), "csv": str(output / "error.csv")}


def cmd_bench_stress(args) -> dict:
    """The stress matrix (:mod:`roughfriction.studies.stress`); a silent failure is an error."""
    from roughfriction.errors import InputError
    from roughfriction.studies import stress
    from roughfriction.studies.batch import batch_plan

    runs = stress.default_runs(args.n)
    if args.plan:
        lines = batch_plan([run.case for run in runs if run.case], args.runs)
        lines += [f"not run: {run.surface} F*={run.load_star:g}: {run.error}"
                  for run in runs if run.case is None]
        return {"plan": lines}
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    rows = stress.run_stress(runs, args.n, stress.MATRIX_LOADS, Path(args.output), comm,
                             args.runs)
    silent = comm.bcast(None if rows is None else stress.outcome_counts(rows)[stress.SILENT],
                        root=0)
    if silent:
        raise InputError(f"{silent} SILENT FAILURE(S): see the problems column of "
                         f"{Path(args.output) / 'stress.csv'}")
    return {"rows": len(rows or []), "csv": str(Path(args.output) / "stress.csv")}
