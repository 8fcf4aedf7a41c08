"""Run cache: every FEM run is computed once and kept as ``results/runs/<key>.h5``.

The key is the SHA-256 of everything that determines a run: the case (``FemCase.inputs()``:
surface digest, loading, material, mesh and solver options), the *physics version* (the SHA-256
of the code of the modules that compute results, without comments and docstrings: editing the
documentation keeps the runs, editing a statement or a constant discards them) and the entry
format. The number of MPI
ranks is not part of it: runs agree to 1e-6 across rank counts (``tests/test_solver_mpi.py``).

An entry is finished when its file exists under its final name. Entries are written by
:func:`studies.results_file.save_run` (temporary file, then rename), each as soon as its run
ends, so a killed batch loses at most the run in progress and a half-written file is never read as a
result. Unconverged runs are entries too (a rerun would repeat them); delete the file to retry.
A run that fails on a normal path shared with smaller loads is run once more on its own path
(:func:`_compute_alone`); if that converges, its entry is the standalone run, with a ``note``
attribute that says so (``roughfriction post``, the runs table and the stress matrix show it).
A group of runs that cannot start (an :class:`~roughfriction.errors.InputError` on every rank,
e.g. an inverted mesh) does not stop the others: :class:`RunsNotStarted` names it at the end.

A normal-only case is also answered by the finished sliding run of the same case: its preload is
the same computation (read it with :func:`studies.post.preload_state`).

    roughfriction runs G5 --load 0.155 0.62 --n 16     # fill the cache, print the paths

Imports without dolfinx; the FEM stack is imported when a run is computed.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from roughfriction.case import FemCase, Loading
from roughfriction.errors import InputError
from roughfriction.solver.results import StepRecord
from roughfriction.studies.physics import (  # noqa: F401  (the cache's keys, re-exported)
    OUTPUT_IMPORTS,
    PHYSICS_MODULES,
    SOLVER_OUTPUT_MODULES,
    code_without_documentation,
    physics_sources,
    physics_version,
)
from roughfriction.studies.results_file import FILE_FORMAT, save_run

#: Environment variable naming the cache directory (default ``results/runs``).
RUNS_VARIABLE = "ROUGHFRICTION_RUNS"
DEFAULT_RUNS = Path("results/runs")
#: Layout version of an entry: that of the results file, whose writer
#: (:mod:`studies.results_file`) is not physics.
ENTRY_FORMAT = FILE_FORMAT

# --- keys ------------------------------------------------------------------------------------


def _digest(record: dict) -> str:
    return hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest()


def run_key(case: FemCase, physics: str) -> str:
    """The cache key of one run: SHA-256 of the case's inputs, the physics version and the
    entry format (hex, 64 characters)."""
    return _digest({"format": ENTRY_FORMAT, "physics": physics, "inputs": case.inputs()})


def group_key(case: FemCase) -> str:
    """What runs sharing everything but the load have in common (surface, material, mesh,
    solver, normal_only)."""
    inputs = case.inputs()
    del inputs["loading"]["load_star"]
    return _digest(inputs)


def runs_directory(directory=None) -> Path:
    """The cache directory: ``directory``, else ``$ROUGHFRICTION_RUNS``, else results/runs."""
    return Path(directory or os.environ.get(RUNS_VARIABLE) or DEFAULT_RUNS)


def entry_path(directory: Path, case: FemCase, physics: str) -> Path:
    """Where the entry of ``case`` lives (finished or not)."""
    return Path(directory) / f"{run_key(case, physics)}.h5"


def finished_entry(directory: Path, case: FemCase, physics: str,
                   summaries: Path | None = None) -> Path | None:
    """The finished entry answering ``case``, or None.

    Its own entry, else its committed run summary (``studies.run_summary``, in ``summaries``,
    default ``run_summary.summaries_directory()``); for a normal-only case, else those of the
    sliding run of the same case.
    """
    from roughfriction.studies.run_summary import summary_file

    candidates = [case]
    if case.loading.normal_only:
        candidates.append(replace(case, loading=Loading(case.loading.load_star)))
    for candidate in candidates:
        for path in (entry_path(directory, candidate, physics),
                     summary_file(run_key(candidate, physics), summaries)):
            if path.is_file():
                return path
    return None


# --- planning --------------------------------------------------------------------------------


@dataclass(frozen=True)
class RunGroup:
    """Missing runs that differ only in the load: one ``run_loads`` call.

    Attributes
    ----------
    cases : tuple of FemCase
        One per load, ascending F*.
    paths : tuple of pathlib.Path
        Their entries.
    """

    cases: tuple
    paths: tuple

    @property
    def loads(self) -> list[float]:
        """F* of the runs [-]."""
        return [case.loading.load_star for case in self.cases]


def plan_runs(cases: Sequence[FemCase], found: Sequence[Path | None], directory: Path,
              physics: str) -> list[RunGroup]:
    """Group the cases without a finished entry (``found[i] is None``) by everything but the
    load, each run once, loads ascending; groups in order of first appearance."""
    groups: dict[str, dict[str, FemCase]] = {}
    for case, path in zip(cases, found, strict=True):
        if path is None:
            groups.setdefault(group_key(case), {})[run_key(case, physics)] = case
    planned = []
    for members in groups.values():
        ordered = tuple(sorted(members.values(), key=lambda case: case.loading.load_star))
        planned.append(RunGroup(ordered, tuple(entry_path(directory, case, physics)
                                               for case in ordered)))
    return planned


# --- progress --------------------------------------------------------------------------------


def run_label(case: FemCase) -> str:
    """``G5 N=32 F*=0.155`` (``normal`` appended for a normal-only run)."""
    label = f"{case.surface.name or 'surface'} N={case.surface.n} F*={case.loading.load_star:g}"
    return label + (" normal" if case.loading.normal_only else "")


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


class RunReporter:
    """Progress of a batch of runs, as text lines (rank 0 prints them to stderr).

    A line per step of the run in progress (run, step, phase, F_t/F_n, Newton iterations),
    a line per finished run with an overall progress bar and the estimated time left (mean wall
    time of the runs so far times the runs left), and a table of all runs at the end.

    Parameters
    ----------
    total : int
        Runs to compute [-].
    write : callable
        Receives each line.
    """

    BAR = 20

    def __init__(self, total: int, write: Callable[[str], None]):
        self.total, self.write = total, write
        self.done = 0
        self.label = ""
        self.steps = self.iterations = 0
        self.started = time.perf_counter()

    def begin(self, case: FemCase) -> None:
        """The next run starts."""
        self.label, self.steps, self.iterations = run_label(case), 0, 0

    def again(self, case: FemCase, why: str) -> None:
        """A finished run starts over (it counts once in the progress bar)."""
        self.done -= 1
        self.begin(case)
        self.write(f"{self.prefix}: {why}")

    @property
    def prefix(self) -> str:
        return f"[{self.done + 1}/{self.total}] {self.label}"

    def step(self, record) -> None:
        """A progress record of the FEM run (``progress`` of :func:`solver.run.run_loads`):
        a step record or another event, shown as its text."""
        if not isinstance(record, StepRecord):
            self.write(f"{self.prefix}: {str(record).strip()}")
            return
        self.steps += 1
        self.iterations += record.newton_iterations + record.cut_iterations
        ratio = (record.tangential_force / record.normal_force if record.normal_force
                 else float("nan"))
        self.write(f"{self.prefix}: step {self.steps} {record.phase} Ft/Fn={ratio:.4f} "
                   f"newton {record.newton_iterations} ({self.iterations} in run)")

    def not_started(self, cases: Sequence[FemCase], why: str) -> None:
        """The runs of a group could not start (``why``: the one-line error); they count as
        done."""
        for case in cases:
            self.done += 1
            self.write(f"[{self.done}/{self.total}] {run_label(case)}: could not start: {why}")

    def finished(self, summary: dict) -> None:
        """A run ended with this summary (``FemResult.summary()``)."""
        self.done += 1
        elapsed = time.perf_counter() - self.started
        left = elapsed / self.done * (self.total - self.done)
        filled = round(self.BAR * self.done / max(self.total, 1))
        mu_s = summary.get("mu_s")
        outcome = "converged" if summary.get("converged") else "NOT converged"
        self.write(f"[{self.done}/{self.total}] {self.label}: {outcome}, "
                   f"{summary.get('steps')} steps, {summary.get('newton_iterations')} its, "
                   + (f"mu_s={mu_s:.4f}, " if mu_s is not None else "")
                   + f"{_minutes(summary.get('wall_s') or 0.0)} |{'#' * filled}"
                   f"{'.' * (self.BAR - filled)}| {self.done}/{self.total} runs, "
                   f"{_minutes(elapsed)} elapsed, ~{_minutes(left)} left")


def runs_table(rows: Sequence[dict]) -> list[str]:
    """The end-of-batch table: one line per run (surface, N, F*, wall time, converged, mu_s,
    whether it was computed now or read from the cache)."""
    header = f"{'surface':<10} {'N':>4} {'F*':>7} {'kind':<8} {'wall_s':>8} {'converged':<9} " \
             f"{'mu_s':>8}  source"
    lines = [header]
    for row in rows:
        mu_s = row["mu_s"]
        lines.append(f"{row['surface']:<10} {row['n']:>4} {row['load_star']:>7g} "
                     f"{'normal' if row['normal_only'] else 'sliding':<8} "
                     f"{row['wall_s'] or 0.0:>8.1f} {row['converged']!s:<9} "
                     f"{'-' if mu_s is None else f'{mu_s:.4f}':>8}  {row['source']}")
    return lines


def _table_rows(cases, paths, computed, not_started) -> list[dict]:
    from roughfriction.studies.post import read_run

    rows = []
    for case, path in zip(cases, paths, strict=True):
        row = {"surface": case.surface.name, "n": case.surface.n,
               "load_star": case.loading.load_star, "normal_only": case.loading.normal_only}
        if path in not_started:
            rows.append(row | {"wall_s": None, "converged": False, "mu_s": None,
                               "source": "could not start"})
            continue
        entry = read_run(path)
        source = "computed" if path in computed else "cache"
        if entry.note:
            source += " (alone: shared path failed)"
        if entry.inputs["loading"]["normal_only"] != case.loading.normal_only:
            source += " (its sliding run)"
        rows.append(row | {"wall_s": entry.summary["wall_s"], "converged": entry.converged,
                           "mu_s": entry.summary["mu_s"], "source": source})
    return rows


def stderr_line(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


# --- the cache -------------------------------------------------------------------------------


def cached_results(cases: Sequence[FemCase], comm=None, progress=None,
                   directory=None) -> list[Path]:
    """The results file of every case, computing (on all ranks of ``comm``) those missing.

    Missing runs are grouped by everything but the load, and each group is one
    :func:`solver.run.run_loads` call; each run's entry is written (by rank 0) as soon as it
    ends.

    Parameters
    ----------
    cases : sequence of FemCase
        What is needed (repeats allowed).
    comm : mpi4py.MPI.Comm, optional
        Communicator of the runs (default COMM_WORLD); call on every rank.
    progress : callable, optional
        Receives the progress lines and the final table (rank 0 only); default stderr.
    directory : str or pathlib.Path, optional
        The cache (default :func:`runs_directory`).

    Returns
    -------
    list of pathlib.Path
        One finished entry per case, in order (for a normal-only case possibly the sliding
        run of the same case).
    """
    from mpi4py import MPI

    comm = MPI.COMM_WORLD if comm is None else comm
    directory = runs_directory(directory)
    physics = physics_version()
    found = None
    if comm.rank == 0:
        found = [finished_entry(directory, case, physics) for case in cases]
    found = comm.bcast(found, root=0)
    groups = plan_runs(cases, found, directory, physics)
    write = (progress or stderr_line) if comm.rank == 0 else (lambda line: None)
    reporter = RunReporter(sum(len(group.cases) for group in groups), write)
    computed, not_started = set(), {}
    for group in groups:
        try:
            _compute_group(group, comm, reporter)
        except InputError as error:  # raised on every rank: the other groups still run
            unwritten = comm.bcast([index for index, path in enumerate(group.paths)
                                    if not path.exists()] if comm.rank == 0 else None,
                                   root=0)
            reporter.not_started([group.cases[index] for index in unwritten], str(error))
            not_started.update({group.paths[index]: str(error) for index in unwritten})
        computed.update(group.paths)
    paths = [path or entry_path(directory, case, physics)
             for case, path in zip(cases, found, strict=True)]
    if comm.rank == 0 and paths:
        for line in runs_table(_table_rows(cases, paths, computed, not_started)):
            write(line)
    if not_started:
        raise RunsNotStarted(cases, paths, not_started)
    return paths


class RunsNotStarted(InputError):
    """Runs of :func:`cached_results` that could not start (an inverted mesh, say), raised
    after every other run has finished.

    Attributes
    ----------
    paths : list of pathlib.Path
        The entry of every case, in order (the missing ones are not written).
    reasons : dict
        Entry path of a run that did not start -> its one-line error.
    """

    def __init__(self, cases: Sequence[FemCase], paths: list[Path], reasons: dict[Path, str]):
        self.paths, self.reasons = paths, reasons
        failed = {run_label(case): reasons[path] for case, path in zip(cases, paths, strict=True)
                  if path in reasons}
        super().__init__(f"{len(failed)} run(s) could not start, the others finished: "
                         + "; ".join(f"{label}: {why}" for label, why in failed.items()))


class CpuShare:
    """CPU time of this process over wall time since the last reading, least over the ranks
    [-]: about 1 on a quiet machine with a core per rank (a waiting MPI rank polls), less when
    other work took the cores, and then the run's wall times overstate its cost. Recorded as
    ``cpu_share`` in each run's summary; the benchmarks flag runs below
    ``QUIET_CPU_SHARE`` (``benchmarks/batch.py``)."""

    def __init__(self, comm):
        self.comm = comm
        self.restart()

    def restart(self) -> None:
        self.cpu_s, self.wall_s = time.process_time(), time.perf_counter()

    def take(self) -> float:
        """The share since the last reading (collective: call on every rank)."""
        share = (time.process_time() - self.cpu_s) / max(time.perf_counter() - self.wall_s,
                                                          1e-9)
        self.restart()
        return min(self.comm.allgather(share))


def _compute_group(group: RunGroup, comm, reporter: RunReporter) -> None:
    """Run one group, writing each entry as soon as its run ends; then free its PETSc objects
    (:func:`release`). A run past the first that failed on the shared normal path
    is run again alone (:func:`_compute_alone`)."""
    from roughfriction.solver.run import run_loads

    cpu = CpuShare(comm)

    def finished(index, fem_run):
        save_run(group.paths[index], group.cases[index], fem_run, comm,
                 extra={"cpu_share": cpu.take()})
        reporter.finished(fem_run.result.summary())
        if index + 1 < len(group.cases):
            reporter.begin(group.cases[index + 1])

    reporter.begin(group.cases[0])
    runs = run_loads(group.cases[0], group.loads, comm, reporter.step, finished=finished)
    failed = [(index, run.result.message) for index, run in enumerate(runs)
              if index > 0 and not run.result.converged]
    release(runs)
    for index, message in failed:
        _compute_alone(group.cases[index], group.paths[index], message, comm, reporter)


def _compute_alone(case: FemCase, path: Path, message: str, comm,
                   reporter: RunReporter) -> None:
    """Run ``case`` on its own normal path after it failed on a shared one (``message``: why),
    and keep that run, noted as such, if it converges (else the shared run's entry stays).

    A shared path reaches a load through the preload steps of the smaller loads, a standalone
    path through its own: the states differ at step level (plastic path dependence), so a
    stick/slip cycle that stalls one may not arise on the other.
    """
    from roughfriction.solver.run import run_loads

    note = f"computed alone: on the shared normal path it failed ({message})"
    cpu = CpuShare(comm)

    def finished(index, fem_run):
        share = cpu.take()
        if fem_run.result.converged:
            save_run(path, case, fem_run, comm, note=note, extra={"cpu_share": share})
        reporter.finished(fem_run.result.summary())

    reporter.again(case, "shared normal path failed; running it alone")
    release(run_loads(case, [case.loading.load_star], comm, reporter.step, finished=finished))


def release(runs) -> None:
    """Free the PETSc objects of the model the runs of one :func:`solver.run.run_loads` call
    share (collectively, on every rank), once their entries are written."""
    if runs:
        runs[0].equilibrium.destroy()
