"""FEM benchmark: the headline cases on N x N surface grids, each run by ``mpirun`` as the CLI.

    roughfriction bench fem --n 32 64 128 --ranks 2 --case G5:0.155 G1:1.86

Headline cases (the default): G5 at F* = 0.155 and 0.93, the 2L stand-in at 0.5, G1 at 1.86
(complete contact). Writes ``results/bench/fem.csv`` (one row per case, N and rank count,
rewritten after every run so that finished rows survive a later failure; rows of other cases, N
or rank counts already in the file are kept) with wall time, peak memory summed over the
ranks, steps, Newton iterations, mu_s and the problem size; each run's full record goes to
``results/bench/fem_<surface>_F<load>_N<N>_<ranks>ranks.h5``.
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
#: (surface, F*) of the headline rows.
HEADLINE_CASES = (("G5", 0.155), ("G5", 0.93), ("2L", 0.5), ("G1", 1.86))
DEFAULT_SIZES = (32, 64, 128)
COLUMNS = ("surface", "load_star", "n", "ranks", "cells", "reduced_dofs", "linear_solver",
           "wall_s", "peak_memory_gb", "steps", "newton_iterations", "cut_steps", "cut_iterations",
           "mu_s", "converged")


def parse_case(text: str) -> tuple[str, float]:
    """'SURFACE:LOAD' (e.g. 'G5:0.155') as (surface, F*)."""
    from roughfriction.errors import InputError

    surface, _, load = text.partition(":")
    try:
        return surface, float(load)
    except ValueError:
        raise InputError(f"a benchmark case is SURFACE:LOAD, e.g. G5:0.155, got {text!r}") from None


def case_stem(surface: str, load: float, n: int, ranks: int) -> str:
    """``<surface>_F<load>_N<n>_<ranks>ranks``: the file name of one benchmark case's output."""
    return f"{surface}_F{load:g}_N{n}_{ranks}ranks"


def run_size(surface: str, load: float, n: int, ranks: int) -> dict:
    """Run one case and grid size through ``roughfriction.scripts.fem`` under mpirun; return
    its row."""
    output = BENCH_DIR / f"fem_{case_stem(surface, load, n, ranks)}.h5"
    command = ["mpirun", "-n", str(ranks), "--oversubscribe", sys.executable, "-m",
               "roughfriction.scripts.fem", surface, "--load", str(load), "--n", str(n),
               "--json", "--output", str(output)]
    output.unlink(missing_ok=True)
    finished = subprocess.run(command, stdout=subprocess.DEVNULL)  # progress, errors: stderr
    if not output.exists():
        raise RuntimeError(f"{surface} at F* = {load:g}, N = {n}: run failed (exit "
                           f"{finished.returncode}) without results")
    with h5py.File(output) as h5:
        summary = json.loads(h5.attrs["summary"])
        sizes = {key: value.item() if isinstance(value, np.generic) else value
                 for key, value in h5["sizes"].attrs.items()}
    row = {"surface": surface, "load_star": load, "n": n, "ranks": ranks}
    row.update({key: sizes.get(key) for key in ("cells", "reduced_dofs", "linear_solver",
                                                "peak_memory_gb")})
    row.update({key: summary[key] for key in ("wall_s", "steps", "newton_iterations",
                                              "cut_steps", "cut_iterations", "mu_s",
                                              "converged")})
    return row


def write_csv(rows: list[dict], path: Path) -> None:
    """The benchmark table."""
    with open(path, "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)


def row_key(row: dict) -> tuple[str, float, int, int]:
    """(surface, F*, N, ranks) of a row (rows written before the cases were columns are G5 at
    F* = 0.155)."""
    return (row.get("surface") or "G5", float(row.get("load_star") or 0.155), int(row["n"]),
            int(row["ranks"]))


def read_rows(path: Path) -> dict[tuple, dict]:
    """The rows of an existing benchmark table, by :func:`row_key` (empty if there is none)."""
    if not path.exists():
        return {}
    table = {}
    with open(path, newline="") as file:
        for row in csv.DictReader(file):
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
