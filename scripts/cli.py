"""``roughfriction`` command line: surface statistics, theory, FEM, figures.

Every subcommand prints a short human-readable table, or with ``--json`` one JSON object on
stdout (SI units; NaN and infinities become ``null``) so that it can be piped into other tools.
Exit status: 0 success; 2 an input the user can fix, or a bad command line (one line on
stderr); 3 a FEM run that did not converge (partial results written, one line on stderr); 130
interrupted (Ctrl-C, or SIGTERM as ``mpirun`` passes Ctrl-C on; one line); 141 stdout closed
early (``| head``); 1 anything else (a bug: traceback). Warnings are counted and
summarised on stderr at the end, one line per distinct warning.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import math
import os
import sys
import warnings
from pathlib import Path

from roughfriction import __version__
from roughfriction.errors import ConvergenceError, InputError
from roughfriction.material import Material
from roughfriction.scripts.surface_args import positive_float, surface_cells, surface_from_args

EXIT_INPUT_ERROR = 2
#: Exit status of a FEM run that did not converge.
EXIT_NOT_CONVERGED = 3
#: Exit status after Ctrl-C (128 + SIGINT, as a shell reports it).
EXIT_INTERRUPTED = 130
#: Exit status when the reader of stdout left early (128 + SIGPIPE: ``post RUN | head -1``).
EXIT_BROKEN_PIPE = 141


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line on stderr (exit 2), naming ``--help``
    instead of printing the usage block."""

    def error(self, message: str):
        self.exit(EXIT_INPUT_ERROR,
                  f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _finite_or_none(value):
    """JSON has no NaN: map non-finite floats to None, recursively."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite_or_none(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite_or_none(v) for v in value]
    return value


def _text(value) -> str:
    if isinstance(value, list):
        return "; ".join(map(_text, value)) or "none"
    return f"{value:.6g}" if isinstance(value, float) else str(value)


#: Units of the quantities the commands print (text tables; JSON is SI without them).
UNITS = {"spacing": "m", "rq": "m", "m0": "m^2", "m4": "m^-2", "sigma_s": "m",
         "R": "m", "Ft_max": "N", "Fn": "N", "E": "Pa", "Sy": "Pa", "Et": "Pa", "tau_c": "Pa",
         "wall_s": "s", "mu_s_error": "(absolute)", "mu_s_error_relative": "(relative)"}


def _section_lines(section: dict) -> list[str]:
    """A nested record as text: equal-length lists as a table with a header row; anything else
    as aligned ``key  value`` lines (a dict value as ``k=v`` pairs)."""
    if not section:
        return ["(none)"]
    if all(isinstance(value, list) for value in section.values()):
        columns = {key: [_text(value) for value in values] for key, values in section.items()}
        widths = [max(len(key), *map(len, column)) for key, column in columns.items()]
        rows = [list(columns), *zip(*columns.values(), strict=True)]
        return ["  ".join(f"{cell:>{width}}" for cell, width in zip(row, widths, strict=True))
                for row in rows]
    width = max(len(key) for key in section)
    return [f"{key:<{width}}  " + (" ".join(f"{k}={_text(v)}" for k, v in value.items())
                                   if isinstance(value, dict) else _with_unit(key, value))
            for key, value in section.items()]


def _with_unit(key: str, value) -> str:
    """``value`` as text, followed by the unit of ``key`` (:data:`UNITS`) when it has one."""
    unit = UNITS.get(key) if value is not None else None
    return f"{_text(value)} {unit}" if unit else _text(value)


def emit(record: dict, as_json: bool) -> None:
    """Print ``record`` as JSON or as text: an aligned key/value table of its scalars, then
    each dict-valued entry as a titled section (see :func:`_section_lines`)."""
    if as_json:
        print(json.dumps(_finite_or_none(record), indent=None))
        return
    scalars = {key: value for key, value in record.items() if not isinstance(value, dict)}
    for line in _section_lines(scalars) if scalars else []:
        print(line)
    for key, value in record.items():
        if isinstance(value, dict):
            print(f"\n{key}")
            for line in _section_lines(value):
                print(f"  {line}")


def add_surface_arguments(parser: argparse.ArgumentParser) -> None:
    """SURFACE and the reader options shared by every subcommand that takes a surface."""
    from roughfriction.geometry.readers import MIN_RMS_SLOPE

    parser.add_argument(
        "surface",
        metavar="SURFACE",
        help="height-map file (.npy, text matrix, x-y-z list incl. NANOVEA ST400 export, "
        "instrument formats with the [instruments] extra) or a built-in name: "
        "G1..G9 (Table 1), 2L, 8L, 63M (self-affine stand-ins)",
    )
    group = parser.add_argument_group("surface reading")
    group.add_argument(
        "--size",
        help="scan length from first to last point, with a unit (e.g. 127um); needed for "
        ".npy and matrix files",
    )
    group.add_argument("--height-unit", metavar="UNIT",
                       help="unit of the heights (m, mm, um, nm); default m for .npy, um for "
                       "x-y-z lists (ST400), needed for matrix files; given, it also keeps "
                       "heights whose RMS slope looks like another unit")
    group.add_argument("--lateral-unit", metavar="UNIT",
                       help="unit of the x-y coordinates of x-y-z point lists (default mm, "
                       "ST400)")
    group.add_argument(
        "--fill",
        choices=["nearest", "plane"],
        help="fill missing (NaN or unmeasured) heights with the nearest measured one or the "
        "least-squares plane; without it such files are refused",
    )
    group.add_argument(
        "--crop", action="store_true", help="crop a non-square grid to its largest centred square"
    )
    group.add_argument(
        "--resample-pixels",
        action="store_true",
        help="interpolate non-square pixels (bilinear) onto square ones of the smaller side",
    )
    group.add_argument(
        "--no-detrend", action="store_true", help="keep the least-squares plane of the data"
    )
    group.add_argument("--allow-flat", action="store_true",
                       help=f"keep a surface whose RMS slope is below {MIN_RMS_SLOPE:g} (refused "
                       "otherwise as a --size/--lateral-unit or --height-unit slip)")


def config_material(args) -> Material:
    """The material of ``--config``'s ``[material]`` table (SI units, or pressures with a unit),
    the paper's without one; refused when it is no metal's (``plausibility.check_material``)."""
    from roughfriction.plausibility import material_from_table
    from roughfriction.scripts.fem import read_config

    return material_from_table(read_config(args.config).get("material", {}))


def add_material_argument(parser: argparse.ArgumentParser) -> None:
    """``--config``: the material of a case file (the ``fem`` command's; its other keys are
    checked, not used)."""
    parser.add_argument("--config", metavar="TOML",
                        help="case file whose [material] table (E, nu, Sy, Et, tau_c in Pa, or "
                        "with a unit: \"800MPa\") replaces the paper's material (E 200 GPa, nu "
                        "0.3, Sy 1 GPa)")


def cmd_surface_stats(args) -> dict:
    from roughfriction.geometry.statistics import surface_statistics
    from roughfriction.plausibility import material_record

    material = config_material(args)
    surface = surface_from_args(args)
    stats = surface_statistics(surface, material)
    return {"surface": surface.name, "n": surface.n, "spacing": surface.spacing, **stats.as_dict(),
            "material": material_record(material)}


def cmd_surface_list(args) -> dict:
    from roughfriction.geometry.generate import BUILTIN_SURFACES

    return {name: entry.description for name, entry in BUILTIN_SURFACES.items()}


def cmd_multiscale(args) -> dict:
    from roughfriction.multiscale.theory import evaluate_theory
    from roughfriction.plausibility import material_record, result_warnings

    material = config_material(args)
    surface = surface_from_args(args)
    result = evaluate_theory(surface, args.load, material, variant=args.variant).as_dict()
    flags = result_warnings(args.load, [result["area_ratio_normal"],
                                        result["area_ratio_sliding"]])
    for line in flags:
        print(f"warning: {line}", file=sys.stderr)
    return {**result, "warnings": flags, "material": material_record(material)}


def cmd_fem(args) -> dict:
    from roughfriction.scripts.fem import run_fem

    return run_fem(args)


def cmd_post(args) -> dict:
    from roughfriction.studies.post import read_run, run_report, write_map_csvs

    run = read_run(args.path)
    record = run_report(run)
    if args.maps:
        record["maps_written"] = " ".join(str(path) for path in write_map_csvs(run, args.maps))
    if args.plot:
        from roughfriction.scripts.fem_views import write_run_plots

        record["plots_written"] = " ".join(str(path) for path in write_run_plots(run, args.plot))
    return record


def cmd_figure(args) -> dict:
    from roughfriction.scripts.figures import FIGURES, make_figure

    if args.name == "runs":  # every FEM figure's runs, one batch (make figures does this first)
        from roughfriction.scripts.figures import compute_fem_runs

        return {"fem_cases": compute_fem_runs(n=args.n)}
    if args.name == "summaries":  # the figure runs' small JSON summaries, committed in data/runs
        from roughfriction.scripts.figures import export_summaries

        return export_summaries(n=args.n)
    if args.name == "claims":  # the paper's statements checked against the figures' CSVs
        from roughfriction.scripts.claims import write_claims
        from roughfriction.scripts.figures import FIGURE_DIR

        return {"claims": str(write_claims(FIGURE_DIR))}
    if args.name == "all":
        names = list(FIGURES)
    elif args.name in FIGURES:
        names = [args.name]
    else:
        raise InputError(f"unknown figure {args.name!r}; known: all, runs, summaries, claims, "
                         f"{', '.join(FIGURES)}")
    return {name: str(make_figure(name, n=args.n)) for name in names}


def cmd_runs(args) -> dict:
    from dataclasses import replace

    from mpi4py import MPI
    from roughfriction.case import Loading
    from roughfriction.files import agreed
    from roughfriction.plausibility import material_record
    from roughfriction.scripts.fem import case_from_args
    from roughfriction.studies.cache import cached_results
    from roughfriction.studies.fem_request import unresolved_warning
    from roughfriction.studies.results_file import stored_run

    comm = MPI.COMM_WORLD
    loads, args.load = args.load, args.load[0]  # one case, built as fem builds it, per load
    case = case_from_args(args, agreed(comm, lambda: surface_from_args(args)), comm)
    cases = [replace(case, loading=Loading(load, case.loading.normal_only)) for load in loads]
    paths = cached_results(cases, directory=args.directory)
    summaries = [stored_run(path).summary for path in paths]
    unreliable = [f"{one.loading.load_star:g}" for one, summary in zip(cases, summaries,
                                                                      strict=True)
                  if unresolved_warning(summary)]
    if unreliable and is_root_rank():
        warning = unresolved_warning(next(s for s in summaries if unresolved_warning(s)))
        print(f"warning: at F* = {', '.join(unreliable)}: {warning}", file=sys.stderr)
    return {"runs": {"F*": [one.loading.load_star for one in cases],
                     "N": [one.surface.n for one in cases],
                     "mu_s": [summary.get("mu_s") for summary in summaries],
                     "A_r/A_n": [summary.get("area_ratio_normal") for summary in summaries],
                     "reliable": [summary.get("reliable") for summary in summaries],
                     "converged": [summary.get("converged") for summary in summaries],
                     "file": [str(path) for path in paths]},
            "material": material_record(case.material)}


def cmd_bench(args) -> dict:
    """``roughfriction bench``: says where the benchmarks are (they are not installed)."""
    raise InputError("the benchmarks are not installed; run them from a checkout of the "
                     f"repository: python -m benchmarks {' '.join(args.words) or 'COMMAND'}")


def describe_commands(parser: argparse.ArgumentParser) -> None:
    """Give every (sub)command without a description its one-line help as the description,
    so that ``roughfriction COMMAND --help`` says what the command does."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:
                command = action.choices[choice.dest]
                if command.description is None:
                    command.description = choice.help
                describe_commands(command)


def build_parser() -> argparse.ArgumentParser:
    from roughfriction.studies.cache import DEFAULT_RUNS, RUNS_VARIABLE
    from roughfriction.studies.paper import DEFAULT_FEM_N, FEM_N_VARIABLE

    parser = OneLineParser(
        prog="roughfriction",
        description="Static friction between rough metal surfaces: multi-scale theory and FEM.",
        epilog="exit status: 0 done, 2 bad input or command line, 3 FEM run not converged, "
        "130 interrupted, 141 stdout closed early",
    )
    parser.add_argument("--version", action="version", version=f"roughfriction {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    surface = commands.add_parser("surface", help="surface statistics and built-in surfaces")
    surface_commands = surface.add_subparsers(dest="surface_command", required=True)
    stats = surface_commands.add_parser(
        "stats", help="Rq, McCool moments, alpha, sigma_s, R, plasticity index psi (SI units)"
    )
    add_surface_arguments(stats)
    add_material_argument(stats)
    stats.add_argument("--json", action="store_true", help="one JSON object on stdout")
    stats.set_defaults(run=cmd_surface_stats)
    listing = surface_commands.add_parser("list", help="the built-in surfaces")
    listing.add_argument("--json", action="store_true", help="one JSON object on stdout")
    listing.set_defaults(run=cmd_surface_list)

    theory = commands.add_parser(
        "multiscale",
        help="multi-scale static friction (Sect. 4) beside CKE (Eq. 8) and LET (Eq. 20)",
    )
    add_surface_arguments(theory)
    theory.add_argument(
        "--load", type=positive_float, required=True, metavar="FSTAR",
        help="dimensionless normal load F* = F_n / (A_n S_y)",
    )
    theory.add_argument(
        "--variant", choices=["A", "B"], default="A",
        help="shear stress passed to the junction-growth fit (Eq. 36): A = tau_c (default), "
        "B = min(tau_i, tau_c)",
    )
    add_material_argument(theory)
    theory.add_argument("--json", action="store_true", help="one JSON object on stdout")
    theory.set_defaults(run=cmd_multiscale)

    fem = commands.add_parser(
        "fem",
        help="deterministic FEM: elastic-plastic rough block, rigid flat preloaded then slid "
        "until every contact node slips (run under mpirun for several ranks)",
    )
    add_surface_arguments(fem)
    from roughfriction.scripts.fem import add_fem_arguments  # imports no dolfinx

    add_fem_arguments(fem)
    fem.set_defaults(run=cmd_fem)

    post = commands.add_parser(
        "post", help="read a FEM results file (roughfriction fem --output, or results/runs/): "
        "summary, steps, junction growth, contact maps; --maps writes them as CSV, --plot "
        "draws the run")
    post.add_argument("path", metavar="RUN",
                      help="HDF5 results file (roughfriction fem --output, or results/runs/)")
    post.add_argument("--maps", metavar="DIR",
                      help="also write each surface map as DIR/<name>.csv: a header x_m,y_m,"
                      "<name>[_<unit>] (e.g. pressure_normal_Pa), then one row per grid point, "
                      "x = i h and y = j h in m, x-major (the third column reshaped to N x N is "
                      "the map); contact and slip flags 0/1, pressure and shear in Pa, contact "
                      "fraction per cell 0..1, heights and gaps in m")
    post.add_argument("--plot", metavar="DIR",
                      help="also draw the run as PNGs in DIR: contact pressure over the "
                      "heights at the end of the preload and at sliding inception "
                      "(<RUN>_contact.png) and F_t/F_n against the slide u_x "
                      "(<RUN>_tangential.png)")
    post.add_argument("--json", action="store_true", help="one JSON object on stdout")
    post.set_defaults(run=cmd_post)

    figure = commands.add_parser("figure", help="make one of the paper's figures (PNG + CSV)")
    figure.add_argument("name", metavar="NAME",
                        help="a figure (fig3 ... fig29, written to figures/figNN.png and .csv), "
                        "'all', 'runs' (compute every FEM figure's runs), 'summaries' (write "
                        "their run summaries to data/runs/, committed) or 'claims' (the "
                        "paper's statements checked against figures/*.csv)")
    figure.add_argument("--n", type=surface_cells, metavar="N",
                        help=f"FEM figures: surface cells per side of the runs (default "
                        f"${FEM_N_VARIABLE}, else {DEFAULT_FEM_N}); runs are kept in the run "
                        f"cache (${RUNS_VARIABLE}, else {DEFAULT_RUNS})")
    figure.add_argument("--json", action="store_true", help="one JSON object on stdout")
    figure.set_defaults(run=cmd_figure)

    runs = commands.add_parser(
        "runs", help=f"compute the runs missing from the run cache (${RUNS_VARIABLE}, else "
        f"{DEFAULT_RUNS}) and print their results files; loads of one surface share one "
        "normal loading path")
    add_surface_arguments(runs)
    runs.add_argument("--load", type=positive_float, nargs="+", required=True, metavar="FSTAR",
                      help="one or more dimensionless normal loads F* = F_n / (A_n S_y)")
    runs.add_argument("--n", type=surface_cells, metavar="N",
                      help="surface cells per side of the FEM grid (default: the surface's "
                      "points per side; fewer re-grid it over its scan length, unless "
                      "--window)")
    runs.add_argument("--window", metavar="K",
                      help="with --n below the surface's points: mesh its K-th N x N window "
                      "at its own spacing (1, 2, ... or 'best'), as fem --window")
    runs.add_argument("--config", metavar="TOML",
                      help="case file, as fem --config (its load and n stand in for missing "
                      "flags)")
    runs.add_argument("--normal-only", action="store_true", default=None,
                      help="preload only (no sliding, no mu_s)")
    runs.add_argument("--directory", metavar="DIR",
                      help=f"the run cache (default ${RUNS_VARIABLE}, else {DEFAULT_RUNS})")
    runs.add_argument("--json", action="store_true", help="one JSON object on stdout")
    runs.set_defaults(run=cmd_runs, elastic=None)

    bench = commands.add_parser("bench", help="not installed: the benchmarks run from a "
                                "checkout of the repository, python -m benchmarks COMMAND")
    bench.add_argument("words", nargs=argparse.REMAINDER, help="the benchmark's command line")
    bench.set_defaults(run=cmd_bench, json=False)
    describe_commands(parser)
    return parser


def is_root_rank() -> bool:
    """True on MPI rank 0, or when MPI is not in use: only that process prints."""
    mpi = sys.modules.get("mpi4py.MPI")
    return mpi is None or mpi.COMM_WORLD.rank == 0


def quiet_library_logging() -> None:
    """Keep the FEM stack's INFO logging off stderr: FFCx calls ``logging.basicConfig()`` and
    its JIT compiler sets the root logger to INFO ("INFO:root:running build_ext" and the C
    compiler's command lines). A root handler installed first at WARNING keeps warnings and
    errors and drops the rest (basicConfig is then a no-op); a root that already has a
    handler (an embedding program's) is left alone."""
    root = logging.getLogger()
    if not root.handlers:
        handler = logging.StreamHandler()
        handler.setLevel(logging.WARNING)
        handler.setFormatter(logging.Formatter(logging.BASIC_FORMAT))
        root.addHandler(handler)


def warning_lines(counts: dict) -> list[str]:
    """One line per distinct warning (category and place): its first message and its count."""
    lines = []
    for (category, filename, lineno), (message, count) in counts.items():
        times = f", {count} times" if count > 1 else ""
        place = Path(filename)
        lines.append(f"roughfriction: warning: {category}: {message} ({place.parent.name}/"
                     f"{place.name}:{lineno}){times}")
    return lines


#: Warnings counted at every occurrence; the others keep their filters (deprecations stay
#: hidden).
COUNTED_WARNINGS = (RuntimeWarning, UserWarning)


@contextlib.contextmanager
def summarised_warnings():
    """Count the warnings raised inside instead of printing each one, then print
    :func:`warning_lines` on stderr (rank 0 under MPI), also when leaving by an exception."""
    counts: dict = {}

    def count(message, category, filename, lineno, file=None, line=None):
        key = (category.__name__, filename, lineno)
        first, number = counts.get(key, (str(message), 0))
        counts[key] = (first, number + 1)

    with warnings.catch_warnings():
        for category in COUNTED_WARNINGS:  # each occurrence (the default shows one per text)
            warnings.simplefilter("always", category)
        warnings.showwarning = count
        try:
            yield
        finally:
            if is_root_rank():
                for line in warning_lines(counts):
                    print(line, file=sys.stderr)


def run_command(args) -> int:
    """Run the parsed command; print its record (rank 0) or its one-line error; the exit
    status."""
    try:
        record = args.run(args)
    except ConvergenceError as error:
        if is_root_rank():
            print(f"roughfriction: not converged: {error}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    except InputError as error:
        if is_root_rank():
            print(f"roughfriction: error: {error}", file=sys.stderr)
        return EXIT_INPUT_ERROR
    if is_root_rank():
        emit(record, args.json)
        sys.stdout.flush()  # a closed pipe fails here, inside main, not at the exit's flush
    return 0


def _terminated(signal_number, frame):
    """SIGTERM handler: stop as Ctrl-C does (``mpirun`` passes a Ctrl-C on to its ranks as
    SIGTERM)."""
    raise KeyboardInterrupt


@contextlib.contextmanager
def terminate_as_interrupt():
    """Inside, SIGTERM raises KeyboardInterrupt (main thread only; the handler before is
    restored after)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGTERM, _terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, before)


def main(argv: list[str] | None = None, build=build_parser) -> int:
    """The ``roughfriction`` command, or the one ``build()`` parses (``python -m benchmarks``);
    returns the exit status (see the module docstring)."""
    quiet_library_logging()
    try:
        with terminate_as_interrupt():
            args = build().parse_args(argv)
            with summarised_warnings():
                return run_command(args)
    except KeyboardInterrupt:
        if is_root_rank():
            print("roughfriction: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no 2nd error at exit
        return EXIT_BROKEN_PIPE


if __name__ == "__main__":
    sys.exit(main())
