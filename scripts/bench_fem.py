"""FEM benchmark: G5 at F* = 0.155 on N x N surface grids, each run by ``mpirun`` as the CLI.

    roughfriction bench fem --n 32 64 128 --ranks 2

Writes ``results/bench/fem.csv`` (one row per N and rank count, rewritten after every run so that
finished rows survive a later failure; rows of other N or rank counts already in the file are
kept: ``--ranks 1`` adds the serial rows beside the two-rank ones) with wall time, peak
memory summed over the ranks, steps, Newton iterations, mu_s and the problem size; each run's
full record goes to ``results/bench/fem_G5_N<N>_<ranks>ranks.h5``.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

BENCH_DIR = Path("results/bench")
SURFACE, LOAD = "G5", 0.155
DEFAULT_SIZES = (32, 64, 128)
COLUMNS = ("n", "ranks", "cells", "reduced_dofs", "linear_solver", "wall_s", "peak_memory_gb",
           "steps", "newton_iterations", "mu_s", "converged")


def run_size(n: int, ranks: int) -> dict:
    """Run one grid size through ``roughfriction.scripts.fem`` under mpirun; return its row."""
    output = BENCH_DIR / f"fem_{SURFACE}_N{n}_{ranks}ranks.h5"
    command = ["mpirun", "-n", str(ranks), "--oversubscribe", sys.executable, "-m",
               "roughfriction.scripts.fem", SURFACE, "--load", str(LOAD), "--n", str(n), "--json",
               "--output", str(output)]
    output.unlink(missing_ok=True)
    finished = subprocess.run(command, stdout=subprocess.DEVNULL)  # progress, errors: stderr
    if not output.exists():
        raise RuntimeError(f"N = {n}: run failed (exit {finished.returncode}) without results")
    with h5py.File(output) as h5:
        summary = json.loads(h5.attrs["summary"])
        sizes = {key: value.item() if isinstance(value, np.generic) else value
                 for key, value in h5["sizes"].attrs.items()}
    row = {"n": n, "ranks": ranks, **{key: sizes.get(key) for key in
                                      ("cells", "reduced_dofs", "linear_solver",
                                       "peak_memory_gb")}}
    row.update({key: summary[key] for key in ("wall_s", "steps", "newton_iterations", "mu_s",
                                              "converged")})
    return row


def write_csv(rows: list[dict], path: Path) -> None:
    """The benchmark table."""
    with open(path, "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)


def read_rows(path: Path) -> dict[tuple[int, int], dict]:
    """The rows of an existing benchmark table, by (N, ranks) (empty if there is none)."""
    if not path.exists():
        return {}
    with open(path, newline="") as file:
        return {(int(row["n"]), int(row["ranks"])): row for row in csv.DictReader(file)}


def benchmark_sizes(sizes: list[int], ranks: int) -> list[dict]:
    """Run every grid size in turn; rewrite ``fem.csv`` after each (keeping rows of other N or
    rank counts); return the new rows."""
    BENCH_DIR.mkdir(parents=True, exist_ok=True)
    table = BENCH_DIR / "fem.csv"
    rows = []
    for n in sizes:
        rows.append(run_size(n, ranks))
        kept = {**read_rows(table), (n, ranks): rows[-1]}
        write_csv([kept[key] for key in sorted(kept)], table)
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return rows
