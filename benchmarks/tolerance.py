"""``roughfriction fem --tol`` on the paper's surfaces, its cost counted in plain elasticity
solves of the same block timed in the same hour (``benchmarks.elastic_solve``).

    python -m benchmarks tol --n 128 --ranks 2 --tol 0.03

Per case: the ladder under mpirun (``roughfriction fem S --load F --n N --tol T``), then one
plain elastic solve under mpirun on the uniform mesh of the ladder's finest level (2x: the
block of the 128^2 surface with cells twice as fine; the adaptive level meshes part of it
coarser): a row with the exit status, the mu_s and certificate (``mu_s_error``) of the
finest level run, the levels, the command's wall time and that time in elastic solves, the
peak memory summed over the ranks. Rows go to
``results/bench/tolerance.csv`` (rewritten after each case, other cases kept).
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

from roughfriction.files import atomic_write
from roughfriction.studies.physics import physics_stamp

from benchmarks.batch import BENCH_DIR
from benchmarks.fem import (
    case_stem,
    ladder_record,
    mpirun_environment,
    read_table,
    run_mpi,
    write_csv,
)

#: (surface, F*) of the rows: the paper's surfaces at F* = 0.155 and G5 at 0.93.
TOLERANCE_CASES = (("G5", 0.155), ("G1", 0.155), ("G9", 0.155), ("2L", 0.155), ("G5", 0.93))
#: Relative tolerance of the rows [-].
DEFAULT_TOLERANCE = 0.03
COLUMNS = ("surface", "load_star", "n", "ranks", "tol", "exit_status", "mu_s", "mu_s_error",
           "mu_s_relative_error", "levels", "finest_factor", "finest_reduced_dofs", "wall_s",
           "elastic_solve_s", "elastic_solves", "peak_memory_gb", "version", "physics")


def mpirun(ranks: int) -> list[str]:
    """The launcher prefix of the benchmark's commands."""
    return ["mpirun", "-n", str(ranks), "--oversubscribe", sys.executable]


def elastic_solve_seconds(surface: str, n: int, ranks: int, level: int = 0) -> float:
    """Seconds of one plain elasticity solve of the surface's n x n block, on its uniform
    ladder's level ``level``, on ``ranks`` ranks (``benchmarks.elastic_solve``, its own
    mpirun)."""
    command = mpirun(ranks) + ["-m", "benchmarks.elastic_solve", surface, "--n", str(n),
                               "--level", str(level)]
    done = subprocess.run(command, capture_output=True, text=True, env=mpirun_environment(),
                          cwd=Path(__file__).resolve().parent.parent)
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode != 0 or not lines:
        raise RuntimeError(f"elastic solve of {surface}, N = {n}: exit {done.returncode}: "
                           f"{done.stderr.strip().splitlines()[-1:] or ''}")
    return float(json.loads(lines[-1])["elastic_solve_s"])


def tolerance_row(surface: str, load: float, n: int, ranks: int, tol: float) -> dict:
    """Run ``roughfriction fem --tol`` on the case, then time one elastic solve on the uniform
    mesh of its finest level; its row."""
    output = BENCH_DIR / f"tol_{case_stem(surface, load, n, ranks)}.h5"
    output.unlink(missing_ok=True)
    command = mpirun(ranks) + ["-m", "roughfriction.scripts.cli", "fem", surface, "--load",
                               str(load), "--n", str(n), "--tol", str(tol), "--output",
                               str(output)]
    started = time.perf_counter()
    status = run_mpi(command)
    wall_s = time.perf_counter() - started
    summary, sizes, versions, physics = ladder_record(
        output, status, f"{surface} at F* = {load:g}, N = {n}, --tol {tol:g}")
    levels = summary["levels"]
    unit_s = elastic_solve_seconds(surface, n, ranks, int(levels["factor"][-1]).bit_length() - 1)
    return {"surface": surface, "load_star": load, "n": n, "ranks": ranks, "tol": tol,
            "exit_status": status, "mu_s": summary["mu_s"],
            "mu_s_error": summary["mu_s_error"],
            "mu_s_relative_error": summary["mu_s_error_relative"],
            "levels": len(levels["factor"]), "finest_factor": levels["factor"][-1],
            "finest_reduced_dofs": levels["reduced_dofs"][-1], "wall_s": wall_s,
            "elastic_solve_s": unit_s, "elastic_solves": wall_s / unit_s,
            "peak_memory_gb": sizes.get("peak_memory_gb"),
            "version": versions.get("roughfriction"), "physics": physics_stamp(physics)}


def benchmark_tolerance(n: int, ranks: int, tol: float = DEFAULT_TOLERANCE,
                        cases=TOLERANCE_CASES, table: Path | None = None) -> list[dict]:
    """Every case in turn (:func:`tolerance_row`); the table (default tolerance.csv) rewritten
    after each, keeping the rows of other cases, sizes and rank counts."""
    BENCH_DIR.mkdir(parents=True, exist_ok=True)
    table = BENCH_DIR / "tolerance.csv" if table is None else table
    rows = []
    for surface, load in cases:
        row = tolerance_row(surface, load, n, ranks, tol)
        key = (surface, float(load), n, ranks)
        kept = [old for old in read_table(table)
                if (old["surface"], float(old["load_star"]), int(old["n"]),
                    int(old["ranks"])) != key]
        atomic_write(table, lambda temporary, kept=kept, row=row: write_csv(
            kept + [row], Path(temporary), COLUMNS))
        rows.append(row)
        print(json.dumps(row), file=sys.stderr, flush=True)
    return rows

