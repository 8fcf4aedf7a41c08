"""Figure registry and output: each ``scripts/figNN.py`` declares what it needs and draws it.

A theory figure module defines ``make() -> (matplotlib Figure, dict of equal-length columns)``.
A FEM figure module also defines ``fem_cases(n) -> list of FemCase`` (the runs it needs on an
n x n FEM grid) and draws with ``make(runs)``, ``runs`` being the runs' results files
(:class:`studies.post.RunFile`) in the order of its cases; the runs come from the run cache
(``studies.cache``, computed on every MPI rank when missing, after one stderr line saying how
many), and only rank 0 draws. Every PNG has :data:`PNG_DPI` pixels per inch.
``make_figure`` writes ``figures/figNN.png`` and the data behind it, ``figures/figNN.csv``,
each atomically (a killed run never leaves a half-written file under the final name).
"""

from __future__ import annotations

import csv
import importlib
from pathlib import Path

import numpy as np
from roughfriction.files import atomic_write

#: Figures from the surfaces and the theory alone.
THEORY_FIGURES = ("fig3", "fig4", "fig5", "fig6", "fig12", "fig13", "fig17", "fig18", "fig19")
#: Figures that need FEM runs (fig14: theory with FEM points).
FEM_FIGURES = ("fig8", "fig9", "fig10", "fig14", "fig15", "fig20", "fig21", "fig22", "fig23",
               "fig24", "fig25", "fig26", "fig27", "fig28", "fig29")
FIGURES = tuple(sorted(THEORY_FIGURES + FEM_FIGURES, key=lambda name: int(name[3:])))
FIGURE_DIR = Path("figures")
#: Resolution of every PNG [pixels per inch]: a 5 x 3.6 in figure is 1000 x 720 px, sharp at
#: README width on a high-density screen.
PNG_DPI = 200


def pyplot():
    """matplotlib.pyplot on the Agg backend (files only, no display) in the figures' style."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 10, "axes.grid": True, "grid.alpha": 0.3})
    return plt


def new_axes(width: float = 5.0, height: float = 3.6, ncols: int = 1):
    """A figure ``width`` x ``height`` [in] with one axes (or a row of ``ncols``), sized to read
    well at README width."""
    return pyplot().subplots(1, ncols, figsize=(width, height), constrained_layout=True)


def figure_module(name: str):
    """The module of figure ``name`` (``figNN``)."""
    return importlib.import_module(f"roughfriction.scripts.{name}")


def write_table(path: Path, columns: dict[str, np.ndarray]) -> None:
    """Write equal-length columns as CSV; the header names carry the units."""
    arrays = [np.asarray(v) for v in columns.values()]
    if len({a.shape for a in arrays}) != 1 or arrays[0].ndim != 1:
        raise ValueError(f"{path.name}: columns must be 1-D and of equal length")
    rows = zip(*arrays, strict=True)
    lines = [",".join(columns)]
    lines += [",".join(f"{v:.10g}" if isinstance(v, float | np.floating) else str(v) for v in r)
              for r in rows]
    atomic_write(path, lambda tmp: Path(tmp).write_text("\n".join(lines) + "\n"))


def read_table(path: Path) -> dict[str, np.ndarray]:
    """A CSV of :func:`write_table` as columns (numbers as float arrays, text as str arrays)."""
    with open(path, newline="") as file:
        rows = list(csv.DictReader(file))
    columns = {}
    for key in rows[0] if rows else []:
        values = [row[key] for row in rows]
        try:
            columns[key] = np.array([float(v) for v in values])
        except ValueError:
            columns[key] = np.array(values)
    return columns


def fem_runs(module, n: int | None = None, runs_directory=None) -> list | None:
    """The results files of the FEM runs a figure module declares, from the run cache
    (computing the missing ones on every rank, announced first by :func:`announce_runs`); None
    on ranks other than 0.

    Parameters
    ----------
    module : module
        A FEM figure module (defines ``fem_cases(n)``).
    n : int, optional
        Surface cells per side (default :func:`scripts.cases.fem_resolution`).
    runs_directory : str or pathlib.Path, optional
        The run cache (default :func:`studies.cache.runs_directory`).
    """
    from mpi4py import MPI
    from roughfriction.studies.cache import cached_results
    from roughfriction.studies.paper import fem_resolution
    from roughfriction.studies.post import read_run

    comm = MPI.COMM_WORLD
    cases = module.fem_cases(fem_resolution(n))
    if comm.rank == 0:
        announce_runs(module.__name__.rpartition(".")[2], cases, runs_directory)
    paths = cached_results(cases, comm, directory=runs_directory)
    return [read_run(path) for path in paths] if comm.rank == 0 else None


def runs_to_compute(label: str, cases, runs_directory=None) -> str:
    """One line saying what the run cache lacks for ``cases`` (repeats counted once): how many
    FEM runs ``label`` needs, on which grids N, how many are cached and how many will be
    computed; "" when every run is cached.

    Parameters
    ----------
    label : str
        Who needs them (``fig20``).
    cases : sequence of FemCase
        The runs needed.
    runs_directory : str or pathlib.Path, optional
        The run cache (default :func:`studies.cache.runs_directory`).
    """
    from roughfriction.studies import cache

    directory = cache.runs_directory(runs_directory)
    physics = cache.physics_version()
    unique = {cache.run_key(case, physics): case for case in cases}.values()
    cached = sum(cache.finished_entry(directory, case, physics) is not None for case in unique)
    if cached == len(unique):
        return ""
    grids = " and ".join(str(n) for n in sorted({case.surface.n for case in unique}))
    return (f"{label}: {len(unique)} FEM runs needed (N = {grids}), {cached} in the run cache "
            f"{directory}, computing {len(unique) - cached} now (progress follows per step)")


def announce_runs(label: str, cases, runs_directory=None) -> None:
    """Print :func:`runs_to_compute` on stderr unless every run is cached (call on rank 0)."""
    from roughfriction.studies.cache import stderr_line

    line = runs_to_compute(label, cases, runs_directory)
    if line:
        stderr_line(line)


def sliding_key(case, physics: str) -> str:
    """The run-cache key of ``case`` as a sliding run (a normal-only case is answered by it)."""
    from dataclasses import replace

    from roughfriction.case import Loading
    from roughfriction.studies.cache import run_key

    return run_key(replace(case, loading=Loading(case.loading.load_star)), physics)


def needed_cases(cases, sliding: set[str], physics: str) -> list:
    """``cases`` without the normal-only ones whose sliding run (:func:`sliding_key`) is among
    the ``sliding`` keys."""
    return [case for case in cases
            if not (case.loading.normal_only and sliding_key(case, physics) in sliding)]


def sliding_keys(cases, physics: str) -> set[str]:
    """The :func:`sliding_key` of every sliding case of ``cases``."""
    return {sliding_key(case, physics) for case in cases if not case.loading.normal_only}


def compute_fem_runs(n: int | None = None, runs_directory=None) -> int:
    """Compute, in one batch, every FEM run that the FEM figures declare: the loads of one
    surface then share one normal loading path (figure by figure they would each repeat it).
    A normal-only case whose sliding run is also declared is answered by that run. Call on
    every rank; returns the number of cases declared."""
    from mpi4py import MPI
    from roughfriction.studies.cache import cached_results, physics_version
    from roughfriction.studies.paper import fem_resolution

    cases = [case for name in FEM_FIGURES
             for case in figure_module(name).fem_cases(fem_resolution(n))]
    physics = physics_version()
    needed = needed_cases(cases, sliding_keys(cases, physics), physics)
    if MPI.COMM_WORLD.rank == 0:
        announce_runs("figure runs", needed, runs_directory)
    cached_results(needed, MPI.COMM_WORLD, directory=runs_directory)
    return len(cases)


def export_summaries(n: int | None = None, runs_directory=None, summaries=None) -> dict:
    """Write the committed run summary (``studies.run_summary``) of every finished run the FEM
    figures declare on ``n`` cells per side, from the run cache, into ``summaries`` (default
    :func:`studies.run_summary.summaries_directory`); the counts written and missing."""
    from roughfriction.studies import cache
    from roughfriction.studies.paper import fem_resolution
    from roughfriction.studies.post import read_run
    from roughfriction.studies.run_summary import (
        summaries_directory,
        summary_record,
        write_summary,
    )

    cases = [case for name in FEM_FIGURES
             for case in figure_module(name).fem_cases(fem_resolution(n))]
    physics, directory = cache.physics_version(), cache.runs_directory(runs_directory)
    unique = {cache.run_key(case, physics): case for case in cases}
    written = 0
    for key, case in unique.items():
        path = cache.entry_path(directory, case, physics)
        if path.is_file():
            write_summary(summaries_directory(summaries),
                          summary_record(read_run(path), key, physics))
            written += 1
    return {"summaries_written": written, "runs_missing": len(unique) - written}


def save_png(fig, path: Path) -> Path:
    """Write ``fig`` as a PNG of :data:`PNG_DPI` at ``path`` atomically and close it; return
    ``path``."""
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=PNG_DPI, format="png"))
    pyplot().close(fig)
    return path


def label_preview(fig, n: int) -> None:
    """Write :func:`studies.paper.preview_note` at the foot of a FEM figure on ``n`` cells per
    side (nothing on the paper's grid)."""
    from roughfriction.studies.paper import preview_note

    note = preview_note(n)
    if note:
        fig.text(0.01, 0.004, note, fontsize=6, color="0.35", ha="left", va="bottom")


def make_figure(name: str, directory: Path = FIGURE_DIR, n: int | None = None,
                runs_directory=None) -> Path:
    """Draw figure ``name`` and write its PNG and CSV into ``directory``; return the PNG path.

    FEM figures use the FEM grid ``n`` and the run cache ``runs_directory`` (see
    :func:`fem_runs`); under MPI only rank 0 draws and writes.
    """
    module = figure_module(name)
    png = Path(directory) / f"{name}.png"
    if hasattr(module, "fem_cases"):
        runs = fem_runs(module, n, runs_directory)
        if runs is None:
            return png
        fig, columns = module.make(runs)
        label_preview(fig, runs[0].n)
    else:
        fig, columns = module.make()
    save_png(fig, png)
    write_table(Path(directory) / f"{name}.csv", columns)
    return png
