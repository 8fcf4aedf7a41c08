"""Benchmarks: numbers (time, iterations, result) written to ``results/bench/``, not timed tests."""

from __future__ import annotations

import platform
import time
from pathlib import Path

import numpy as np

from geometry.generate import builtin_surface
from multiscale.friction import static_friction
from multiscale.scales import scale_decomposition
from scripts.cases import GAUSSIAN_SURFACES, LOAD_SWEEP, LOAD_SWEEP_SURFACES, PSI_SWEEP_LOADS
from scripts.figures import write_table
from solver.material import Material

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


def bench_fem() -> dict:
    """FEM benchmark (G5, F* = 0.155, N = 32, 64, 128 on 2 ranks): see :mod:`solver.benchmark`."""
    from solver.benchmark import BENCH_DIR as FEM_DIR
    from solver.benchmark import benchmark_sizes

    rows = benchmark_sizes([32, 64, 128], ranks=2)
    return {"runs": rows, "csv": str(FEM_DIR / "fem.csv")}


BENCHMARKS = {"multiscale": bench_multiscale, "fem": bench_fem}
