"""Stress matrix of the FEM (``make stress``): where it converges, how, and where it is reliable.

    mpirun -n 2 python -m benchmarks stress --n 32
    python -m benchmarks stress --plan --n 32     # the runs, without computing them

Runs (tables below), every one a :class:`~roughfriction.case.FemCase` through the run cache on an
N x N grid: G1–G9 as the figures mesh them (an N x N window at their own spacing, psi 1.3 to
26) at the loads of :data:`MATRIX_LOADS` (one group per surface: its loads share one normal
loading path; F* = 1.86 and 2.5 are near-complete contact); the measured surface
:data:`MEASURED_SURFACE` resampled to the grid, at the same loads; G5 at :data:`OPTION_LOADS`
with each solver option of :data:`OPTIONS` (contact penalty, first tangential step, Newton
and penetration tolerances) times its :data:`OPTION_FACTORS`, and with the material extremes
of :data:`MATERIALS`; G5 at :data:`CHECK_LOAD` on each of :data:`RANK_COUNTS` ranks (each its
own ``mpirun ... -m benchmarks stress --rank-run``) and :data:`REPEATS` times on this
command's ranks, each of these in its own, initially empty, run cache
(:func:`check_directory`), so that it is computed, not looked up.

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

Agreement (:func:`agreement`): mu_s on 1, 2 and 4 ranks within :data:`RANK_TOLERANCE`, each run
on the ranks asked; the repeats within :data:`REPEAT_TOLERANCE`. The command exits 1 if not.

Reliability: at least :data:`~solver.results.RELIABLE_CELLS_PER_PATCH` grid cells of contact
area per contact patch (the paper's 4 contact nodes per patch), at inception (else at the end of
the preload), as the run summary's ``cells_per_patch`` and ``reliable``.

Output (rank 0): ``results/bench/stress.csv`` (a row per run) and ``results/bench/stress.md``
(README-ready tables: the code version, date and machine; the matrix with each surface's psi,
the outcome counts, the solver-option and material tables, the rank and repeat agreement, the
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
from roughfriction.material import Material
from roughfriction.solver.results import (
    RELIABLE_CELLS_PER_PATCH,
    SlipState,
    at_inception,
    plateau_change,
)
from roughfriction.studies.tables import csv_text, write_text

from benchmarks.batch import BatchResult, cached_batch, compute_batch, summary_columns

# --- what is run -----------------------------------------------------------------------------

#: Surfaces of the matrix (built-in names), each as the figures mesh it (an N x N window at
#: its own spacing, :func:`studies.paper.fem_surface`): psi 1.3 (G1) to 26 (G9).
MATRIX_SURFACES = tuple(f"G{k}" for k in range(1, 10))
#: Loads F* of the matrix [-].
MATRIX_LOADS = (0.01, 0.155, 0.62, 1.86, 2.5)
#: Measured surface (path under data/surfaces), run at MATRIX_LOADS: ST400 test3, by Sdq the
#: least steep of the four ST400 files (test3 0.47, test1 0.69, test2 0.79, test4 0.80).
MEASURED_SURFACE = "nanovea_st400/test3.txt"
#: Surface and loads F* [-] of the option, material, rank and repeat variants.
OPTION_SURFACE, OPTION_LOADS = "G5", (0.01, 0.155)
#: Contact penalty factors against the default (run as kind "default" on the same surface).
PENALTY_FACTORS = (0.01, 0.1, 10.0, 100.0)
#: First tangential step (first_slide) factors against the default.
STEP_FACTORS = (0.25, 0.5, 2.0, 4.0)
#: Factors of each solver tolerance (Newton residual and increment, contact penetration).
TOLERANCE_FACTORS = (0.01, 100.0)
#: Option varied by each kind of option run.
OPTIONS = {"penalty": "penalty", "step": "first_slide", "residual": "residual_tolerance",
           "increment": "increment_tolerance", "penetration": "penetration_tolerance"}
#: Factors of each kind of option run.
OPTION_FACTORS = {"penalty": PENALTY_FACTORS, "step": STEP_FACTORS,
                  "residual": TOLERANCE_FACTORS, "increment": TOLERANCE_FACTORS,
                  "penetration": TOLERANCE_FACTORS}
#: Material extremes against the paper's (E 200 GPa, nu 0.3, S_y 1 GPa, E_t 2 % of E), as
#: changed fields of :class:`~roughfriction.material.Material` [Pa, -]: nearly incompressible,
#: no hardening (E_t 1e-6 E, the smallest the model takes is > 0), very stiff and very soft
#: (E / S_y 2000 and 20, E_t 2 % of E).
MATERIALS = {"nu = 0.499": {"nu": 0.499}, "no hardening (E_t = 1e-6 E)": {"Et": 2e5},
             "very stiff (E = 2000 GPa)": {"E": 2e12}, "very soft (E = 20 GPa)": {"E": 2e10}}
#: Load F* [-] of the rank and repeat runs (on OPTION_SURFACE).
CHECK_LOAD = 0.155
#: MPI rank counts of the rank runs, each its own ``mpirun`` (``-m benchmarks stress --rank-run``).
RANK_COUNTS = (1, 2, 4)
#: Repeats of the check run on this command's ranks, each computed in an empty run cache.
REPEATS = 5
#: Largest relative difference of mu_s between rank counts [-] (tests/test_solver_mpi.py) and
#: between repeats on the same ranks [-] (round-off; a repeat should be bit-identical).
RANK_TOLERANCE, REPEAT_TOLERANCE = 1e-6, 1e-12
#: Run caches of the rank and repeat runs, under the output directory.
CHECK_RUNS = "stress_runs"

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
        an option of :data:`OPTIONS`, "material", "ranks" or "repeat".
    surface : str
        The surface's label.
    load_star : float
        F* [-].
    factor : float
        The option's value over its default (1 for the other kinds) [-].
    case : FemCase or None
        What is run; None if the case could not be set up.
    error : str
        Why not (a missing file...), "" otherwise.
    variant : str
        What a material, rank or repeat run changes ("nu = 0.499", "4 ranks", "repeat 3").
    ranks : int
        The rank count a "ranks" run is computed on (0: this command's).
    """

    kind: str
    surface: str
    load_star: float
    factor: float = 1.0
    case: FemCase | None = None
    error: str = ""
    variant: str = ""
    ranks: int = 0


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


def material_runs(case: FemCase, loads: Sequence[float], materials=None) -> list[StressRun]:
    """``case`` at each load with each material of ``materials`` (default :data:`MATERIALS`:
    label -> fields of :class:`~roughfriction.material.Material` that differ from the paper's;
    E_t and tau_c follow E and S_y unless given)."""
    runs = []
    for label, fields in (MATERIALS if materials is None else materials).items():
        material = Material(**fields)
        runs += [StressRun("material", case.surface.name, load, case=replace(
            case, loading=Loading(load), material=material), variant=label) for load in loads]
    return runs


def check_runs(case: FemCase, rank_counts: Sequence[int] = RANK_COUNTS,
               repeats: int = REPEATS) -> list[StressRun]:
    """``case`` once per rank count (kind "ranks") and ``repeats`` times on this command's
    ranks (kind "repeat"), each computed in its own run cache (:func:`check_directory`)."""
    label, load = case.surface.name, case.loading.load_star
    runs = [StressRun("ranks", label, load, case=case, variant=f"{count} rank"
                      + ("s" if count != 1 else ""), ranks=count) for count in rank_counts]
    return runs + [StressRun("repeat", label, load, case=case, variant=f"repeat {k}")
                   for k in range(1, repeats + 1)]


def check_directory(output: Path, run: StressRun) -> Path:
    """The run cache of a rank or repeat run: ``<output>/stress_runs/ranks<k>`` or
    ``.../repeat<k>`` (empty before ``make stress``, so the run is computed, not looked up)."""
    name = f"ranks{run.ranks}" if run.kind == "ranks" else run.variant.replace(" ", "")
    return Path(output) / CHECK_RUNS / name


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


def base_case(n: int) -> FemCase:
    """The option, material, rank and repeat runs' case: :data:`OPTION_SURFACE` as the figures
    mesh it, at :data:`CHECK_LOAD`."""
    from roughfriction.studies.paper import fem_case

    return fem_case(OPTION_SURFACE, CHECK_LOAD, n)


def default_runs(n: int) -> list[StressRun]:
    """The runs of the tables above on an n x n grid."""
    from roughfriction.studies.paper import fem_surface

    runs = []
    for name in MATRIX_SURFACES:
        runs += load_runs("matrix", name, fem_surface(name, n), MATRIX_LOADS)
    surface, error = measured_surface(n)
    label = "ST400 " + Path(MEASURED_SURFACE).stem
    runs += load_runs("measured", label, surface, MATRIX_LOADS, error)
    base = base_case(n)
    runs += load_runs("default", base.surface.name, base.surface, OPTION_LOADS)
    for kind, factors in OPTION_FACTORS.items():
        runs += option_runs(kind, base, OPTION_LOADS, factors)
    return runs + material_runs(base, OPTION_LOADS) + check_runs(base)


# --- classification --------------------------------------------------------------------------


def run_facts(run) -> dict:
    """What the classification needs from a results file (:class:`studies.post.RunFile`).

    Returns
    -------
    dict
        :func:`benchmarks.batch.summary_columns`, plus ``normal_only``, ``inception`` (the last
        sliding step is at inception, ``solver.results.at_inception``; None without a sliding
        step) and ``force_error`` (F_n of the last step over its target - 1 [-]; None without
        steps).
    """
    from roughfriction.studies.post import target_normal_force

    facts = summary_columns(run)
    steps = run.steps
    sliding = [k for k, phase in enumerate(steps["phase"]) if phase == "tangential"]
    last = sliding[-1] if sliding else None
    facts["normal_only"] = bool(run.inputs["loading"]["normal_only"])
    facts["inception"] = None if last is None else at_inception(
        recorded_slip_state(steps, sliding), run.inputs["solver"]["stuck_shear_tolerance"])
    facts["force_error"] = (float(steps["normal_force"][-1] / target_normal_force(run) - 1.0)
                            if len(steps["phase"]) else None)
    return facts


def recorded_slip_state(steps: dict, sliding: list[int]) -> SlipState:
    """The :class:`~roughfriction.solver.results.SlipState` of the last of the ``sliding``
    steps (indices into the results file's ``steps`` columns)."""
    last = sliding[-1]
    forces = [float(steps["tangential_force"][k]) for k in sliding]
    return SlipState(int(steps["slipping_nodes"][last]), int(steps["contact_nodes"][last]),
                     float(steps["stuck_shear_share"][last]), plateau_change(forces))


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


def surface_psi(case: FemCase | None) -> float | None:
    """Plasticity index psi of a run's surface and material [-] (Eq. 15); None without a
    case or for a surface that has none (no roughness)."""
    from roughfriction.geometry.statistics import surface_statistics

    try:
        return None if case is None else float(surface_statistics(case.surface,
                                                                  case.material).psi)
    except InputError:
        return None


def stress_row(run: StressRun, n: int, facts: dict | None, error: str = "") -> dict:
    """One row of the table: the run, its facts (None: it did not start, ``error`` says why),
    its outcome and reliability."""
    if facts is None:
        facts = {**summary_columns(None), "message": error or run.error}
    outcome, problems = classify(facts)
    return {"kind": run.kind, "surface": run.surface, "n": n, "load_star": run.load_star,
            "option": OPTIONS.get(run.kind, ""), "factor": run.factor, "variant": run.variant,
            "expected_ranks": run.ranks or None, "psi": surface_psi(run.case), **facts,
            "outcome": outcome, "problems": "; ".join(problems)}


def add_changes(rows: Sequence[dict]) -> None:
    """``mu_s_change``: mu_s of each option or material run over that of the default run of
    its surface and load - 1 [-] (None where either is missing)."""
    baseline = {(row["surface"], row["load_star"]): row["mu_s"] for row in rows
                if row["kind"] == "default"}
    for row in rows:
        reference = baseline.get((row["surface"], row["load_star"]))
        row["mu_s_change"] = (row["mu_s"] / reference - 1.0
                              if row["kind"] in VARIANT_KINDS and row["mu_s"] is not None
                              and reference else None)


# --- agreement of ranks and repeats ----------------------------------------------------------


@dataclass(frozen=True)
class Agreement:
    """How far mu_s of the runs of one kind ("ranks" or "repeat") lies apart.

    Attributes
    ----------
    kind : str
        "ranks" or "repeat".
    values : tuple of (str, float or None)
        (variant, mu_s) per run.
    spread : float or None
        Largest |mu_s - mu_s of the first run| over the first run's [-]; None if a run has
        no mu_s.
    tolerance : float
        Largest spread that counts as agreeing [-].
    problems : tuple of str
        Why the runs do not agree ([] if they do).
    """

    kind: str
    values: tuple
    spread: float | None
    tolerance: float
    problems: tuple

    @property
    def agrees(self) -> bool:
        """The runs all have mu_s, on the ranks asked, within the tolerance."""
        return not self.problems


def agreement(rows: Sequence[dict], kind: str) -> Agreement | None:
    """:class:`Agreement` of the ``kind`` runs ("ranks": :data:`RANK_TOLERANCE`, also that
    each ran on the ranks asked; "repeat": :data:`REPEAT_TOLERANCE`); None without such runs."""
    runs = [row for row in rows if row["kind"] == kind]
    if not runs:
        return None
    tolerance = RANK_TOLERANCE if kind == "ranks" else REPEAT_TOLERANCE
    values = tuple((row["variant"], row["mu_s"]) for row in runs)
    problems = [f"{row['variant']}: ran on {row['ranks']} rank(s)" for row in runs
                if row.get("expected_ranks") and row["ranks"] is not None
                and row["ranks"] != row["expected_ranks"]]
    missing = [variant for variant, mu_s in values if mu_s is None]
    spread = None
    if missing:
        problems.append("no mu_s to compare: " + ", ".join(missing))
    else:
        first = values[0][1]
        spread = max(abs(mu_s - first) / first for _, mu_s in values)
        if not spread <= tolerance:
            problems.append(f"mu_s differs by {spread:.3g} (relative) > {tolerance:g}")
    return Agreement(kind, values, spread, tolerance, tuple(problems))


def agreement_lines(found: Agreement) -> list[str]:
    """The Markdown of an :class:`Agreement`: mu_s per run (12 digits), spread, verdict."""
    title = {"ranks": "rank counts", "repeat": "repeats on the same ranks"}[found.kind]
    values = ", ".join(f"{variant}: " + ("–" if mu_s is None else f"{mu_s:.12g}")
                       for variant, mu_s in found.values)
    spread = "–" if found.spread is None else f"{found.spread:.3g}"
    verdict = ("agree" if found.agrees else "**DO NOT AGREE**: " + "; ".join(found.problems))
    return [f"- {title}: mu_s {values}; largest relative difference {spread} "
            f"(tolerance {found.tolerance:g}): {verdict}."]


def disagreements(rows: Sequence[dict]) -> list[str]:
    """The problems of the rank and repeat agreement ([] if both agree or are absent)."""
    found = [agreement(rows, kind) for kind in CHECK_KINDS]
    return [f"{one.kind}: {problem}" for one in found if one for problem in one.problems]


# --- tables ----------------------------------------------------------------------------------

#: Kinds compared with the default run of their surface and load.
VARIANT_KINDS = (*OPTIONS, "material")
#: Kinds of the rank and repeat runs.
CHECK_KINDS = ("ranks", "repeat")
COLUMNS = ("kind", "surface", "n", "load_star", "psi", "option", "factor", "variant", "outcome",
           "problems", "converged", "message", "note", "mu_s", "mu_s_change",
           "area_ratio_normal", "area_ratio_sliding", "junction_growth", "contact_nodes",
           "contact_patches", "nodes_per_patch", "cells_per_patch", "reliable", "steps",
           "cut_steps", "newton_iterations", "wall_s", "peak_memory_gb", "expected_ranks",
           "ranks", "physics")
UNRELIABLE_MARK = "†"


def cell_text(row: dict) -> str:
    """A table cell: mu_s (or the normal-load outcome), ``(k cuts)`` after step cutting,
    ``FAILED``, ``SILENT`` and † when unreliable."""
    if row["outcome"] == SILENT:
        return "**SILENT**"
    if row["outcome"] == FAILED:
        return "FAILED"
    text = f"{row['mu_s']:.3f}" if row["mu_s"] is not None else "converged"
    if row["kind"] in VARIANT_KINDS and row.get("mu_s_change") is not None:
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
    """Surfaces down (with psi), loads across: the matrix and measured runs."""
    cells = {(row["surface"], row["load_star"]): row for row in rows
             if row["kind"] in ("matrix", "measured")}
    surfaces = list(dict.fromkeys(surface for surface, _ in cells))
    psi = {surface: row.get("psi") for (surface, _), row in cells.items()}
    body = [[surface, "–" if psi[surface] is None else f"{psi[surface]:.2f}"]
            + [cell_text(cells[surface, load]) if (surface, load) in cells else "–"
               for load in loads] for surface in surfaces]
    return markdown_table(["surface", "psi"] + [f"F* = {load:g}" for load in loads], body)


def setting(row: dict) -> tuple[str, str]:
    """What a variant run changes, as two table cells: (option, ``x factor``) or
    ("material", its label)."""
    if row["kind"] == "material":
        return "material", row["variant"]
    return row["option"], f"x{row['factor']:g}"


def option_table(rows: Sequence[dict], kinds: Sequence[str]) -> list[str]:
    """Setting down, loads across: the runs of ``kinds`` beside their default run."""
    option_rows = [row for row in rows if row["kind"] in kinds]
    loads = sorted({row["load_star"] for row in option_rows})
    surfaces = {row["surface"] for row in option_rows}
    baseline = {row["load_star"]: row for row in rows
                if row["kind"] == "default" and row["surface"] in surfaces}
    body = [["defaults", "x1"] + [cell_text(baseline[load]) if load in baseline else "–"
                                  for load in loads]]
    cells = {(*setting(row), row["load_star"]): row for row in option_rows}
    for name, value in dict.fromkeys(setting(row) for row in option_rows):
        body.append([name, value] + [cell_text(cells[name, value, load])
                                     if (name, value, load) in cells else "–" for load in loads])
    surface = ", ".join(sorted(surfaces))
    return markdown_table(["option", "setting"] + [f"{surface} F* = {load:g}" for load in loads],
                          body)


def check_table(rows: Sequence[dict]) -> list[str]:
    """The rank and repeat runs: variant, ranks it ran on, mu_s to 12 digits, outcome."""
    body = [[row["kind"], row["variant"], str(row["ranks"] or "–"),
             "–" if row["mu_s"] is None else f"{row['mu_s']:.12g}", row["outcome"]]
            for row in rows if row["kind"] in CHECK_KINDS]
    return markdown_table(["kind", "run", "ranks", "mu_s", "outcome"], body)


def outcome_counts(rows: Sequence[dict]) -> Counter:
    """Runs per outcome (every outcome present, 0 if none)."""
    counts = Counter({outcome: 0 for outcome in OUTCOMES})
    counts.update(row["outcome"] for row in rows)
    return counts


def run_name(row: dict) -> str:
    """``G5 F*=0.155`` (with ``penalty x100``, the material or the rank/repeat run)."""
    name = f"{row['surface']} F*={row['load_star']:g}"
    if row["kind"] in OPTIONS:
        return name + f" {row['option']} x{row['factor']:g}"
    return name + (f" {row['variant']}" if row.get("variant") else "")


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


def variant_sections(rows: Sequence[dict]) -> list[str]:
    """The option, material and rank/repeat sections of the Markdown (those with runs)."""
    lines = []
    if any(row["kind"] in OPTIONS for row in rows):
        lines += ["Solver options against the defaults: contact penalty, first tangential "
                  "step, Newton residual and increment tolerances, contact penetration "
                  "tolerance (change of mu_s in brackets: numerical error):", ""]
        lines += option_table(rows, tuple(OPTIONS)) + [""]
    if any(row["kind"] == "material" for row in rows):
        lines += ["Material extremes (change of mu_s in brackets: physics, the material "
                  "changes psi too):", ""] + option_table(rows, ("material",)) + [""]
    found = [one for one in (agreement(rows, kind) for kind in CHECK_KINDS) if one]
    if found:
        lines += ["Rank counts (each its own mpirun) and repeats (each in an empty run cache):",
                  ""] + check_table(rows) + [""]
        lines += [line for one in found for line in agreement_lines(one)] + [""]
    return lines


def stress_markdown(rows: Sequence[dict], n: int, loads: Sequence[float],
                    provenance: str = "") -> str:
    """The README-ready section: provenance, matrix, counts, options, materials, ranks and
    repeats, failures, reliable region."""
    counts = outcome_counts(rows)
    ranks = sorted({row["ranks"] for row in rows if row.get("ranks")
                    and row["kind"] not in CHECK_KINDS})
    lines = [provenance, ""] if provenance else []
    lines += [f"Stress runs on N = {n} grids ({', '.join(map(str, ranks)) or '?'} rank(s)). "
              "G1-G9 as the figures mesh them (an N x N window at their own spacing), "
              "ST400 test3 resampled to N x N. "
              "Cells: mu_s; (k cuts): converged after k step cuts (a cut on the normal path "
              "a surface's loads share counts in each of them); (alone): failed on the "
              "normal path shared with the smaller loads, converged on its own; FAILED: failed "
              "loudly "
              f"(reason below); {UNRELIABLE_MARK}: unreliable, fewer than "
              f"{RELIABLE_CELLS_PER_PATCH} grid cells of contact area per patch.", ""]
    lines += matrix_table(rows, loads) + [""]
    lines += ["Outcomes of all " + str(len(rows)) + " runs: "
              + ", ".join(f"{counts[outcome]} {outcome}" for outcome in OUTCOMES) + ".", ""]
    lines += variant_sections(rows)
    failed = [row for row in rows if row["outcome"] in (FAILED, SILENT)]
    if failed:
        lines += ["Failures:", ""] + [f"- {run_name(row)}: {row['outcome']}: "
                                      f"{row['problems'] or row['message']}" for row in failed]
        lines.append("")
    lines += [f"Reliable region (converged, >= {RELIABLE_CELLS_PER_PATCH} grid cells of contact "
              "area per patch):", ""] + reliable_region(rows, loads)
    return "\n".join(lines) + "\n"


def provenance_line() -> str:
    """Which code ran, when and where: version, UTC date, cores and load average (the wall
    times of the CSV are not benchmarks on a shared machine)."""
    from datetime import UTC, datetime

    from roughfriction import __version__

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return (f"roughfriction {__version__}, run {datetime.now(UTC):%Y-%m-%d %H:%M} UTC "
            f"on {os.cpu_count()} cores (1-min load average {load:.1f} at the end); no timings "
            "are claimed: the wall times in stress.csv depend on the machine's other work.")


# --- command line ----------------------------------------------------------------------------


def rank_run_missing(run: StressRun, n: int) -> str:
    """The message of a rank run whose own mpirun has not run."""
    return (f"not computed: run it first with mpirun -n {run.ranks} --oversubscribe "
            f"python -m benchmarks stress --n {n} --rank-run (make stress does)")


def compute_rank_run(n: int, output: Path, comm, progress=None) -> Path | None:
    """Compute the rank run of this many ranks (``comm.size``, one of :data:`RANK_COUNTS`) into
    its own run cache (:func:`check_directory`); its results file (None: it could not
    start)."""
    found = [run for run in check_runs(base_case(n)) if run.kind == "ranks"
             and run.ranks == comm.size]
    if not found:
        raise InputError(f"--rank-run runs on {', '.join(map(str, RANK_COUNTS))} ranks, not "
                         f"{comm.size}")
    return compute_batch([found[0].case], comm, check_directory(output, found[0]),
                         progress)[0].path


def compute_runs(runs: Sequence[StressRun], n: int, output: Path, comm, runs_directory=None,
                 progress=None) -> list:
    """The :class:`~benchmarks.batch.BatchResult` of each run (None: not set up): the plan's runs
    through the run cache, each repeat computed in its own, the rank runs read from theirs."""
    plain = [run for run in runs if run.case is not None and run.kind not in CHECK_KINDS]
    results = dict(zip((id(run) for run in plain),
                       compute_batch([run.case for run in plain], comm, runs_directory,
                                     progress), strict=True))
    for run in runs:
        if run.kind == "repeat":
            results[id(run)] = compute_batch([run.case], comm, check_directory(output, run),
                                             progress)[0]
        elif run.kind == "ranks":
            result = cached_batch([run.case], check_directory(output, run))[0]
            results[id(run)] = (result if result.path else
                                BatchResult(None, rank_run_missing(run, n)))
    return [results.get(id(run)) for run in runs]


def run_stress(runs: Sequence[StressRun], n: int, loads: Sequence[float], output: Path, comm,
               runs_directory=None, progress=None) -> list[dict] | None:
    """Compute (every rank) and write (rank 0) the stress test; the rows on rank 0, else
    None."""
    from roughfriction.studies.post import read_run

    results = compute_runs(runs, n, output, comm, runs_directory, progress)
    if comm.rank != 0:
        return None
    rows = []
    for run, result in zip(runs, results, strict=True):
        if result is not None and result.path is not None:
            rows.append(stress_row(run, n, run_facts(read_run(result.path))))
        else:
            rows.append(stress_row(run, n, None, result.error if result else run.error))
    add_changes(rows)
    output.mkdir(parents=True, exist_ok=True)
    write_text(output / "stress.csv", csv_text(rows, COLUMNS))
    write_text(output / "stress.md", stress_markdown(rows, n, loads, provenance_line()))
    counts = outcome_counts(rows)
    print("; ".join(f"{outcome}: {counts[outcome]}" for outcome in OUTCOMES), flush=True)
    for problem in disagreements(rows):
        print(f"DISAGREEMENT {problem}", flush=True)
    print(f"wrote {output / 'stress.csv'} and {output / 'stress.md'}", flush=True)
    return rows
