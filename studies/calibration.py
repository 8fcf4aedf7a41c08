"""Calibration of the discretisation error estimate of mu_s against a fine uniform reference.

    mpirun -n 2 python -m roughfriction.studies.calibration docs/bench/calibration.csv [N]

On small windows of i.i.d. (G1, G5, G9) and self-affine (2L, 8L) surfaces, each case is run on
uniform meshes 1x, 2x, 4x and the reference 8x (``studies.refinement.level_case``; both loads
share one preload per level, ``solver.run.run_loads``). The estimate ``--tol`` would report
after two levels (2x value, assumed order) and after three (4x value, observed order where the
differences shrink) is checked against the 8x value (issue 53, item 3):

* covered: |mu_s - reference| <= mu_s_error;
* sharp: mu_s_error <= 3 |mu_s - reference| + :data:`SHARPNESS_FLOOR` mu_s (an estimate that is
  always huge is no estimate).

The 8x value has its own error, so for the 4x estimate |mu_s - reference| is a lower bound of
the true error. Rows are written as each surface finishes (rank 0, atomically).
"""

from __future__ import annotations

import csv
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from roughfriction.files import atomic_write
from roughfriction.studies.refinement import LADDER_RATIO, ladder_estimate, level_case

#: The test set: (surface, 0-based window) of CALIBRATION_N x CALIBRATION_N points.
CALIBRATION_SURFACES = (("G1", 0), ("G5", 0), ("G9", 0), ("2L", 0), ("8L", 0), ("8L", 1))
#: Window size of the test set [points per side].
CALIBRATION_N = 4
#: Normal loads F* [-].
CALIBRATION_LOADS = (0.155, 0.93)
#: Level of the reference (2^3 = 8x) [-].
REFERENCE_LEVEL = 3
#: Allowance of the sharpness check, relative to mu_s [-].
SHARPNESS_FLOOR = 0.005
#: Columns of the calibration table.
COLUMNS = ("surface", "window", "n", "load_star", "levels_used", "mu_1x", "mu_2x", "mu_4x",
           "reference_factor", "mu_reference", "mu_s", "mu_s_error", "order", "order_observed",
           "actual_error", "covered", "sharp", "dofs_reference", "wall_reference_s")


#: The calibration table quoted with every error estimate (in the checkout).
QUOTED_TABLE = Path(__file__).resolve().parent.parent / "docs" / "bench" / "calibration_n8.csv"


def coverage_statement(table: Path = QUOTED_TABLE) -> str:
    """One line on what ``--tol``'s error estimate is and how often it covered the reference
    in ``table`` (a calibration CSV of :data:`COLUMNS`); without the table, where to read it."""
    what = "the error estimate is a Richardson extrapolation from the last two or three levels"
    try:
        with open(table, newline="") as file:
            rows = list(csv.DictReader(file))
    except OSError:
        return f"{what}; its measured coverage is in docs/verification.md (calibration)"
    covered = sum(row["covered"] == "True" for row in rows)
    windows = sorted({int(row["n"]) for row in rows})
    sizes = ", ".join(f"{n}^2" for n in windows)
    return (f"{what}; against an {rows[0]['reference_factor']}x reference on {sizes} windows it "
            f"covered {covered} of {len(rows)} ladders ({table.name}), not yet calibrated on "
            "whole surfaces")


@dataclass(frozen=True)
class Check:
    """One estimate against the reference: the estimated value and error, and the two
    criteria."""

    mu_s: float
    error: float
    actual: float
    covered: bool
    sharp: bool


def check_estimate(mu_s: float, error: float, reference: float) -> Check:
    """Check an estimate ``mu_s +- error`` against ``reference`` (module docstring)."""
    actual = abs(mu_s - reference)
    return Check(mu_s, error, actual, actual <= error,
                 error <= 3.0 * actual + SHARPNESS_FLOOR * abs(mu_s))


def calibration_rows(surface: str, window: int, n: int, load: float, values: list,
                     sizes: dict) -> list[dict]:
    """The table rows of one case from its values on levels 0, 1, ... (coarse to fine; the
    last is the reference): one per estimate from the first 2, 3, ... levels short of the
    reference, each checked against it."""
    reference = values[-1]
    rows = []
    for used in range(2, len(values)):
        estimate = ladder_estimate(values[:used])
        check = check_estimate(values[used - 1], estimate.error, reference)
        rows.append({
            "surface": surface, "window": window + 1, "n": n, "load_star": load,
            "levels_used": used,
            **{f"mu_{LADDER_RATIO**k}x": values[k] for k in range(len(values) - 1)},
            "reference_factor": LADDER_RATIO**(len(values) - 1), "mu_reference": reference,
            "mu_s": check.mu_s, "mu_s_error": check.error,
            "order": estimate.order, "order_observed": estimate.observed,
            "actual_error": check.actual, "covered": check.covered, "sharp": check.sharp,
            **sizes,
        })
    return rows


def write_table(path: Path, rows: list[dict]) -> None:
    """Write the rows as CSV (atomically), numbers to 6 significant digits."""
    def write(temporary) -> None:
        with open(temporary, "w", newline="") as file:
            writer = csv.DictWriter(file, COLUMNS, extrasaction="ignore")
            writer.writeheader()
            for row in rows:
                writer.writerow({key: f"{value:.6g}" if isinstance(value, float) else value
                                 for key, value in row.items()})
    atomic_write(Path(path), write)


def surface_levels(surface: str, window: int, n: int, loads, comm,
                   top_level: int = REFERENCE_LEVEL) -> tuple[dict, dict]:
    """mu_s of a window at every load on levels 0..top_level, and the finest level's size.

    Returns
    -------
    values : dict
        Load -> list of mu_s, coarse to fine (None for an unconverged run).
    sizes : dict
        ``dofs_reference`` (reduced dofs) and ``wall_reference_s`` [s] of the finest level
        (both loads).
    """
    from roughfriction.case import FemCase, Loading
    from roughfriction.geometry.generate import builtin_surface
    from roughfriction.solver.run import run_loads
    from roughfriction.studies.paper import surface_window

    case = FemCase(surface_window(builtin_surface(surface), n, window), Loading(loads[0]))
    values = {load: [] for load in loads}
    sizes = {}
    for level in range(top_level + 1):
        started = time.perf_counter()
        runs = run_loads(level_case(case, level), loads, comm, progress=lambda record: None)
        for load, fem_run in zip(loads, runs, strict=True):
            converged = fem_run.result.converged
            values[load].append(fem_run.result.summary()["mu_s"] if converged else None)
        sizes = {"dofs_reference": runs[0].result.sizes["reduced_dofs"],
                 "wall_reference_s": time.perf_counter() - started}
        if comm.rank == 0:
            print(f"{surface} window {window + 1} level {level} ({LADDER_RATIO**level}x): "
                  f"mu_s {[values[load][-1] for load in loads]}, {sizes['dofs_reference']} "
                  f"dofs, {sizes['wall_reference_s']:.0f} s", file=sys.stderr, flush=True)
        del runs
    return values, sizes


def run_calibration(path: Path, comm, surfaces=CALIBRATION_SURFACES, n: int = CALIBRATION_N,
                    loads=CALIBRATION_LOADS, top_level: int = REFERENCE_LEVEL) -> list[dict]:
    """Run the test set and write its table to ``path`` (rank 0) after every surface; a case
    with an unconverged level is left out of the table and named on stderr."""
    rows = []
    for surface, window in surfaces:
        values, sizes = surface_levels(surface, window, n, loads, comm, top_level)
        for load in loads:
            if None in values[load]:
                if comm.rank == 0:
                    print(f"{surface} window {window + 1} F* = {load}: a level did not "
                          "converge, left out", file=sys.stderr, flush=True)
                continue
            rows += calibration_rows(surface, window, n, load, values[load], sizes)
        if comm.rank == 0:
            write_table(path, rows)
    return rows


def main(argv: list[str] | None = None) -> int:
    """Run the calibration and write the table to the path given (default
    docs/bench/calibration.csv), on windows of the size given second (default
    :data:`CALIBRATION_N`); print the pass counts on rank 0."""
    from mpi4py import MPI

    argv = sys.argv[1:] if argv is None else argv
    path = Path(argv[0] if argv else "docs/bench/calibration.csv")
    n = int(argv[1]) if len(argv) > 1 else CALIBRATION_N
    rows = run_calibration(path, MPI.COMM_WORLD, n=n)
    if MPI.COMM_WORLD.rank == 0:
        for used in (2, 3):
            chosen = [row for row in rows if row["levels_used"] == used]
            print(f"{used} levels: covered {sum(row['covered'] for row in chosen)}/{len(chosen)}"
                  f", sharp {sum(row['sharp'] for row in chosen)}/{len(chosen)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
