"""The calibration set: uniform ladders 1x, 2x, 4x, 8x (16x where asked) of 16 x 16 windows,
run resumably, one row per (window, load, level), stamped with the physics version.

    mpirun -n 2 python -m benchmarks.calibration_set docs/bench/calibration_ladders.csv \
        [LEVELS [LOADS [SURFACES]]]

The table holds measured values only (mu_s, areas, contact counts, cost); the error estimate
under test is judged from it afterwards (``benchmarks.calibration``), so an estimate can change
without re-running the set. Each window runs all its loads on one shared preload per level
(``solver.run.run_loads``); rows are appended after every level (rank 0, atomically) and a
window-level-load already in the table with today's physics (or physics an equivalence record
beside the table carries to it) is skipped, so a killed run resumes at the level it was on,
and a level run at some loads first (the cheap low loads of an 8x level) gets the others
later.
"""

from __future__ import annotations

import csv
import sys
import time
from pathlib import Path

from roughfriction.files import atomic_write

#: The set: (surface, 0-based window) of SET_N x SET_N points. Windows 1 (0-based 0) of these
#: surfaces shaped the zone rule and the earlier calibrations; these are others.
SET_WINDOWS = (("G1", 9), ("G3", 18), ("G5", 27), ("G7", 36), ("G9", 45), ("2L", 54),
               ("8L", 63))
#: Window size of the set [points per side].
SET_N = 16
#: Normal loads F* [-], run on one shared preload per level.
SET_LOADS = (0.06, 0.155, 0.5, 0.93, 1.86)
#: Levels run by default (0: own grid; level L is 2^L times finer) [-].
SET_LEVELS = (0, 1, 2, 3)
#: Columns of the ladder table.
COLUMNS = ("surface", "window", "n", "load_star", "level", "factor", "mu_s", "converged",
           "area_ratio_normal", "area_ratio_sliding", "contact_nodes", "contact_patches",
           "cells_per_patch", "boundary_nodes", "steps", "newton_iterations", "reduced_dofs",
           "wall_level_s", "peak_memory_gb", "physics")


def read_rows(path: Path) -> list[dict]:
    """The rows of a ladder table (strings), none when it does not exist."""
    try:
        with open(path, newline="") as file:
            return list(csv.DictReader(file))
    except FileNotFoundError:
        return []


def write_rows(path: Path, rows: list[dict], columns=COLUMNS, digits: int = 7) -> None:
    """Write the rows as CSV of ``columns`` (atomically), floats to ``digits`` significant
    digits."""
    def write(temporary) -> None:
        with open(temporary, "w", newline="") as file:
            writer = csv.DictWriter(file, columns, extrasaction="ignore")
            writer.writeheader()
            for row in rows:
                writer.writerow({key: f"{value:.{digits}g}" if isinstance(value, float)
                                 else value for key, value in row.items()})
    atomic_write(Path(path), write)


def done(rows: list[dict], surface: str, window: int, level: int, physics,
         load: float | None = None) -> bool:
    """Whether the table holds the window's level (at ``load``, F* [-], if given) made by this
    code's physics, or by earlier physics an equivalence record carries to it (``physics``: a
    ``benchmarks.stamps.Physics``)."""
    return any(row["surface"] == surface and int(row["window"]) == window + 1
               and int(row["level"]) == level and physics.is_current(row["physics"])
               and (load is None or float(row["load_star"]) == load)
               for row in rows)


def level_rows(surface: str, window: int, n: int, level: int, loads, runs, wall_s: float,
               peak_gb: float, stamp: str) -> list[dict]:
    """The table rows of one window-level, a row per load."""
    rows = []
    for load, fem_run in zip(loads, runs, strict=True):
        summary = fem_run.result.summary()
        rows.append({
            "surface": surface, "window": window + 1, "n": n, "load_star": load,
            "level": level, "factor": 2**level, "mu_s": summary["mu_s"],
            "converged": summary["converged"],
            "area_ratio_normal": summary["area_ratio_normal"],
            "area_ratio_sliding": summary["area_ratio_sliding"],
            "contact_nodes": summary["contact_nodes"],
            "contact_patches": summary["contact_patches"],
            "cells_per_patch": summary["cells_per_patch"],
            "boundary_nodes": summary["boundary_nodes"],
            "steps": summary["steps"],
            "newton_iterations": summary["newton_iterations"],
            "reduced_dofs": fem_run.result.sizes["reduced_dofs"], "wall_level_s": wall_s,
            "peak_memory_gb": peak_gb, "physics": stamp})
    return rows


def run_set(path: Path, comm, windows=SET_WINDOWS, n: int = SET_N, loads=SET_LOADS,
            levels=SET_LEVELS, level_case=None) -> None:
    """Run every window's levels not yet in ``path`` with today's physics, appending as each
    finishes; progress on stderr (rank 0), a line per step (:func:`level_progress`).
    ``level_case(case, level)``: the case of a level (default the uniform ladder's,
    ``studies.refinement.level_case``)."""
    from roughfriction.case import FemCase, Loading
    from roughfriction.geometry.generate import builtin_surface
    from roughfriction.solver.run import run_loads
    from roughfriction.studies.cache import release
    from roughfriction.studies.paper import surface_window
    from roughfriction.studies.refinement import level_case as uniform_level_case

    from benchmarks.stamps import code_physics

    level_case = level_case or uniform_level_case

    physics = code_physics(Path(path).parent)
    stamp = physics.today
    rows = read_rows(path)
    for surface, window in windows:
        case = FemCase(surface_window(builtin_surface(surface), n, window), Loading(loads[0]))
        for level in levels:
            missing = [load for load in loads
                       if not done(rows, surface, window, level, physics, load)]
            if not missing:
                continue
            started = time.perf_counter()
            runs = run_loads(level_case(case, level), missing, comm,
                             progress=level_progress(comm, f"{surface} {2**level}x"))
            release(runs)  # the rows need their results alone; the next level starts empty
            wall_s = time.perf_counter() - started
            peak_gb = max(run.result.sizes.get("peak_memory_gb", float("nan")) for run in runs)
            rows += level_rows(surface, window, n, level, missing, runs, wall_s, peak_gb, stamp)
            if comm.rank == 0:
                write_rows(path, rows)
                values = ", ".join(f"{run.result.mu_s or float('nan'):.4f}" for run in runs)
                print(f"{time.strftime('%H:%M')} {surface} window {window + 1} level {level} "
                      f"({2**level}x): mu_s {values}; {runs[0].result.sizes['reduced_dofs']} "
                      f"dofs, {wall_s:.0f} s, {peak_gb:.2f} GB", file=sys.stderr, flush=True)
            del runs


def level_progress(comm, label: str):
    """A run's progress callable: each record (``solver.progress``) as one stderr line on rank
    0, with the clock and ``label``, so a level of hours shows where it is."""
    def write(record) -> None:
        if comm.rank == 0:
            print(f"  {time.strftime('%H:%M')} {label}: {str(record).strip()}", file=sys.stderr,
                  flush=True)
    return write


def set_windows(surfaces: str) -> tuple:
    """The :data:`SET_WINDOWS` of the comma-separated ``surfaces`` (e.g. ``G1,2L``).

    Raises
    ------
    ValueError
        A surface that is not in the set.
    """
    known = dict(SET_WINDOWS)
    names = surfaces.split(",")
    unknown = [name for name in names if name not in known]
    if unknown:
        raise ValueError(f"not in the calibration set: {', '.join(unknown)}; "
                         f"it holds {', '.join(known)}")
    return tuple((name, known[name]) for name in names)


def main(argv: list[str] | None = None) -> int:
    """``TABLE [LEVELS [LOADS [SURFACES]]]``: run the set into TABLE (default
    docs/bench/calibration_ladders.csv) on the LEVELS (e.g. ``0,1,2,3``), at the LOADS (F*,
    e.g. ``0.06,0.155``) of the windows of the SURFACES (e.g. ``G1,G5``), each default all."""
    from mpi4py import MPI

    argv = sys.argv[1:] if argv is None else argv
    path = Path(argv[0] if argv else "docs/bench/calibration_ladders.csv")
    levels = tuple(int(level) for level in argv[1].split(",")) if len(argv) > 1 else SET_LEVELS
    loads = tuple(float(load) for load in argv[2].split(",")) if len(argv) > 2 else SET_LOADS
    try:
        windows = set_windows(argv[3]) if len(argv) > 3 else SET_WINDOWS
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    run_set(path, MPI.COMM_WORLD, windows=windows, loads=loads, levels=levels)
    return 0


if __name__ == "__main__":
    sys.exit(main())
