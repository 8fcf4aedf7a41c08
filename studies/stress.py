"""Stress matrix of the FEM (``make stress``): where it converges, how, and where it is reliable.

    mpirun -n 2 roughfriction bench stress --n 32
    roughfriction bench stress --plan --n 32     # the runs, without computing them

Runs (tables below), every one a :class:`~roughfriction.case.FemCase` through the run cache on an
N x N grid: G1–G9 at the loads of :data:`MATRIX_LOADS` (one group per surface: its loads share
one normal loading path; G1 at F* = 1.86 is near-complete contact); the measured surface
:data:`MEASURED_SURFACE` resampled to the grid, at the same loads; and G5 at
:data:`OPTION_LOADS` with the contact penalty times :data:`PENALTY_FACTORS` and the first
tangential step (``first_slide``) times :data:`STEP_FACTORS`.

Each run is classified (:func:`classify`):

* converged directly: no step was cut;
* converged after step cutting: ``cut_steps`` > 0 (failed attempts before accepted steps);
* converged alone: failed on the normal path shared with the smaller loads of its surface and
  converged when run again on its own path (the run cache's retry; the entry's ``note``);
* failed loudly: not converged, with a message saying where and why (also a run refused before
  solving, e.g. an inverted mesh);
* SILENT FAILURE: anything else: a mu_s from a run that is not converged, whose last step is
  not sliding inception (every contact node slipping) or whose F_n is off its target; a
  converged sliding run without mu_s; a failure without a message. The command exits 1 if
  there is one.

Reliability: at least :data:`~solver.results.RELIABLE_CELLS_PER_PATCH` grid cells of contact
area per contact patch (the paper's 4 contact nodes per patch), at inception (else at the end of
the preload), as the run summary's ``cells_per_patch`` and ``reliable``.

Output (rank 0): ``results/bench/stress.csv`` (a row per run) and ``results/bench/stress.md``
(README-ready tables: the matrix, the outcome counts, the penalty and step-size table, the
failures with their messages and the reliable region).
"""

from __future__ import annotations

import math
import os
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from roughfriction.case import FemCase, Loading
from roughfriction.errors import InputError
from roughfriction.geometry.surface import Surface
from roughfriction.solver.results import RELIABLE_CELLS_PER_PATCH
from roughfriction.studies.batch import (
    compute_batch,
    csv_text,
    summary_columns,
    write_text,
)

# --- what is run -----------------------------------------------------------------------------

#: Surfaces of the matrix (built-in names).
MATRIX_SURFACES = tuple(f"G{k}" for k in range(1, 10))
#: Loads F* of the matrix [-].
MATRIX_LOADS = (0.01, 0.155, 0.62, 1.86)
#: Measured surface (path under data/surfaces), run at MATRIX_LOADS: ST400 test3, by Sdq the
#: least steep of the four ST400 files (test3 0.47, test1 0.69, test2 0.79, test4 0.80).
MEASURED_SURFACE = "nanovea_st400/test3.txt"
#: Surface and loads F* [-] of the option variants.
OPTION_SURFACE, OPTION_LOADS = "G5", (0.01, 0.155)
#: Contact penalty factors against the default (run as kind "default" on the same surface).
PENALTY_FACTORS = (0.01, 0.1, 10.0, 100.0)
#: First tangential step (first_slide) factors against the default.
STEP_FACTORS = (0.25, 0.5, 2.0, 4.0)
#: Option varied by each kind of option run.
OPTIONS = {"penalty": "penalty", "step": "first_slide"}

#: Environment variable naming another surface data directory (default <repo>/data/surfaces).
DATA_VARIABLE = "ROUGHFRICTION_SURFACE_DATA"

#: Outcomes, in table order.
DIRECT, CUT, ALONE, FAILED, SILENT = ("converged directly", "converged after step cutting",
                                      "converged alone", "failed loudly", "SILENT FAILURE")
OUTCOMES = (DIRECT, CUT, ALONE, FAILED, SILENT)
#: Largest relative deviation of F_n at inception from its target [-] (the Newton residual
#: tolerance is 1e-6 F_n by default).
FORCE_TOLERANCE = 1e-4


@dataclass(frozen=True)
class StressRun:
    """One run of the stress test.

    Attributes
    ----------
    kind : str
        "matrix", "measured", "default" (the option runs' surface with the default options),
        "penalty" or "step".
    surface : str
        The surface's label.
    load_star : float
        F* [-].
    factor : float
        The option's value over its default (1 for matrix and measured runs) [-].
    case : FemCase or None
        What is run; None if the case could not be set up.
    error : str
        Why not (a missing file...), "" otherwise.
    """

    kind: str
    surface: str
    load_star: float
    factor: float = 1.0
    case: FemCase | None = None
    error: str = ""


def surface_data_directory() -> Path:
    """The measured surfaces: $ROUGHFRICTION_SURFACE_DATA, else data/surfaces of the source
    tree (shipped with the repository)."""
    default = Path(__file__).resolve().parents[1] / "data" / "surfaces"
    return Path(os.environ.get(DATA_VARIABLE) or default)


def load_runs(kind: str, label: str, surface: Surface | None, loads: Sequence[float],
              error: str = "") -> list[StressRun]:
    """A run per load of one surface with the default options (``surface`` None: not set up,
    for ``error``)."""
    return [StressRun(kind, label, load, 1.0,
                      FemCase(surface, Loading(load)) if surface is not None else None, error)
            for load in loads]


def option_runs(kind: str, case: FemCase, loads: Sequence[float],
                factors: Sequence[float]) -> list[StressRun]:
    """``case`` at each load with the option of ``kind`` (:data:`OPTIONS`) times each factor."""
    option = OPTIONS[kind]
    default = getattr(case.solver, option)
    return [StressRun(kind, case.surface.name, load, factor,
                      replace(case, loading=Loading(load),
                              solver=replace(case.solver, **{option: factor * default})))
            for factor in factors for load in loads]


def measured_surface(n: int) -> tuple[Surface | None, str]:
    """:data:`MEASURED_SURFACE` on the n x n FEM grid (bicubic resampling), or None and why
    not."""
    from roughfriction.geometry.readers import read_surface
    from roughfriction.geometry.surface import surface_on_fem_grid

    path = surface_data_directory() / MEASURED_SURFACE
    try:
        return surface_on_fem_grid(read_surface(path), n), ""
    except InputError as error:
        return None, f"measured surface not available: {error}"


def default_runs(n: int) -> list[StressRun]:
    """The runs of the tables above on an n x n grid."""
    from roughfriction.geometry.generate import builtin_surface
    from roughfriction.geometry.surface import surface_on_fem_grid
    from roughfriction.studies.paper import fem_case

    runs = []
    for name in MATRIX_SURFACES:
        runs += load_runs("matrix", name, surface_on_fem_grid(builtin_surface(name), n),
                          MATRIX_LOADS)
    surface, error = measured_surface(n)
    label = "ST400 " + Path(MEASURED_SURFACE).stem
    runs += load_runs("measured", label, surface, MATRIX_LOADS, error)
    base = fem_case(OPTION_SURFACE, OPTION_LOADS[0], n)  # the figures' surface, not the matrix's
    runs += load_runs("default", base.surface.name, base.surface, OPTION_LOADS)
    runs += option_runs("penalty", base, OPTION_LOADS, PENALTY_FACTORS)
    runs += option_runs("step", base, OPTION_LOADS, STEP_FACTORS)
    return runs


# --- classification --------------------------------------------------------------------------


def run_facts(run) -> dict:
    """What the classification needs from a results file (:class:`studies.post.RunFile`).

    Returns
    -------
    dict
        :func:`studies.batch.summary_columns`, plus ``normal_only``, ``inception`` (the last
        sliding step has every contact node slipping, > 0 of them; None without a sliding
        step) and ``force_error`` (F_n of the last step over its target - 1 [-]; None without
        steps).
    """
    from roughfriction.studies.post import target_normal_force

    facts = summary_columns(run)
    steps = run.steps
    sliding = [k for k, phase in enumerate(steps["phase"]) if phase == "tangential"]
    last = sliding[-1] if sliding else None
    facts["normal_only"] = bool(run.inputs["loading"]["normal_only"])
    facts["inception"] = (None if last is None else
                          bool(steps["slipping_nodes"][last] == steps["contact_nodes"][last] > 0))
    facts["force_error"] = (float(steps["normal_force"][-1] / target_normal_force(run) - 1.0)
                            if len(steps["phase"]) else None)
    return facts


def silent_failure_problems(facts: dict) -> list[str]:
    """Why a run's report cannot be trusted though it did not fail loudly ([] if it can)."""
    mu_s, problems = facts.get("mu_s"), []
    if facts["converged"] and not facts.get("normal_only") and mu_s is None:
        problems.append("converged sliding run without mu_s")
    if not facts["converged"] and not (facts.get("message") or "").strip():
        problems.append("not converged, and no message says why")
    if mu_s is None:
        return problems
    if not facts["converged"]:
        problems.append("mu_s reported by an unconverged run")
    if not (math.isfinite(mu_s) and mu_s > 0):
        problems.append(f"mu_s = {mu_s} is not a positive number")
    if not facts.get("inception"):
        problems.append("mu_s reported before every contact node slips")
    force_error = facts.get("force_error")
    if force_error is None or abs(force_error) > FORCE_TOLERANCE:
        problems.append(f"F_n at inception off its target by {force_error}")
    return problems


def classify(facts: dict) -> tuple[str, list[str]]:
    """The outcome of a run (one of :data:`OUTCOMES`) and, for a silent failure, why."""
    problems = silent_failure_problems(facts)
    if problems:
        return SILENT, problems
    if not facts["converged"]:
        return FAILED, []
    if facts.get("note"):
        return ALONE, []
    return (CUT if facts.get("cut_steps") else DIRECT), []


def stress_row(run: StressRun, n: int, facts: dict | None, error: str = "") -> dict:
    """One row of the table: the run, its facts (None: it did not start, ``error`` says why),
    its outcome and reliability."""
    if facts is None:
        facts = {**summary_columns(None), "message": error or run.error}
    outcome, problems = classify(facts)
    return {"kind": run.kind, "surface": run.surface, "n": n, "load_star": run.load_star,
            "option": OPTIONS.get(run.kind, ""), "factor": run.factor, **facts,
            "outcome": outcome, "problems": "; ".join(problems)}


def add_changes(rows: Sequence[dict]) -> None:
    """``mu_s_change``: mu_s of each option run over that of the default run of its surface
    and load - 1 [-] (None where either is missing)."""
    baseline = {(row["surface"], row["load_star"]): row["mu_s"] for row in rows
                if row["kind"] == "default"}
    for row in rows:
        reference = baseline.get((row["surface"], row["load_star"]))
        row["mu_s_change"] = (row["mu_s"] / reference - 1.0
                              if row["kind"] in OPTIONS and row["mu_s"] is not None
                              and reference else None)


# --- tables ----------------------------------------------------------------------------------

COLUMNS = ("kind", "surface", "n", "load_star", "option", "factor", "outcome", "problems",
           "converged", "message", "note", "mu_s", "mu_s_change", "area_ratio_normal",
           "area_ratio_sliding", "junction_growth", "contact_nodes", "contact_patches",
           "nodes_per_patch", "cells_per_patch", "reliable", "steps", "cut_steps",
           "newton_iterations", "wall_s", "peak_memory_gb", "ranks")
UNRELIABLE_MARK = "†"


def cell_text(row: dict) -> str:
    """A table cell: mu_s (or the normal-load outcome), ``(k cuts)`` after step cutting,
    ``FAILED``, ``SILENT`` and † when unreliable."""
    if row["outcome"] == SILENT:
        return "**SILENT**"
    if row["outcome"] == FAILED:
        return "FAILED"
    text = f"{row['mu_s']:.3f}" if row["mu_s"] is not None else "converged"
    if row["kind"] in OPTIONS and row.get("mu_s_change") is not None:
        text += f" ({100 * row['mu_s_change']:+.1f} %)"
    if row["outcome"] == CUT:
        cuts = row["cut_steps"]
        text += f" ({cuts} cut{'s' if cuts != 1 else ''})"
    if row["outcome"] == ALONE:
        text += " (alone)"
    if row.get("reliable") is False:
        text += f" {UNRELIABLE_MARK}"
    return text


def markdown_table(header: Sequence[str], body: Sequence[Sequence[str]]) -> list[str]:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(cells) + " |" for cells in body]


def matrix_table(rows: Sequence[dict], loads: Sequence[float]) -> list[str]:
    """Surfaces down, loads across: the matrix and measured runs."""
    cells = {(row["surface"], row["load_star"]): row for row in rows
             if row["kind"] in ("matrix", "measured")}
    surfaces = list(dict.fromkeys(surface for surface, _ in cells))
    body = [[surface] + [cell_text(cells[surface, load]) if (surface, load) in cells else "–"
                         for load in loads] for surface in surfaces]
    return markdown_table(["surface"] + [f"F* = {load:g}" for load in loads], body)


def option_table(rows: Sequence[dict]) -> list[str]:
    """Option, factor down, loads across: the option runs beside their default run."""
    option_rows = [row for row in rows if row["kind"] in OPTIONS]
    loads = sorted({row["load_star"] for row in option_rows})
    surfaces = {row["surface"] for row in option_rows}
    baseline = {row["load_star"]: row for row in rows
                if row["kind"] == "default" and row["surface"] in surfaces}
    body = [["defaults", "x1"] + [cell_text(baseline[load]) if load in baseline else "–"
                                  for load in loads]]
    cells = {(row["option"], row["factor"], row["load_star"]): row for row in option_rows}
    for option, factor in dict.fromkeys((row["option"], row["factor"]) for row in option_rows):
        body.append([option, f"x{factor:g}"] + [cell_text(cells[option, factor, load])
                                               if (option, factor, load) in cells else "–"
                                               for load in loads])
    surface = ", ".join(sorted(surfaces))
    return markdown_table(["option", "factor"] + [f"{surface} F* = {load:g}" for load in loads],
                          body)


def outcome_counts(rows: Sequence[dict]) -> Counter:
    """Runs per outcome (every outcome present, 0 if none)."""
    counts = Counter({outcome: 0 for outcome in OUTCOMES})
    counts.update(row["outcome"] for row in rows)
    return counts


def run_name(row: dict) -> str:
    """``G5 F*=0.155`` (with ``penalty x100`` for an option run)."""
    name = f"{row['surface']} F*={row['load_star']:g}"
    return name + (f" {row['option']} x{row['factor']:g}" if row["kind"] in OPTIONS else "")


def reliable_region(rows: Sequence[dict], loads: Sequence[float]) -> list[str]:
    """Per load, the matrix and measured surfaces whose runs are reliable (converged, at least
    the contact area per patch of the paper's 4 contact nodes)."""
    lines = []
    for load in loads:
        at_load = [row for row in rows if row["kind"] in ("matrix", "measured")
                   and row["load_star"] == load]
        good = [row["surface"] for row in at_load if row["converged"] and row["reliable"]]
        lines.append(f"- F* = {load:g}: {len(good)} of {len(at_load)} reliable"
                     + (f" ({', '.join(good)})" if good else ""))
    return lines


def stress_markdown(rows: Sequence[dict], n: int, loads: Sequence[float]) -> str:
    """The README-ready section: matrix, counts, options, failures, reliable region."""
    counts = outcome_counts(rows)
    ranks = sorted({row["ranks"] for row in rows if row.get("ranks")})
    lines = [f"Stress runs on N = {n} grids ({', '.join(map(str, ranks)) or '?'} rank(s)). "
             "Cells: mu_s; (k cuts): converged after k step cuts; (alone): failed on the "
             "normal path shared with the smaller loads, converged on its own; FAILED: failed "
             "loudly "
             f"(reason below); {UNRELIABLE_MARK}: unreliable, fewer than "
             f"{RELIABLE_CELLS_PER_PATCH} grid cells of contact area per patch.", ""]
    lines += matrix_table(rows, loads) + [""]
    lines += ["Outcomes of all " + str(len(rows)) + " runs: "
              + ", ".join(f"{counts[outcome]} {outcome}" for outcome in OUTCOMES) + ".", ""]
    if any(row["kind"] in OPTIONS for row in rows):
        lines += ["Contact penalty and first tangential step against the defaults "
                  "(change of mu_s in brackets):", ""] + option_table(rows) + [""]
    failed = [row for row in rows if row["outcome"] in (FAILED, SILENT)]
    if failed:
        lines += ["Failures:", ""] + [f"- {run_name(row)}: {row['outcome']}: "
                                      f"{row['problems'] or row['message']}" for row in failed]
        lines.append("")
    lines += [f"Reliable region (converged, >= {RELIABLE_CELLS_PER_PATCH} grid cells of contact "
              "area per patch):", ""] + reliable_region(rows, loads)
    return "\n".join(lines) + "\n"


# --- command line ----------------------------------------------------------------------------


def run_stress(runs: Sequence[StressRun], n: int, loads: Sequence[float], output: Path, comm,
               runs_directory=None, progress=None) -> list[dict] | None:
    """Compute (every rank) and write (rank 0) the stress test; the rows on rank 0, else
    None."""
    from roughfriction.studies.post import read_run

    ready = [run for run in runs if run.case is not None]
    results = iter(compute_batch([run.case for run in ready], comm, runs_directory, progress))
    if comm.rank != 0:
        return None
    rows = []
    for run in runs:
        result = next(results) if run.case is not None else None
        if result is not None and result.path is not None:
            rows.append(stress_row(run, n, run_facts(read_run(result.path))))
        else:
            rows.append(stress_row(run, n, None, result.error if result else run.error))
    add_changes(rows)
    output.mkdir(parents=True, exist_ok=True)
    write_text(output / "stress.csv", csv_text(rows, COLUMNS))
    write_text(output / "stress.md", stress_markdown(rows, n, loads))
    counts = outcome_counts(rows)
    print("; ".join(f"{outcome}: {counts[outcome]}" for outcome in OUTCOMES), flush=True)
    print(f"wrote {output / 'stress.csv'} and {output / 'stress.md'}", flush=True)
    return rows
