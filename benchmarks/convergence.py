"""Run time against error of the FEM on the paper's surfaces (``make bench-error``).

    mpirun -n 2 python -m benchmarks error              # the four cases on their 128^2 grids
    mpirun -n 2 python -m benchmarks error --quick      # the same on 16^2 windows
    python -m benchmarks error --plan                   # the runs, without computing them

Cases (:data:`CASES`): G5 at F* = 0.155 and 0.93, the 2L stand-in at F* = 0.5 and G1 at
F* = 1.86, each on its own 128 x 128 grid (:func:`studies.paper.fem_surface`). Each case is run

* on the mesh ladder :data:`LEVELS`: level 0 is the surface's own grid (the default), level k
  the same bilinear surface on a 2^k times finer mesh (:func:`studies.refinement.level_case`);
* with each knob of :data:`KNOBS` changed alone from the defaults, on level 0 (for the cases
  of :data:`KNOB_CASES`).

The reference of a case is its finest level that converged; its own error is estimated from
the ladder (:func:`studies.refinement.richardson`: two levels at the assumed order, three at
the observed one) and written beside it (``reference_error``, relative). Every run is a
:class:`~roughfriction.case.FemCase` through the run cache (``results/runs``): a rerun computes
nothing. All ranks compute; rank 0 writes.

Errors (rank 0), relative for mu_s and A_r/A_n (under the normal load), differences for the
junction growth: against the case's reference (``*_error``) and against the run's comparator
(``*_change``: a knob against the defaults, a level against the next coarser one). Wall time
(``total_s``) and peak memory (summed over the ranks) come from the results files, and so do
``version``, the code that computed the run, and ``physics``, the stamp of its physics.

Output: ``error.csv`` and ``error.png`` (wall time against |mu_s error|, a panel per case, the
Pareto front dashed, the defaults starred) in ``results/bench/`` (``--quick``:
``results/bench/quick/``), and the frontier on stdout.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from roughfriction.case import FemCase
from roughfriction.files import atomic_write
from roughfriction.studies.refinement import LADDER_RATIO, level_case, richardson
from roughfriction.studies.tables import csv_text, write_text

from benchmarks.batch import cached_batch, compute_batch, summary_columns

# --- what is run -----------------------------------------------------------------------------

#: Surface cells per side: the paper's surfaces on their own grid [-].
BASE_N = 128
#: Mesh levels: 0 the surface's own grid, k a 2^k times finer mesh [-].
LEVELS = (0, 1)
#: Knobs changed one at a time from the defaults on level 0, each towards a cheaper run:
#: (options table, option, values).
KNOBS = (
    ("solver", "first_slide", (0.08,)),  # first tangential increment, default 0.02
    ("solver", "max_slide_increment", (0.5,)),  # largest tangential increment, default 0.25
    ("solver", "residual_tolerance", (1e-4,)),  # Newton tolerance, default 1e-6
    ("mesh", "fine_layers", (1,)),  # full-resolution layers under the surface, default 2
)
#: Cases whose knobs are run (G5's two loads share their preload, so a knob costs one group).
KNOB_CASES = ("G5 F*=0.155", "G5 F*=0.93")
#: --quick: the same on small windows, with one more level.
QUICK_N, QUICK_LEVELS = 16, (0, 1, 2)


@dataclass(frozen=True)
class ErrorCase:
    """One case of the benchmark.

    Attributes
    ----------
    label : str
        Name in the tables.
    surface : str
        A built-in surface name.
    load_star : float
        F* = F_n / (A_n S_y) [-].
    """

    label: str
    surface: str
    load_star: float


CASES = (
    ErrorCase("G5 F*=0.155", "G5", 0.155),
    ErrorCase("G5 F*=0.93", "G5", 0.93),
    ErrorCase("2L F*=0.5", "2L", 0.5),
    ErrorCase("G1 F*=1.86", "G1", 1.86),
)


@dataclass(frozen=True)
class Variant:
    """How one run differs from the defaults.

    Attributes
    ----------
    knob : str
        "level" (the mesh level) or "<table>.<option>" (on level 0).
    value : object
        The level [-] or the option's value.
    """

    knob: str
    value: object

    @property
    def level(self) -> int:
        """Mesh level of the run: 0 the surface's own grid [-]."""
        return int(self.value) if self.knob == "level" else 0

    @property
    def label(self) -> str:
        """``1x``, ``2x``, ``first_slide=0.08``."""
        if self.knob == "level":
            return f"{LADDER_RATIO**self.level}x"
        value = self.value if isinstance(self.value, (str, bool)) else f"{self.value:g}"
        return f"{self.knob.split('.')[1]}={value}"


DEFAULTS = Variant("level", 0)


@dataclass(frozen=True)
class ErrorPlan:
    """The benchmark's runs: cases, grid, levels and knobs (defaults: the tables above)."""

    cases: tuple = CASES
    n: int = BASE_N
    levels: tuple = LEVELS
    knobs: tuple = KNOBS
    knob_cases: tuple = KNOB_CASES


def case_variants(case: ErrorCase, plan: ErrorPlan) -> list[Variant]:
    """The variants run for ``case``: the levels, then (for the plan's knob cases) each knob
    value alone."""
    variants = [Variant("level", level) for level in sorted(plan.levels)]
    if case.label not in plan.knob_cases:
        return variants
    return variants + [Variant(f"{table}.{option}", value)
                       for table, option, values in plan.knobs for value in values]


def fem_case(case: ErrorCase, variant: Variant, n: int) -> FemCase:
    """The FemCase of one run: the figures' case of the surface on n x n cells
    (:func:`studies.paper.fem_case`) with the variant's option changed, on its level."""
    from roughfriction.studies.paper import fem_case as paper_case

    fem = paper_case(case.surface, case.load_star, n)
    if "." in variant.knob:
        table, option = variant.knob.split(".")
        fem = replace(fem, **{table: replace(getattr(fem, table), **{option: variant.value})})
    return level_case(fem, variant.level)


def benchmark_runs(plan: ErrorPlan) -> list[tuple[ErrorCase, Variant, FemCase]]:
    """Every run of the plan: (case, variant, FemCase)."""
    return [(case, variant, fem_case(case, variant, plan.n))
            for case in plan.cases for variant in case_variants(case, plan)]


# --- errors ----------------------------------------------------------------------------------


def relative_change(value, reference) -> float:
    """value / reference - 1 [-]; NaN when either is missing or the reference is 0."""
    if value is None or reference is None or reference == 0:
        return math.nan
    return value / reference - 1.0


def difference(value, reference) -> float:
    """value - reference; NaN when either is missing."""
    return math.nan if value is None or reference is None else value - reference


def error_columns(row: dict, reference: dict) -> dict:
    """Errors of a run's values against ``reference``'s: ``mu_s`` and ``area`` (A_r/A_n under
    the normal load) relative [-], ``growth`` (junction growth) a difference [-]."""
    return {
        "mu_s": relative_change(row.get("mu_s"), reference.get("mu_s")),
        "area": relative_change(row.get("area_ratio_normal"), reference.get("area_ratio_normal")),
        "growth": difference(row.get("junction_growth"), reference.get("junction_growth")),
    }


@dataclass(frozen=True)
class Reference:
    """The reference of a case: its finest converged level.

    Attributes
    ----------
    values : dict
        Its measured columns ({} if no level converged).
    name : str
        ``2x``, ``1x (no converged 2x)`` or ``none converged``.
    error : float
        Estimated relative error of its mu_s [-] (NaN without a coarser converged level).
    order : float
        Order of that estimate [-], observed with three levels, else assumed.
    """

    values: dict
    name: str
    error: float = math.nan
    order: float = math.nan


def case_reference(table: dict, label: str, levels: Sequence[int]) -> Reference:
    """The finest converged level of case ``label`` and its error estimate from the converged
    levels just below it (:func:`studies.refinement.richardson`)."""
    finest = max(levels)
    ladder = []
    for level in sorted(levels):
        values = table.get((label, Variant("level", level)), {})
        if not values.get("converged") or values.get("mu_s") is None:
            break
        ladder.append((level, values))
    if not ladder:
        return Reference({}, "none converged")
    level, values = ladder[-1]
    name = Variant("level", level).label
    if level != finest:
        name += f" (no converged {Variant('level', finest).label})"
    if len(ladder) < 2:
        return Reference(values, name)
    estimate = richardson([row["mu_s"] for _, row in ladder[-3:]])
    return Reference(values, name, estimate.relative_error, estimate.order)


def comparator(variant: Variant) -> Variant | None:
    """What a run is compared with: a knob with the defaults, a level with the next coarser
    one; None for level 0."""
    if variant.knob != "level":
        return DEFAULTS
    return Variant("level", variant.level - 1) if variant.level > 0 else None


def error_rows(runs: Sequence[tuple], measurements: Sequence[dict], plan: ErrorPlan) -> list:
    """One row per run: case, variant, measured columns, the case's reference with its own
    error estimate, errors against it (``*_error``) and against the run's comparator
    (``*_change``).

    Parameters
    ----------
    runs : sequence of (ErrorCase, Variant, FemCase)
        As :func:`benchmark_runs`.
    measurements : sequence of dict
        :func:`measured` of each run.
    plan : ErrorPlan
        The levels.
    """
    table = {(case.label, variant): values
             for (case, variant, _), values in zip(runs, measurements, strict=True)}
    references = {case.label: case_reference(table, case.label, plan.levels)
                  for case, _, _ in runs}
    rows = []
    for (case, variant, _), values in zip(runs, measurements, strict=True):
        reference = references[case.label]
        compared = comparator(variant)
        other = table.get((case.label, compared), {}) if compared else {}
        row = {"case": case.label, "knob": variant.knob, "value": variant.value,
               "label": variant.label, "level": variant.level, "is_default": variant == DEFAULTS,
               **values, "reference": reference.name,
               "reference_mu_s": reference.values.get("mu_s"),
               "reference_error": reference.error, "reference_order": reference.order}
        row.update({f"{key}_error": value for key, value in
                    error_columns(values, reference.values).items()})
        row["compared_with"] = compared.label if compared else ""
        row.update({f"{key}_change": value for key, value in
                    error_columns(values, other).items()})
        rows.append(row)
    return rows


def pareto_front(times: Sequence[float], errors: Sequence[float]) -> list[int]:
    """Indices of the points no other point beats in both wall time and error (ties in time
    broken by error), fastest first; NaN points are left out."""
    points = [(t, e, k) for k, (t, e) in enumerate(zip(times, errors, strict=True))
              if math.isfinite(t) and math.isfinite(e)]
    front, best = [], math.inf
    for _, error, index in sorted(points):
        if error < best:
            front.append(index)
            best = error
    return front


def percent(value) -> str:
    """A fraction as a signed percentage, "-" where there is none."""
    return f"{100 * value:+.2f} %" if value is not None and math.isfinite(value) else "-"


def frontier_lines(rows: Sequence[dict]) -> list[str]:
    """The printed summary per case: the reference with its error estimate, then every run
    on the Pareto front of wall time against |mu_s error| (the defaults marked)."""
    lines = []
    for case in dict.fromkeys(row["case"] for row in rows):
        mine = [row for row in rows if row["case"] == case and row["wall_s"]]
        errors = [abs(row["mu_s_error"]) for row in mine]
        front = pareto_front([row["wall_s"] for row in mine], errors)
        first = mine[0] if mine else {}
        lines.append(f"{case}: reference {first.get('reference', '-')} mu_s = "
                     f"{first.get('reference_mu_s') or math.nan:.4f}, its estimated error "
                     f"{percent(first.get('reference_error'))}")
        lines += [f"  {row['label']:>24} {row['wall_s']:8.1f} s  mu_s {row['mu_s']:.4f}  "
                  f"error {percent(row['mu_s_error'])}" + ("  (defaults)" if row["is_default"]
                                                           else "")
                  for row in (mine[k] for k in front)]
    return lines


# --- output ----------------------------------------------------------------------------------

COLUMNS = ("case", "knob", "value", "label", "level", "is_default", "converged", "message",
           "mu_s", "area_ratio_normal", "junction_growth", "reference", "reference_mu_s",
           "reference_error", "reference_order", "mu_s_error", "area_error", "growth_error",
           "compared_with", "mu_s_change", "area_change", "growth_change", "wall_s",
           "peak_memory_gb", "cpu_share", "ranks", "steps", "cut_steps", "newton_iterations",
           "version", "physics")


def measured(result) -> dict:
    """The columns of one run (a :class:`benchmarks.batch.BatchResult`) from its results file,
    with ``version``, the code that computed it."""
    from roughfriction.studies.post import read_run
    from roughfriction.studies.results_file import run_version

    if result.path is None:
        return summary_columns(None) | {"message": result.error, "version": None}
    return summary_columns(read_run(result.path)) | {"version": run_version(result.path)}


def plot_error(rows: Sequence[dict], path: Path) -> None:
    """Wall time against |mu_s error|, a panel per case, levels and each knob a colour, the
    Pareto front dashed, the defaults a star; the reference (error 0) is named in the title
    with its own error estimate."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys(row["case"] for row in rows))
    knobs = list(dict.fromkeys(row["knob"] for row in rows))
    colours = dict(zip(knobs, plt.get_cmap("tab10").colors, strict=False))
    ncols = 2 if len(cases) > 1 else 1
    nrows = math.ceil(len(cases) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.2 * ncols, 4.0 * nrows), squeeze=False,
                             constrained_layout=True)
    for ax, case in zip(axes.flat, cases, strict=False):
        mine = [row for row in rows if row["case"] == case]
        shown = [row for row in mine if row["wall_s"] and math.isfinite(row["mu_s_error"])
                 and row["mu_s_error"] != 0]
        reference = mine[0]
        ax.set_title(f"{case}: vs {reference['reference']} (its error "
                     f"~{percent(reference['reference_error'])})", fontsize=9)
        if not shown:
            ax.text(0.5, 0.5, "no run with a finite error", ha="center", transform=ax.transAxes)
            continue
        times = [row["wall_s"] for row in shown]
        errors = [100 * abs(row["mu_s_error"]) for row in shown]
        for knob in knobs:
            points = [(t, e) for t, e, row in zip(times, errors, shown, strict=True)
                      if row["knob"] == knob]
            if points:
                ax.scatter(*zip(*points, strict=True), s=22, color=colours[knob], label=knob)
        for t, e, row in zip(times, errors, shown, strict=True):
            ax.annotate(row["label"], (t, e), fontsize=6, xytext=(3, 2),
                        textcoords="offset points")
        front = pareto_front(times, errors)
        ax.plot([times[k] for k in front], [errors[k] for k in front], "k--", lw=0.8,
                drawstyle="steps-post", label="Pareto front")
        chosen = [k for k, row in enumerate(shown) if row["is_default"]]
        ax.scatter([times[k] for k in chosen], [errors[k] for k in chosen], marker="*", s=160,
                   facecolor="none", edgecolor="k", label="defaults")
        ax.set(xscale="log", yscale="log", xlabel="wall time [s]", ylabel="|mu_s error| [%]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6)
    for ax in axes.flat[len(cases):]:
        ax.set_visible(False)
    atomic_write(Path(path), lambda temporary: fig.savefig(temporary, dpi=110, format="png"))
    plt.close(fig)


# --- command line ----------------------------------------------------------------------------


def run_benchmark(plan: ErrorPlan, output: Path, comm, runs_directory=None,
                  progress=None, compute: bool = True) -> list[dict] | None:
    """Compute (every rank) and write (rank 0) the benchmark; the rows on rank 0, else None.
    With ``compute`` False nothing is computed: the tables are written from the runs in the
    cache, the others reported as not computed."""
    runs = benchmark_runs(plan)
    cases = [fem for _, _, fem in runs]
    if not compute:
        results = cached_batch(cases, runs_directory) if comm.rank == 0 else None
    else:
        results = compute_batch(cases, comm, runs_directory, progress)
    if comm.rank != 0:
        return None
    rows = error_rows(runs, [measured(result) for result in results], plan)
    output.mkdir(parents=True, exist_ok=True)
    write_text(output / "error.csv", csv_text(rows, COLUMNS))
    plot_error(rows, output / "error.png")
    print("\n".join(frontier_lines(rows)), flush=True)
    print(f"wrote {output / 'error.csv'} and {output / 'error.png'}", flush=True)
    return rows
