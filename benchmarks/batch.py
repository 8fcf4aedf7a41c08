"""Batches of FEM runs for the benchmarks (:mod:`benchmarks.convergence`,
:mod:`benchmarks.stress`).

Every run goes through the run cache (:func:`studies.cache.cached_results`), one cache call per
group of runs that differ only in the load (they share one normal loading path), the groups of
the smallest surface grids first. Before each group the peak resident memory of every rank is
reset, so that the ``peak_memory_gb`` a run records is that of its own group, not of the
largest run computed earlier in the same process. A run that cannot start (an inverted mesh:
:class:`studies.cache.RunsNotStarted`) is recorded with its message instead of ending the
batch; any other exception ends it (finished runs stay in the cache).

Imports without dolfinx; :func:`compute_batch` needs mpi4py and, for missing runs, the FEM.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from roughfriction.case import FemCase
from roughfriction.studies.cache import (
    RunsNotStarted,
    cached_results,
    finished_entry,
    group_key,
    physics_version,
    run_key,
    runs_directory,
)

#: Where the benchmark tables and plots go.
BENCH_DIR = Path("results/bench")
#: Summary keys of a results file copied into the benchmark tables (units in the run summary:
#: areas and growth [-], wall time [s]).
SUMMARY_COLUMNS = ("converged", "mu_s", "area_ratio_normal", "area_ratio_sliding",
                   "junction_growth", "contact_nodes", "contact_patches", "nodes_per_patch",
                   "cells_per_patch", "reliable", "steps", "cut_steps", "newton_iterations",
                   "cpu_share")
#: Least CPU share (``studies.cache.CpuShare``) of a run whose wall time counts as measured on
#: a quiet machine [-].
QUIET_CPU_SHARE = 0.9


@dataclass(frozen=True)
class BatchResult:
    """Where the results of one case of a batch are.

    Attributes
    ----------
    path : pathlib.Path or None
        Its results file (a run-cache entry); None if its run could not start.
    error : str
        Why it could not start ("" when there is a results file).
    """

    path: Path | None
    error: str = ""


def reset_peak_memory() -> bool:
    """Reset this process's peak resident memory (what ``ru_maxrss`` reports) to its current
    size (Linux: "5" written to /proc/self/clear_refs); False where that is not possible (the
    peaks then accumulate over the process)."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        return False
    return True


def batch_groups(cases: Sequence[FemCase]) -> list[list[int]]:
    """Indices of ``cases`` grouped by everything but the load (:func:`studies.cache.group_key`),
    the groups ordered by surface cells per side N (smallest first), then by first appearance.
    """
    groups: dict[str, list[int]] = {}
    for index, case in enumerate(cases):
        groups.setdefault(group_key(case), []).append(index)
    return sorted(groups.values(), key=lambda members: cases[members[0]].surface.n)


def compute_batch(cases: Sequence[FemCase], comm, directory=None,
                  progress=None) -> list[BatchResult]:
    """The results file of every case, computing the missing runs group by group.

    Parameters
    ----------
    cases : sequence of FemCase
        The runs (repeats allowed).
    comm : mpi4py.MPI.Comm
        Every rank computes; call on all of them.
    directory : str or pathlib.Path, optional
        The run cache (default :func:`studies.cache.runs_directory`).
    progress : callable, optional
        Receives the progress lines (rank 0); default stderr.

    Returns
    -------
    list of BatchResult
        One per case, in order.
    """
    results: list[BatchResult | None] = [None] * len(cases)
    for members in batch_groups(cases):
        reset_peak_memory()
        try:
            paths = cached_results([cases[index] for index in members], comm, progress,
                                   directory)
            found = [BatchResult(path) for path in paths]
        except RunsNotStarted as error:
            found = [BatchResult(None, error.reasons[path]) if path in error.reasons
                     else BatchResult(path) for path in error.paths]
        for index, result in zip(members, found, strict=True):
            results[index] = result
    return results


#: The message of a run that :func:`cached_batch` did not find.
NOT_IN_CACHE = "not computed (not in the run cache)"


def cached_batch(cases: Sequence[FemCase], directory=None) -> list[BatchResult]:
    """The results file of every case that is in the run cache, computing nothing; a missing
    run is a :class:`BatchResult` without a file that says so."""
    directory = runs_directory(directory)
    physics = physics_version()
    paths = [finished_entry(directory, case, physics) for case in cases]
    return [BatchResult(path) if path else BatchResult(None, NOT_IN_CACHE) for path in paths]


def batch_plan(cases: Sequence[FemCase], directory=None) -> list[str]:
    """What :func:`compute_batch` would do, as text lines: per N, the distinct runs, how many
    are in the cache, and the runs and groups (``run_loads`` calls) left to compute."""
    directory = runs_directory(directory)
    physics = physics_version()
    distinct = {run_key(case, physics): case for case in cases}
    missing = [case for case in distinct.values()
               if finished_entry(directory, case, physics) is None]
    runs = Counter(case.surface.n for case in distinct.values())
    to_run = Counter(case.surface.n for case in missing)
    groups = Counter(case.surface.n for case in {group_key(case): case
                                                 for case in missing}.values())
    lines = [f"{'N':>5} {'runs':>5} {'cached':>7} {'to run':>7} {'groups':>7}"]
    for n in sorted(runs):
        lines.append(f"{n:>5} {runs[n]:>5} {runs[n] - to_run[n]:>7} {to_run[n]:>7} "
                     f"{groups[n]:>7}")
    lines.append(f"{'all':>5} {len(distinct):>5} {len(distinct) - len(missing):>7} "
                 f"{len(missing):>7} {sum(groups.values()):>7}   (cache: {directory})")
    return lines


def summary_columns(run) -> dict:
    """The columns every benchmark table takes from a results file.

    Parameters
    ----------
    run : studies.post.RunFile or None
        The run (None: it did not start).

    Returns
    -------
    dict
        :data:`SUMMARY_COLUMNS` from the run's summary (None where absent), ``message``,
        ``note`` (:attr:`studies.post.RunFile.note`), ``wall_s`` (total wall time [s]),
        ``peak_memory_gb`` (summed over ranks [GB]), ``ranks`` and ``physics`` (the stamp of
        the physics that computed it, :func:`run_physics`).
    """
    if run is None:
        return {**dict.fromkeys(SUMMARY_COLUMNS), "converged": False, "message": "",
                "note": "", "wall_s": None, "peak_memory_gb": None, "ranks": None,
                "physics": None}
    columns = {key: run.summary.get(key) for key in SUMMARY_COLUMNS}
    columns["converged"] = run.converged
    columns.update(message=run.message, note=run.note, wall_s=run.timings.get("total_s"),
                   peak_memory_gb=run.sizes.get("peak_memory_gb"), ranks=run.sizes.get("ranks"),
                   physics=run_physics(run.path))
    return columns


def run_physics(path: Path) -> str:
    """The short physics version (``studies.physics.physics_stamp``) of the code that wrote the
    results file at ``path`` ("" for a file older than the record)."""
    from roughfriction.studies.physics import physics_stamp
    from roughfriction.studies.results_file import stored_run

    return physics_stamp(stored_run(path).physics)
