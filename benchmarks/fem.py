"""FEM benchmark: the headline cases on N x N surface grids, each run by ``mpirun`` as the CLI
(``roughfriction fem``), and the time profile of one run.

    python -m benchmarks fem --n 32 64 128 --ranks 2 --case G5:0.155 G1:1.86

Headline cases (the default): G5 at F* = 0.155 and 0.93, the 2L stand-in at 0.5, G1 at 1.86
(complete contact). Writes ``results/bench/fem.csv`` (one row per case, N and rank count,
rewritten after every run so that finished rows survive a later failure; rows of other cases, N
or rank counts already in the file are kept) with wall time, peak memory summed over the
ranks, steps, Newton iterations, mu_s and the problem size; each run's full record goes to
``results/bench/fem_<surface>_F<load>_N<N>_<ranks>ranks.h5``.

    python -m benchmarks path --n 64

The load path's error per case: each case on the default path and on one ``PATH_FACTOR`` times
finer (largest preload and sliding increments divided by it, ``SolverOptions``), written to
``results/bench/path.csv`` with mu_s of both and their relative difference.

    mpirun -n 2 python -m benchmarks profile G5 --load 0.155 --n 32

Where one figure case's time goes (:mod:`benchmarks.profile`), written as JSON to
``results/bench/profile_<surface>_F<load>_N<n>_<ranks>ranks.json``.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
from roughfriction.case import SolverOptions
from roughfriction.errors import ConvergenceError, InputError
from roughfriction.files import atomic_write
from roughfriction.studies.physics import physics_stamp

from benchmarks.batch import BENCH_DIR

#: (surface, F*) of the headline rows.
HEADLINE_CASES = (("G5", 0.155), ("G5", 0.93), ("2L", 0.5), ("G1", 1.86))
DEFAULT_SIZES = (32, 64, 128)
#: The finer path of ``bench path`` divides the largest load increments by this [-].
PATH_FACTOR = 4
PATH_COLUMNS = ("surface", "load_star", "n", "ranks", "path_factor", "mu_s", "mu_s_fine_path",
                "path_error", "newton_iterations", "fine_newton_iterations", "wall_s",
                "fine_wall_s", "converged", "physics")
COLUMNS = ("surface", "load_star", "n", "ranks", "cells", "reduced_dofs", "linear_solver",
           "wall_s", "peak_memory_gb", "steps", "newton_iterations",
           "cut_steps", "cut_iterations", "inception_slide_m", "mu_s", "converged", "physics")


#: Prefixes of the variables an MPI launcher sets in its processes.
LAUNCHER_VARIABLES = ("OMPI_", "PMIX_", "PMI_", "OPAL_", "HYDRA_")
#: The user's permission for Open MPI to run as root, kept.
ROOT_PERMISSION = ("OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM")


def mpirun_environment() -> dict:
    """The environment for ``mpirun`` in a child process: this process's as Python read it at
    start (an MPI singleton's own launcher variables, set later, would make the child's exit
    status 1 whatever the job's), without an MPI launcher's variables (this process may be an
    MPI process itself), the permission to run as root kept."""
    return {key: value for key, value in os.environ.items()
            if not key.startswith(LAUNCHER_VARIABLES) or key in ROOT_PERMISSION}


def run_mpi(command: list[str]) -> int:
    """Run an ``mpirun`` command line (:func:`mpirun_environment`; its progress and errors go to
    stderr) and return its exit status."""
    return subprocess.run(command, stdout=subprocess.DEVNULL, env=mpirun_environment()).returncode


def read_record(path: Path) -> tuple[dict, dict, dict]:
    """The summary, sizes and versions of a results file (``studies.results_file``)."""
    with h5py.File(path) as h5:
        sizes = {key: value.item() if isinstance(value, np.generic) else value
                 for key, value in h5["sizes"].attrs.items()}
        return json.loads(h5.attrs["summary"]), sizes, json.loads(h5.attrs["versions"])


def case_stem(surface: str, load: float, n: int, ranks: int, window: int | None = None,
              level: int = 0) -> str:
    """``<surface>_F<load>_N<n>[_W<window>][_<2^level>x]_<ranks>ranks``: the file name of one
    benchmark case's output (the level's factor only above level 0)."""
    part = "" if window is None else f"_W{window}"
    part += f"_{2**level}x" if level else ""
    return f"{surface}_F{load:g}_N{n}{part}_{ranks}ranks"


def run_size(surface: str, load: float, n: int, ranks: int, config: Path | None = None,
             label: str = "fem") -> dict:
    """Run one case and grid size through ``roughfriction fem`` under mpirun (with the case
    file ``config``); return its row. Its record goes to ``<label>_<case_stem>.h5``."""
    output = BENCH_DIR / f"{label}_{case_stem(surface, load, n, ranks)}.h5"
    command = ["mpirun", "-n", str(ranks), "--oversubscribe", sys.executable, "-m",
               "roughfriction.scripts.cli", "fem", surface, "--load", str(load), "--n", str(n),
               "--json", "--output", str(output)]
    if config is not None:
        command += ["--config", str(config)]
    output.unlink(missing_ok=True)
    status = run_mpi(command)
    if not output.exists():
        raise RuntimeError(f"{surface} at F* = {load:g}, N = {n}: run failed (exit "
                           f"{status}) without results")
    summary, sizes, _ = read_record(output)
    with h5py.File(output) as h5:
        slides, physics = h5["steps/slide"][()], str(h5.attrs["physics"])
    row = {"surface": surface, "load_star": load, "n": n, "ranks": ranks}
    row.update({key: sizes.get(key) for key in ("cells", "reduced_dofs", "linear_solver",
                                                "peak_memory_gb")})
    row.update({key: summary[key] for key in ("wall_s", "steps", "newton_iterations",
                                              "cut_steps", "cut_iterations", "mu_s",
                                              "converged")})
    row["inception_slide_m"] = float(slides[-1]) if summary["mu_s"] is not None else None
    row["physics"] = physics_stamp(physics)
    return row


#: Columns of the ladder table (ladder.csv): one row per level of a ladder; ``window`` is
#: empty for the whole surface.
LADDER_COLUMNS = ("surface", "load_star", "n", "window", "ranks", "ladder", "level", "factor",
                  "reduced_dofs", "cells", "wall_s", "mu_s", "zone_escaped", "contact_nodes",
                  "boundary_nodes", "mu_s_error", "peak_memory_gb", "version", "physics")
#: Exit status of ``roughfriction fem --tol`` when a limit stopped the ladder (results written).
TOLERANCE_NOT_MET = 3


def ladder_command(surface: str, load: float, n: int, ranks: int, max_level: int, ladder: str,
                   output: Path, window: int | None = None) -> list[str]:
    """``roughfriction fem`` under mpirun running levels 0 .. ``max_level`` of a ladder on the
    built-in surface re-gridded to n x n, or on its n x n ``window`` (1-based; a tolerance of
    1e-12 is not met, so every level the limits allow runs; exit 3)."""
    command = ["mpirun", "-n", str(ranks), "--oversubscribe", sys.executable, "-m",
               "roughfriction.scripts.cli", "fem", surface, "--load", str(load), "--n", str(n),
               "--tol", "1e-12", "--max-level", str(max_level), "--ladder", ladder,
               "--output", str(output)]
    return command if window is None else command + ["--window", str(window)]


def ladder_rows(summary: dict, sizes: dict, case: dict, version: str,
                physics: str = "") -> list[dict]:
    """The ladder table's rows of one ladder from its finest level's results file: the
    ``summary`` (``studies.refinement.Ladder.summary``) and ``sizes`` attributes; ``case``
    holds surface, load_star, n, ranks and ladder. The peak memory, of the whole process, goes
    to the finest level's row."""
    levels = summary["levels"]
    count = len(levels["factor"])
    rows = []
    for level in range(count):
        finest = level == count - 1
        rows.append({**case, "level": level, "factor": levels["factor"][level],
                     "reduced_dofs": levels["reduced_dofs"][level],
                     "cells": levels["cells"][level], "wall_s": levels["wall_s"][level],
                     "mu_s": levels["mu_s"][level],
                     "zone_escaped": levels["zone_escaped"][level],
                     **{key: levels[key][level] if key in levels else None
                        for key in ("contact_nodes", "boundary_nodes")},
                     "mu_s_error": summary["mu_s_error"] if finest else None,
                     "peak_memory_gb": sizes.get("peak_memory_gb") if finest else None,
                     "version": version, "physics": physics_stamp(physics)})
    return rows


def run_ladder_levels(surface: str, load: float, n: int, ranks: int, max_level: int,
                      ladder: str, window: int | None = None) -> list[dict]:
    """Run levels 0 .. ``max_level`` of a ladder (:func:`ladder_command`) and return its rows
    (:func:`ladder_rows`); the finest level's record goes to
    ``ladder_<ladder>_<case_stem>.h5``."""
    output = BENCH_DIR / f"ladder_{ladder}_{case_stem(surface, load, n, ranks, window)}.h5"
    output.unlink(missing_ok=True)
    status = run_mpi(ladder_command(surface, load, n, ranks, max_level, ladder, output, window))
    where = "" if window is None else f", window {window}"
    summary, sizes, versions, physics = ladder_record(
        output, status, f"{surface} at F* = {load:g}, N = {n}{where}, {ladder} ladder")
    case = {"surface": surface, "load_star": load, "n": n, "window": window, "ranks": ranks,
            "ladder": ladder}
    return ladder_rows(summary, sizes, case, versions.get("roughfriction"), physics)


def ladder_record(output: Path, status: int, what: str) -> tuple[dict, dict, dict, str]:
    """The summary, sizes, versions and physics of a ladder's results file written by a
    command that exited with ``status`` (0, or 3 when a limit stopped it); ``what`` names the
    run in the error when it failed."""
    if status not in (0, TOLERANCE_NOT_MET) or not output.exists():
        raise RuntimeError(f"{what}: run failed (exit {status})")
    summary, sizes, versions = read_record(output)
    with h5py.File(output) as h5:
        return summary, sizes, versions, str(h5.attrs["physics"])


def ladder_key(row: dict) -> tuple:
    """(surface, F*, N, window, ranks, ladder, level) of a ladder row (window 0: the whole
    surface)."""
    return (row["surface"], float(row["load_star"]), int(row["n"]), int(row.get("window") or 0),
            int(row["ranks"]), row["ladder"], int(row["level"]))


def benchmark_ladders(sizes: list[int], ranks: int, max_level: int, ladders=("adaptive",),
                      cases=HEADLINE_CASES, windows=(None,),
                      table: Path | None = None) -> list[dict]:
    """Every case, grid size, window (None: the whole surface) and ladder in turn; the table
    (default ``ladder.csv``) is rewritten after each ladder, keeping the rows of other cases,
    sizes, windows, rank counts and ladders."""
    BENCH_DIR.mkdir(parents=True, exist_ok=True)
    table = BENCH_DIR / "ladder.csv" if table is None else table
    rows = []
    for surface, load in cases:
        for n in sizes:
            for window in windows:
                for ladder in ladders:
                    new = run_ladder_levels(surface, load, n, ranks, max_level, ladder, window)
                    merge_ladder_rows(table, new)
                    rows += new
                    print(json.dumps(new), file=sys.stderr, flush=True)
    return rows


def merge_ladder_rows(table: Path, new: list[dict]) -> None:
    """Put one ladder's rows into the ladder table, replacing that ladder's earlier rows (all
    of its levels) and keeping the others; written whole or not at all."""
    replaced = ladder_key(new[0])[:6]
    kept = {ladder_key(row): row for row in read_table(table)
            if ladder_key(row)[:6] != replaced}
    kept |= {ladder_key(row): row for row in new}
    atomic_write(table, lambda temporary: write_csv([kept[key] for key in sorted(kept)],
                                                    Path(temporary), LADDER_COLUMNS))


def read_table(path: Path) -> list[dict]:
    """The rows of a CSV table (none if there is no file)."""
    if not path.exists():
        return []
    with open(path, newline="") as file:
        return list(csv.DictReader(file))


def write_csv(rows: list[dict], path: Path, columns=COLUMNS) -> None:
    """The benchmark table (of ``columns``; other keys of the rows are left out)."""
    with open(path, "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


def row_key(row: dict) -> tuple[str, float, int, int]:
    """(surface, F*, N, ranks) of a row (rows written before the cases were columns are G5 at
    F* = 0.155)."""
    return (row.get("surface") or "G5", float(row.get("load_star") or 0.155), int(row["n"]),
            int(row["ranks"]))


def read_rows(path: Path) -> dict[tuple, dict]:
    """The rows of an existing benchmark table, by :func:`row_key` (empty if there is none)."""
    table = {}
    for row in read_table(path):
        key = row_key(row)
        table[key] = row | {"surface": key[0], "load_star": key[1]}
    return table


def benchmark_sizes(sizes: list[int], ranks: int,
                    cases=HEADLINE_CASES) -> list[dict]:
    """Run every case on every grid size in turn; rewrite ``fem.csv`` after each run (keeping
    the rows of other cases, N or rank counts); return the new rows."""
    BENCH_DIR.mkdir(parents=True, exist_ok=True)
    table = BENCH_DIR / "fem.csv"
    rows = []
    for surface, load in cases:
        for n in sizes:
            rows.append(run_size(surface, load, n, ranks))
            kept = read_rows(table) | {row_key(rows[-1]): rows[-1]}
            write_csv([kept[key] for key in sorted(kept)], table)
            print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return rows


def finer_path_options(factor: float) -> dict:
    """Solver options of a load path ``factor`` times finer than the default: its largest
    preload and sliding increments divided by ``factor``."""
    default = SolverOptions()
    return {"max_preload_increment": default.max_preload_increment / factor,
            "max_slide_increment": default.max_slide_increment / factor}


def path_errors(n: int, ranks: int, cases=HEADLINE_CASES, factor: float = PATH_FACTOR
                ) -> list[dict]:
    """Each case on the default load path and on one ``factor`` times finer: the relative
    difference of mu_s is the path's error estimate. Rewrites ``path.csv`` after each case
    (keeping the rows of other cases, N or rank counts)."""
    BENCH_DIR.mkdir(parents=True, exist_ok=True)
    table = BENCH_DIR / "path.csv"
    config = BENCH_DIR / f"path_x{factor:g}.toml"
    config.write_text("[solver]\n" + "".join(
        f"{key} = {value!r}\n" for key, value in finer_path_options(factor).items()))
    rows = []
    for surface, load in cases:
        default = run_size(surface, load, n, ranks, label="path")
        fine = run_size(surface, load, n, ranks, config, label=f"path_x{factor:g}")
        both = default["mu_s"] is not None and fine["mu_s"] is not None  # (None: no inception)
        rows.append({"surface": surface, "load_star": load, "n": n, "ranks": ranks,
                     "path_factor": factor, "mu_s": default["mu_s"],
                     "mu_s_fine_path": fine["mu_s"],
                     "path_error": default["mu_s"] / fine["mu_s"] - 1.0 if both else None,
                     "newton_iterations": default["newton_iterations"],
                     "fine_newton_iterations": fine["newton_iterations"],
                     "wall_s": default["wall_s"], "fine_wall_s": fine["wall_s"],
                     "converged": default["converged"] and fine["converged"],
                     "physics": default.get("physics")})
        kept = read_rows(table) | {row_key(rows[-1]): rows[-1]}
        write_csv([kept[key] for key in sorted(kept)], table, PATH_COLUMNS)
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return rows


#: Memory of a profiled run's fixed start-up on 2 ranks (imports, gmsh) [GB], subtracted in
#: memory.csv's "above the fixed" row.
FIXED_STARTUP_GB = 0.335
#: Columns of memory.csv (``make bench-profile MEMORY_CSV=...``).
MEMORY_COLUMNS = ("case", "version", "kind", "item", "gb", "kb_per_dof", "kb_per_surface_node",
                  "physics")


def memory_case_label(profile: dict) -> str:
    """memory.csv's name of a profiled case, e.g. "G5 N=64 F*=0.155 2 ranks 32784 dofs" (with
    the mesh's factor after N above level 0: "N=128 2x")."""
    case = profile["case"]
    level = case.get("level", 0)
    mesh = f"N={case['n']}" + (f" {2**level}x" if level else "")
    return (f"{case['surface']} {mesh} F*={case['load_star']:g} {case['ranks']} ranks "
            f"{profile['memory']['reduced_dofs']} dofs")


def memory_column(profile: dict, version: str) -> list[dict]:
    """memory.csv's rows of one version from a ``bench profile`` result: the peak after each
    set-up phase [GB, kB per dof], each object [GB, kB per dof and per surface node], the peak
    in all and above :data:`FIXED_STARTUP_GB`, and the run's mu_s, Newton and Krylov counts;
    each row with the profile's physics stamp ("" for a profile without one)."""
    memory, case = profile["memory"], memory_case_label(profile)

    physics = profile.get("physics", "")

    def row(kind, item, gb="", per_dof="", per_node=""):
        return dict(zip(MEMORY_COLUMNS, (case, version, kind, item, gb, per_dof, per_node,
                                         physics), strict=True))

    rows = [row("peak after phase", phase, f"{value['peak_gb']:.4f}",
                f"{value['peak_kb_per_dof']:.3f}") for phase, value in memory["phases"].items()]
    rows += [row("object", item, f"{value['gb']:.4f}", f"{value['kb_per_dof']:.3f}",
                 f"{value['kb_per_surface_node']:.3f}")
             for item, value in memory["objects"].items()]
    above = memory["peak_gb"] - FIXED_STARTUP_GB
    rows += [row("total", "peak (VmHWM, both ranks)", f"{memory['peak_gb']:.4f}",
                 f"{memory['peak_kb_per_dof']:.3f}"),
             row("total", f"peak above the fixed {FIXED_STARTUP_GB} GB (imports, gmsh)",
                 f"{above:.4f}", f"{above * 2**30 / 1e3 / memory['reduced_dofs']:.3f}")]
    krylov = "/".join(str(value["krylov_iterations"])
                      for value in profile["linear_solves"].values())
    return rows + [row("result", f"mu_s={profile['mu_s']:.12f} "
                       f"newton={profile['newton_iterations']} krylov={krylov}")]


def add_memory_column(path: Path, profile: dict, version: str) -> None:
    """Replace ``version``'s rows of memory.csv at ``path`` (written if absent) by those of
    ``profile`` (:func:`memory_column`); the other versions' rows stay.

    Raises
    ------
    InputError
        The file's rows are of another case than the profile's.
    """
    rows = read_table(Path(path))
    new = memory_column(profile, version)
    cases = {row["case"] for row in rows}
    if cases and cases != {new[0]["case"]}:
        raise InputError(f"{path} holds {', '.join(sorted(cases))}, not {new[0]['case']}: "
                         "profile that case or give another file")
    rows = [row for row in rows if row["version"] != version] + new
    atomic_write(path, lambda temporary: write_csv(rows, Path(temporary), MEMORY_COLUMNS))


def profile_case(surface: str, load: float, n: int, comm, directory: Path = BENCH_DIR,
                 level: int = 0) -> tuple[dict, Path]:
    """Profile one figure case (:func:`studies.paper.fem_case`) on level ``level`` of its
    uniform ladder (a mesh 2^level times finer, :func:`studies.refinement.level_case`) on every
    rank of ``comm`` (:func:`benchmarks.profile.profile_run`) and write the profile, with the
    case, its summary and the physics stamp, as ``directory/profile_<case_stem>.json`` (rank
    0); return it and its path.

    Raises
    ------
    ConvergenceError
        The run did not converge (after writing the profile).
    """
    from roughfriction.solver.run import stderr_progress
    from roughfriction.studies.paper import fem_case
    from roughfriction.studies.physics import physics_version
    from roughfriction.studies.refinement import level_case
    from roughfriction.version import __version__

    from benchmarks.profile import profile_run

    fem, profile = profile_run(level_case(fem_case(surface, load, n), level), comm,
                               stderr_progress(comm))
    summary = fem.result.summary()
    fem.equilibrium.destroy()
    profile |= {"case": {"surface": surface, "load_star": load, "n": n, "ranks": comm.size,
                         "level": level},
                **{key: summary[key] for key in ("mu_s", "newton_iterations", "steps",
                                                 "cut_steps", "converged")},
                "version": __version__, "physics": physics_stamp(physics_version())}
    stem = case_stem(surface, load, n, comm.size, level=level)
    path = Path(directory) / f"profile_{stem}.json"
    if comm.rank == 0:
        atomic_write(path, lambda tmp: Path(tmp).write_text(json.dumps(profile, indent=1)))
    if not summary["converged"]:
        raise ConvergenceError(f"{fem.result.message} (profile written to {path})")
    return profile, path
