"""Run time against error of the FEM (``make bench-error``, part of ``make bench``).

    mpirun -n 2 roughfriction bench error              # the tables below
    mpirun -n 2 roughfriction bench error --quick      # N = 8 and 16 only
    roughfriction bench error --plan                   # the runs, without computing them

Cases (:data:`CASES`): G5 at F* = 0.155 and 0.93, the 2L stand-in at F* = 0.5, and an elastic
single sinusoid pressed to 1.4 p* (complete contact: closed form p* = sqrt(2) pi E' Delta /
lambda and A_r/A_n = 1). Each case is run

* at every resolution of :data:`SIZES` (the built-in 128^2 surface re-gridded to N x N, as
  ``--n N`` does: a coarser N is a smoother surface, not only a coarser mesh);
* with each surface of the sweep but the finest spectrally interpolated onto the next finer
  grid (the same surface on a 2x finer mesh: the mesh error alone, at every N);
* with each knob of :data:`VARIANTS` changed alone from the defaults, at :data:`BASE_N`.

Every run is a :class:`~roughfriction.case.FemCase` through the run cache (``results/runs``): a
rerun computes nothing, and runs are shared with the figures. All ranks compute; rank 0 writes.

Errors (rank 0): of mu_s, A_r/A_n (under the normal load) and junction growth, against the
reference of the case (the finest run of :data:`SIZES` that converged, named in the table; for
the sinusoid the closed form, also for p*) and against each run's comparator (a knob variant:
the defaults at the same N; a resolution N: the run at 2N; the spectral run: the run of its
coarse surface). Relative errors
for mu_s, A_r/A_n and p*, differences for the junction growth. Wall time (``total_s`` of the
results file) and peak memory (summed over the ranks) come from the results files.

Output: ``results/bench/error.csv`` and ``error.png`` (wall time against the mu_s error, p* for
the sinusoid, with each case's Pareto front and the chosen defaults marked; ``--quick`` writes
to ``results/bench/quick/``), and the resolution check on stdout: the default N is the smallest
N of the sweep from which on every doubling changes mu_s by at most :data:`MU_S_TOLERANCE` in
every sliding case.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from roughfriction.case import FemCase, Loading, SolverOptions
from roughfriction.files import atomic_write
from roughfriction.geometry.surface import Surface
from roughfriction.material import Material
from roughfriction.studies.batch import (
    cached_batch,
    compute_batch,
    csv_text,
    summary_columns,
    write_text,
)

# --- what is run -----------------------------------------------------------------------------

#: Surface cells per side of the resolution sweep [-].
SIZES = (16, 32, 64, 128)
#: Resolution at which the knobs of VARIANTS are varied [-] (the figures' default, so that the
#: default runs are shared with them).
BASE_N = 32
#: Knobs changed one at a time from the defaults at BASE_N: (options table, option, values).
VARIANTS = (
    ("mesh", "blend_layers", (4, 8)),  # default 2
    ("mesh", "fine_layers", (4, 8)),  # full-resolution layers, default 2
    ("mesh", "coarsen", (False,)),  # 2:1 coarsened levels below them, default on
    ("mesh", "depth", (0.5, 2.0)),  # base depth in periods, default 1
    ("solver", "integration", ("full",)),  # default "selective" (SRI)
    ("solver", "first_slide", (0.005, 0.08)),  # tangential step size, default 0.02
    ("solver", "residual_tolerance", (1e-4, 1e-8)),  # default 1e-6
    ("solver", "penalty", (1.0, 100.0)),  # default 40 E'/h
)
#: Knobs without effect on a normal-only run (not run for the sinusoid).
SLIDING_ONLY = ("first_slide",)
#: --quick: the same knobs on small grids.
QUICK_SIZES, QUICK_BASE_N = (8, 16), 8
#: Largest change of mu_s under a doubling of N accepted for the default resolution [-].
MU_S_TOLERANCE = 0.02

#: The elastic sinusoid Delta cos(2 pi x / lambda) cos(2 pi y / lambda), lambda = the period.
SINUSOID = "sinusoid"
SINUSOID_PERIOD = 128e-6  # [m]
SINUSOID_SLOPE = 5e-4  # Delta / lambda [-]
SINUSOID_LOAD_RATIO = 1.4  # mean pressure / p* [-]: complete contact


#: The paper's material (the default of every case).
PAPER_MATERIAL = Material()


def sinusoid_p_star(material: Material = PAPER_MATERIAL) -> float:
    """Closed-form complete-contact pressure p* = sqrt(2) pi E' Delta / lambda [Pa]."""
    return math.sqrt(2) * math.pi * material.E_star * SINUSOID_SLOPE


@dataclass(frozen=True)
class ErrorCase:
    """One case of the benchmark.

    Attributes
    ----------
    label : str
        Name in the tables.
    surface : str
        A built-in surface name, or :data:`SINUSOID`.
    load_star : float
        F* = F_n / (A_n S_y) [-].
    """

    label: str
    surface: str
    load_star: float

    @property
    def analytic(self) -> bool:
        """The elastic sinusoid: normal load only, compared with its closed form."""
        return self.surface == SINUSOID


CASES = (
    ErrorCase("G5 F*=0.155", "G5", 0.155),
    ErrorCase("G5 F*=0.93", "G5", 0.93),
    ErrorCase("2L F*=0.5", "2L", 0.5),
    ErrorCase("sinusoid 1.4p*", SINUSOID, SINUSOID_LOAD_RATIO * sinusoid_p_star()
              / PAPER_MATERIAL.Sy),
)


@dataclass(frozen=True)
class Variant:
    """How one run differs from the defaults.

    Attributes
    ----------
    knob : str
        "n" (resolution), "spectral" (coarse surface on a finer grid) or "<table>.<option>".
    value : object
        N [-], the coarse grid [-] for "spectral", or the option's value.
    n : int
        Surface cells per side of the FEM grid [-].
    """

    knob: str
    value: object
    n: int

    @property
    def label(self) -> str:
        """``N=32``, ``64^2 on 128``, ``penalty=100``."""
        if self.knob == "n":
            return f"N={self.n}"
        if self.knob == "spectral":
            return f"{self.value}^2 on {self.n}"
        value = self.value if isinstance(self.value, (str, bool)) else f"{self.value:g}"
        return f"{self.knob.split('.')[1]}={value}"


@dataclass(frozen=True)
class ErrorPlan:
    """The benchmark's runs: cases, resolutions and knobs (defaults: the tables above)."""

    cases: tuple = CASES
    sizes: tuple = SIZES
    base_n: int = BASE_N
    variants: tuple = VARIANTS
    spectral: bool = True
    material: Material = PAPER_MATERIAL


def case_variants(case: ErrorCase, plan: ErrorPlan) -> list[Variant]:
    """The variants run for ``case``: the sizes, the spectral runs (rough surfaces: each size
    but the finest on the next one), the knobs (those of :data:`SLIDING_ONLY` only for sliding
    cases)."""
    sizes = sorted(plan.sizes)
    variants = [Variant("n", n, n) for n in sizes]
    if plan.spectral and not case.analytic:
        variants += [Variant("spectral", coarse, fine)
                     for coarse, fine in zip(sizes, sizes[1:], strict=False)]
    for table, option, values in plan.variants:
        if case.analytic and option in SLIDING_ONLY:
            continue
        variants += [Variant(f"{table}.{option}", value, plan.base_n) for value in values]
    return variants


def sinusoid_surface(n: int) -> Surface:
    """The benchmark's sinusoid on n x n points over one period [m]."""
    phase = 2 * np.pi * np.arange(n) / n
    amplitude = SINUSOID_SLOPE * SINUSOID_PERIOD
    return Surface(amplitude * np.outer(np.cos(phase), np.cos(phase)), SINUSOID_PERIOD / n,
                   SINUSOID)


def case_surface(case: ErrorCase, variant: Variant) -> Surface:
    """The surface of a run on its FEM grid: the sinusoid; a built-in surface re-gridded as
    ``--n`` does; for "spectral" re-gridded to the coarse grid, then Fourier-interpolated."""
    from roughfriction.geometry.generate import builtin_surface
    from roughfriction.geometry.surface import spectral_interpolate, surface_on_fem_grid

    if case.analytic:
        return sinusoid_surface(variant.n)
    surface = builtin_surface(case.surface)
    if variant.knob == "spectral":
        return spectral_interpolate(surface_on_fem_grid(surface, variant.value), variant.n)
    return surface_on_fem_grid(surface, variant.n)


def fem_case(case: ErrorCase, variant: Variant, material: Material = PAPER_MATERIAL) -> FemCase:
    """The FemCase of one run: the defaults (elastic and normal-only for the sinusoid) with the
    variant's option changed."""
    fem = FemCase(case_surface(case, variant), Loading(case.load_star, case.analytic),
                  material, solver=SolverOptions(elastic=case.analytic))
    if "." in variant.knob:
        table, option = variant.knob.split(".")
        fem = replace(fem, **{table: replace(getattr(fem, table), **{option: variant.value})})
    return fem


def benchmark_runs(plan: ErrorPlan) -> list[tuple[ErrorCase, Variant, FemCase]]:
    """Every run of the plan: (case, variant, FemCase)."""
    return [(case, variant, fem_case(case, variant, plan.material))
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


def mode_amplitude(values: np.ndarray) -> float:
    """Amplitude of the cos(2 pi i / n) cos(2 pi j / n) mode of an n x n map (its units)."""
    n = values.shape[0]
    phase = 2 * np.pi * np.arange(n) / n
    mode = np.outer(np.cos(phase), np.cos(phase))
    return float(np.sum(values * mode) / np.sum(mode**2))


def complete_contact_p_star(run) -> float | None:
    """p* of a sinusoid run in complete contact [Pa]: the amplitude of its pressure mode (the
    surface is pressed flat, so the pressure is the mean plus p* cos cos); None unless every
    node touches."""
    contact, pressure = run.maps.get("contact_normal"), run.maps.get("pressure_normal")
    if contact is None or pressure is None or not np.all(contact):
        return None
    return mode_amplitude(np.asarray(pressure))


def measured(run, case: ErrorCase) -> dict:
    """The columns of one run from its results file (``run`` None: it did not start)."""
    columns = summary_columns(run)
    columns["p_star_Pa"] = complete_contact_p_star(run) if run and case.analytic else None
    return columns


def comparator(variant: Variant, sizes: Sequence[int], base_n: int) -> Variant | None:
    """What a run is compared with: a knob variant with the defaults at its N, resolution N
    with 2N (if in the sweep), the spectral run with the run of its coarse surface."""
    if variant.knob == "n":
        return Variant("n", 2 * variant.n, 2 * variant.n) if 2 * variant.n in sizes else None
    if variant.knob == "spectral":
        return Variant("n", variant.value, variant.value)
    return Variant("n", base_n, base_n)


def closed_form(material: Material) -> dict:
    """The sinusoid's exact values: A_r/A_n = 1 (complete contact) and p* [Pa]."""
    return {"area_ratio_normal": 1.0, "p_star_Pa": sinusoid_p_star(material)}


def error_columns(row: dict, reference: dict) -> dict:
    """Errors of a run's values against ``reference``'s: ``mu_s``, ``area`` (A_r/A_n under the
    normal load), ``p_star`` relative [-], ``growth`` (junction growth) a difference [-]."""
    return {
        "mu_s": relative_change(row.get("mu_s"), reference.get("mu_s")),
        "area": relative_change(row.get("area_ratio_normal"), reference.get("area_ratio_normal")),
        "growth": difference(row.get("junction_growth"), reference.get("junction_growth")),
        "p_star": relative_change(row.get("p_star_Pa"), reference.get("p_star_Pa")),
    }


def finest_converged(table: dict, label: str, sizes: Sequence[int]) -> tuple[dict, str]:
    """The reference of a rough case: its finest run of the sweep that converged, and its name
    (``N=128``, or ``N=64 (no converged N=128)``); ({}, "none converged") if none did."""
    finest = max(sizes)
    for n in sorted(sizes, reverse=True):
        values = table.get((label, Variant("n", n, n)), {})
        if values.get("converged"):
            return values, f"N={n}" + (f" (no converged N={finest})" if n != finest else "")
    return {}, "none converged"


def error_rows(runs: Sequence[tuple], measurements: Sequence[dict], plan: ErrorPlan) -> list:
    """One row per run: case, variant, measured columns, errors against the case's reference
    (``*_error``) and against the run's comparator (``*_change``).

    Parameters
    ----------
    runs : sequence of (ErrorCase, Variant, FemCase)
        As :func:`benchmark_runs`.
    measurements : sequence of dict
        :func:`measured` of each run.
    plan : ErrorPlan
        Sizes and base resolution.
    """
    table = {(case.label, variant): values
             for (case, variant, _), values in zip(runs, measurements, strict=True)}
    rows = []
    for (case, variant, _), values in zip(runs, measurements, strict=True):
        if case.analytic:
            reference, reference_name = closed_form(plan.material), "closed form"
        else:
            reference, reference_name = finest_converged(table, case.label, plan.sizes)
        compared = comparator(variant, plan.sizes, plan.base_n)
        other = table.get((case.label, compared), {}) if compared else {}
        row = {"case": case.label, "knob": variant.knob, "value": variant.value,
               "label": variant.label, "n": variant.n, "chosen_default": False, **values,
               "reference": reference_name}
        row.update({f"{key}_error": value for key, value in
                    error_columns(values, reference).items()})
        row["compared_with"] = compared.label if compared else ""
        row.update({f"{key}_change": value for key, value in
                    error_columns(values, other).items()})
        rows.append(row)
    return rows


def doubling_changes(rows: Sequence[dict]) -> dict[int, dict[str, float]]:
    """mu_s(N) / mu_s(2N) - 1 of every sliding case, for each N of the sweep whose 2N is in it
    (NaN where a run gave no mu_s)."""
    changes: dict[int, dict[str, float]] = {}
    for row in rows:
        if row["knob"] == "n" and row["compared_with"] and row["reference"] != "closed form":
            changes.setdefault(row["n"], {})[row["case"]] = row["mu_s_change"]
    return dict(sorted(changes.items()))


def chosen_resolution(changes: dict[int, dict[str, float]], tolerance: float) -> int | None:
    """The smallest N from which on every doubling changes mu_s by at most ``tolerance`` in
    every case (a NaN fails); None if even the largest N checked fails."""
    chosen = None
    for n in sorted(changes, reverse=True):
        values = list(changes[n].values())
        if not values or not all(abs(value) <= tolerance for value in values):
            break
        chosen = n
    return chosen


def percent_cell(change: float) -> str:
    """A change [-] as a 14-character percentage, "no mu_s" where a run gave none."""
    return f"{100 * change:>+13.2f}%" if math.isfinite(change) else f"{'no mu_s':>14}"


def check_lines(changes: dict[int, dict[str, float]], chosen: int | None,
                tolerance: float) -> list[str]:
    """The printed resolution check: a row per N, a column per case, then the verdict."""
    cases = list(dict.fromkeys(case for row in changes.values() for case in row))
    lines = [f"mu_s at N against 2N (tolerance {100 * tolerance:g} %):",
             f"{'N':>5}  " + "  ".join(f"{case:>14}" for case in cases) + "  verdict"]
    for n, row in changes.items():
        ok = all(abs(row.get(case, math.nan)) <= tolerance for case in cases)
        lines.append(f"{n:>5}  " + "  ".join(percent_cell(row.get(case, math.nan))
                                              for case in cases)
                     + f"  {'PASS' if ok else 'FAIL'}")
    if chosen is None:
        lines.append("default resolution: NONE of the sweep meets the tolerance")
    else:
        lines.append(f"default resolution: N = {chosen} (smallest N from which on every "
                     f"doubling changes mu_s by <= {100 * tolerance:g} %)")
    return lines


def mesh_lines(rows: Sequence[dict]) -> list[str]:
    """The printed mesh-only check: mu_s of each sliding case's coarse surface on the finer
    mesh (the spectral run) against the same surface on its own grid."""
    spectral = [row for row in rows
                if row["knob"] == "spectral" and row["reference"] != "closed form"]
    if not spectral:
        return []
    return (["mu_s of the same surface on a 2x finer mesh against its own grid (mesh error):"]
            + [f"{row['label']:>12}  {row['case']:>14} {percent_cell(row['mu_s_change'])}"
               for row in spectral])


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


# --- output ----------------------------------------------------------------------------------

COLUMNS = ("case", "knob", "value", "label", "n", "chosen_default", "converged", "message",
           "mu_s", "area_ratio_normal", "junction_growth", "p_star_Pa", "reference",
           "mu_s_error", "area_error", "growth_error", "p_star_error", "compared_with",
           "mu_s_change", "area_change", "growth_change", "p_star_change", "wall_s",
           "peak_memory_gb", "ranks", "steps", "cut_steps", "newton_iterations")


def plotted_error(row: dict) -> float:
    """The error on the plot's axis [-]: p* against its closed form for the sinusoid, else
    mu_s against the case's reference (absolute values)."""
    key = "p_star_error" if row["reference"] == "closed form" else "mu_s_error"
    return abs(row[key])


def plot_error(rows: Sequence[dict], path: Path) -> None:
    """Wall time against error, a panel per case, each knob a colour, the Pareto front dashed,
    the chosen defaults a star; the reference run (error 0) is named in the panel title."""
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
        shown = [row for row in mine if row["wall_s"] and plotted_error(row) > 0]
        times = [row["wall_s"] for row in shown]
        errors = [100 * plotted_error(row) for row in shown]
        for knob in knobs:
            points = [(t, e) for t, e, row in zip(times, errors, shown, strict=True)
                      if row["knob"] == knob]
            if points:
                ax.scatter(*zip(*points, strict=True), s=22, color=colours[knob], label=knob)
        for t, e, row in zip(times, errors, shown, strict=True):
            ax.annotate(row["label"], (t, e), fontsize=6, xytext=(3, 2),
                        textcoords="offset points")
        if not shown:
            ax.text(0.5, 0.5, "no run with a finite error", ha="center", transform=ax.transAxes)
            ax.set_title(case)
            continue
        front = pareto_front(times, errors)
        ax.plot([times[k] for k in front], [errors[k] for k in front], "k--", lw=0.8,
                drawstyle="steps-post", label="Pareto front")
        chosen = [k for k, row in enumerate(shown) if row["chosen_default"]]
        ax.scatter([times[k] for k in chosen], [errors[k] for k in chosen], marker="*", s=160,
                   facecolor="none", edgecolor="k", label="chosen defaults")
        ax.set(xscale="log", yscale="log", xlabel="wall time [s]", title=case,
               ylabel="|p* error| vs closed form [%]" if mine[0]["reference"] == "closed form"
               else f"|mu_s error| vs {mine[0]['reference']} [%]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6)
    for ax in axes.flat[len(cases):]:
        ax.set_visible(False)
    atomic_write(Path(path), lambda temporary: fig.savefig(temporary, dpi=110, format="png"))
    plt.close(fig)


def mark_defaults(rows: list[dict], chosen: int) -> None:
    """Set ``chosen_default`` on the default-options runs at the chosen N."""
    for row in rows:
        row["chosen_default"] = row["knob"] == "n" and row["n"] == chosen


# --- command line ----------------------------------------------------------------------------


def run_benchmark(plan: ErrorPlan, output: Path, comm, runs_directory=None,
                  progress=None, compute: bool = True) -> list[dict] | None:
    """Compute (every rank) and write (rank 0) the benchmark; the rows on rank 0, else None.
    With ``compute`` False nothing is computed: the tables are written from the runs in the
    cache, the others reported as not computed."""
    from roughfriction.studies.post import read_run

    runs = benchmark_runs(plan)
    cases = [fem for _, _, fem in runs]
    if not compute:
        results = cached_batch(cases, runs_directory) if comm.rank == 0 else None
    else:
        results = compute_batch(cases, comm, runs_directory, progress)
    if comm.rank != 0:
        return None
    measurements = [measured(read_run(result.path) if result.path else None, case)
                    | ({"message": result.error} if result.error else {})
                    for (case, _, _), result in zip(runs, results, strict=True)]
    rows = error_rows(runs, measurements, plan)
    changes = doubling_changes(rows)
    chosen = chosen_resolution(changes, MU_S_TOLERANCE)
    mark_defaults(rows, plan.base_n if chosen is None else chosen)
    output.mkdir(parents=True, exist_ok=True)
    write_text(output / "error.csv", csv_text(rows, COLUMNS))
    plot_error(rows, output / "error.png")
    print("\n".join(check_lines(changes, chosen, MU_S_TOLERANCE) + mesh_lines(rows)),
          flush=True)
    if chosen is None:
        print(f"(the defaults at the base N = {plan.base_n} are marked instead)", flush=True)
    print(f"wrote {output / 'error.csv'} and {output / 'error.png'}", flush=True)
    return rows
