"""Time the multi-scale theory over the cases of Figs. 22-28 (``python -m benchmarks
multiscale``): numbers written to ``results/bench/multiscale.csv``, not timed tests."""

from __future__ import annotations

import platform
import time

import numpy as np
from roughfriction.geometry.generate import builtin_surface
from roughfriction.material import Material
from roughfriction.multiscale.friction import static_friction
from roughfriction.multiscale.scales import scale_decomposition
from roughfriction.studies.paper import (
    GAUSSIAN_SURFACES,
    LOAD_SWEEP,
    LOAD_SWEEP_SURFACES,
    PSI_SWEEP_LOADS,
)
from roughfriction.studies.tables import csv_text, write_text

from benchmarks.batch import BENCH_DIR

#: Columns of multiscale.csv (time per evaluation [ms], load iterations [-], mu_s [-]).
COLUMNS = ("surface", "load_star", "time_ms", "iterations", "mu_s")


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
    rows = []
    for name, load in cases:
        seconds, result = _median_seconds(
            lambda n=name, f=load: static_friction(scales[n], f, material), repeats
        )
        rows.append(dict(zip(COLUMNS, (name, load, 1e3 * seconds, result.iterations,
                                       float(result.mu_s)), strict=True)))

    start = time.perf_counter()
    for name, load in cases:
        static_friction(scale_decomposition(surfaces[name]), load, material)
    all_curves_s = time.perf_counter() - start

    write_text(BENCH_DIR / "multiscale.csv", csv_text(rows, COLUMNS))
    times = np.array([row["time_ms"] for row in rows])
    return {
        "machine": f"{platform.processor() or platform.machine()}, {platform.python_version()}",
        "evaluations": len(cases),
        "fft_decomposition_ms": 1e3 * fft_s,
        "evaluation_median_ms": float(np.median(times)),
        "evaluation_max_ms": float(times.max()),
        "all_curves_s": all_curves_s,
        "csv": str(BENCH_DIR / "multiscale.csv"),
    }
