"""mu_s of the FEM beside the multi-scale model and the statistical CKE and LET models
(Figs. 22–28). The theory uses each surface on its own 128 x 128 grid; the FEM the surface of
``studies.paper.fem_surface`` (for G1–G9 a window at their own spacing), whose psi is in the
``psi_fem`` column and, where it is more than 3 % off the surface's, on the figure; the
columns ``fem_pressure_over_Sy`` and ``fem_cells_per_patch`` say how well the mesh resolves
the contact patches (``scripts.fem_views``); at low load ``fem_windows``,
``mu_fem_windows_min`` and ``mu_fem_windows_max`` give the scatter of the windows (on the
figure's mesh). At the ``ERROR_BAR_LOADS`` (every FEM load) a point is the mu_s on a 2x
finer mesh of the same surface, with ``mu_fem_error`` (its certified error,
``studies.certificate``: the bar), ``mu_fem_coarse``, ``fem_refinement`` (the mesh
plotted: 1 or 2) and ``fem_uncertified`` (why a point is not certified to 3 %, drawn hollow;
"" if it is). A
statistical value outside its model's published range (``multiscale.statistical``) is drawn
hollow on a dotted line and labelled so."""

import numpy as np
from roughfriction.geometry.generate import builtin_surface
from roughfriction.geometry.statistics import surface_statistics
from roughfriction.material import Material
from roughfriction.multiscale.scales import scale_decomposition
from roughfriction.multiscale.theory import evaluate_theory
from roughfriction.scripts.fem_views import (
    fem_cells_per_patch,
    fem_contact_pressure,
    fem_label,
    fem_mu,
    fem_mu_at_least,
    fem_psi,
)
from roughfriction.scripts.figures import new_axes
from roughfriction.studies.certificate import certify
from roughfriction.studies.paper import (
    ERROR_BAR_LOADS,
    FEM_LOAD_SWEEP,
    GAUSSIAN_SURFACES,
    LOAD_SWEEP,
    WINDOW_SCATTER_LOADS,
    fem_case,
    window_cases,
)
from roughfriction.studies.refinement import next_mesh

STAND_INS = ("2L", "8L", "63M")
#: A FEM point is certified when its certificate is at most this share of its mu_s [-].
CERTIFIED_RELATIVE_ERROR = 0.03
#: Legend suffix of FEM points that are not certified.
UNCERTIFIED = (f"\nhollow: not certified to {100 * CERTIFIED_RELATIVE_ERROR:g} % "
               "(CSV: fem_uncertified)")
#: Largest relative difference of the meshed surface's psi from the surface's own [-].
PSI_TOLERANCE = 0.03


def draw_statistical(ax, x, mu, valid, label: str, style: dict) -> None:
    """Points inside the model's range solid on a solid line; outside hollow, dotted, and
    labelled "outside its range"."""
    x, mu, valid = np.asarray(x), np.asarray(mu), np.asarray(valid, dtype=bool)
    if valid.any():
        ax.plot(x[valid], mu[valid], "-", label=label, **style)
    if (~valid).any():
        ax.plot(x[~valid], mu[~valid], ":", mfc="none", label=f"{label}, outside its range",
                **style)


def certified_error(coarse, fine) -> float:
    """The certificate (``studies.certificate``) of the fine run's mu_s from the coarse run's,
    with the fine run's contact nodes and their boundary nodes (NaN where a run has no mu_s or
    the summary no boundary count) [-]."""
    mu_coarse, mu_fine = fem_mu(coarse), fem_mu(fine)
    nodes, boundary = (fine.summary.get(key) for key in ("contact_nodes", "boundary_nodes"))
    if not (np.isfinite(mu_coarse) and np.isfinite(mu_fine)) or nodes is None or boundary is None:
        return np.nan
    return certify((mu_coarse, mu_fine), nodes, boundary).error


def error_bars(coarse, fine) -> tuple[list, dict]:
    """The run to plot at each FEM point and its error bar, from the figure's mesh
    (``coarse``) and the 2x finer one (``fine``, None where not run): the fine run where it
    reached sliding inception, with its certificate (:func:`certified_error`) if the coarse
    run did too; else the coarse run, no bar. Returns the runs and the columns
    ``mu_fem_coarse``, ``mu_fem_error`` [-] (NaN: none), ``fem_refinement`` (1 or 2: the
    mesh plotted) and ``fem_uncertified`` (:func:`uncertified_reason`, "" if certified)."""
    plotted, mu_coarse, error, refinement = [], [], [], []
    for one, finer in zip(coarse, fine, strict=True):
        use_finer = finer is not None and bool(np.isfinite(fem_mu(finer)))
        plotted.append(finer if use_finer else one)
        refinement.append(2 if use_finer else 1)
        mu_coarse.append(fem_mu(one))
        error.append(certified_error(one, finer) if use_finer else np.nan)
    reasons = [uncertified_reason(fem_mu(run), bar, level)
               for run, bar, level in zip(plotted, error, refinement, strict=True)]
    return plotted, {"mu_fem_coarse": np.array(mu_coarse), "mu_fem_error": np.array(error),
                     "fem_refinement": np.array(refinement),
                     "fem_uncertified": np.array(reasons)}


def uncertified_reason(mu_s: float, error: float, refinement: int) -> str:
    """Why a FEM point is not certified to :data:`CERTIFIED_RELATIVE_ERROR` ("" if it is):
    no finer level, or a certificate above it."""
    if not np.isfinite(mu_s):
        return ""
    if not np.isfinite(error):
        return ("no certificate: the 2x level did not reach sliding inception" if refinement == 1
                else "no certificate")
    if error > CERTIFIED_RELATIVE_ERROR * mu_s:
        return (f"certificate {100 * error / mu_s:.1f} % of mu_s > "
                f"{100 * CERTIFIED_RELATIVE_ERROR:g} %")
    return ""


def draw_fem(ax, x, runs, error, label: str) -> tuple[np.ndarray, np.ndarray]:
    """The FEM's mu_s at ``x`` (circles, with ``error`` bars where finite: filled where the
    bar, the certificate, is at most :data:`CERTIFIED_RELATIVE_ERROR` of mu_s, else hollow)
    and, for runs that failed before sliding inception, the F_t/F_n they reached (hollow
    triangles: mu_s is at least that); return both [-] (NaN where absent)."""
    x = np.asarray(x, dtype=float)
    mu_fem = np.array([fem_mu(run) for run in runs])
    at_least = np.array([fem_mu_at_least(run) for run in runs])
    error = np.asarray(error, dtype=float)
    bars = np.where(np.isfinite(error), error, 0.0)
    certified = np.isfinite(error) & (error <= CERTIFIED_RELATIVE_ERROR * mu_fem)
    uncertified = ~certified & np.isfinite(mu_fem)
    if np.isfinite(error).any():
        label += " (on a 2x finer mesh where barred; bar: its certified error)"
    for points, style, text in ((certified, {}, label),
                                (uncertified, {"mfc": "none"}, label + UNCERTIFIED)):
        if points.any():
            ax.errorbar(x[points], mu_fem[points], yerr=bars[points], fmt="ko", ms=5, capsize=3,
                        label=text, **style)
    if np.isfinite(at_least).any():
        ax.plot(x, at_least, "k^", mfc="none", label="FEM failed before inception: $\\mu_s \\geq$")
    return mu_fem, at_least


def surface_title(name: str) -> str:
    return f"{name} (stand-in)" if name in STAND_INS else name


def psi_sweep_cases(load: float, n: int) -> list:
    """Sliding runs of G1–G9 at F* = ``load``; at the :data:`ERROR_BAR_LOADS` the same on a 2x
    finer mesh; at the :data:`WINDOW_SCATTER_LOADS` those of the windows on each surface's
    diagonal (``studies.paper.window_cases``), surface by surface."""
    cases = [fem_case(name, load, n) for name in GAUSSIAN_SURFACES]
    if load in ERROR_BAR_LOADS:
        cases += [next_mesh(case) for case in cases]
    if load in WINDOW_SCATTER_LOADS:
        cases += [case for name in GAUSSIAN_SURFACES for case in window_cases(name, load, n)]
    return cases


def draw_window_scatter(ax, psi, runs) -> dict:
    """mu_s of the windows on each surface's diagonal (grey bars at the surface's psi; ``runs``
    surface by surface, at least one each) and their range per surface, as CSV columns (NaN
    without a converged window) [-]."""
    per_surface = len(runs) // len(psi)
    mu = np.array([fem_mu(run) for run in runs], dtype=float).reshape(len(psi), per_surface)
    ax.plot(np.repeat(psi, per_surface), mu.ravel(), "_", color="0.45", ms=9, mew=1.5,
            label=f"FEM, {per_surface} windows on the diagonal (1x mesh)")
    converged = np.isfinite(mu)
    low, high = ([reduce(row[ok]) if ok.any() else np.nan
                  for row, ok in zip(mu, converged, strict=True)] for reduce in (np.min, np.max))
    return {"fem_windows": converged.sum(axis=1), "mu_fem_windows_min": np.array(low),
            "mu_fem_windows_max": np.array(high)}


def psi_sweep(load: float, runs):
    """mu_s vs psi for G1–G9 at one load: FEM, multi-scale, CKE, LET (Figs. 22–25)."""
    material = Material()
    theory = [evaluate_theory(builtin_surface(name), load, material) for name in GAUSSIAN_SURFACES]
    psi = np.array([result.psi for result in theory])
    fig, ax = new_axes()
    coarse, others = runs[:len(psi)], runs[len(psi):]
    fine = [None] * len(psi)
    if load in ERROR_BAR_LOADS:
        fine, others = others[:len(psi)], others[len(psi):]
    runs, errors = error_bars(coarse, fine)
    mu_fem, at_least = draw_fem(ax, psi, runs, errors["mu_fem_error"], fem_label(coarse))
    columns = {
        "surface": np.array(GAUSSIAN_SURFACES),
        "psi": psi,
        "psi_fem": np.array([fem_psi(run) for run in coarse]),
        "mu_fem": mu_fem,
        **errors,
        "mu_fem_at_least": at_least,
        "fem_pressure_over_Sy": np.array([fem_contact_pressure(run) for run in runs]),
        "fem_cells_per_patch": np.array([fem_cells_per_patch(run) for run in runs]),
        "mu_multiscale": np.array([result.mu_s for result in theory]),
        "mu_cke": np.array([result.mu_cke for result in theory]),
        "cke_valid": np.array([result.cke_valid for result in theory]),
        "mu_let": np.array([result.mu_let for result in theory]),
        "let_valid": np.array([result.let_valid for result in theory]),
    }
    if others:
        columns |= draw_window_scatter(ax, psi, others)
    ax.plot(psi, columns["mu_multiscale"], "s-", color="C0", ms=4, label="multi-scale")
    draw_statistical(ax, psi, columns["mu_cke"], columns["cke_valid"], "CKE (Eq. 8)",
                     {"color": "C1", "marker": "^", "ms": 4})
    draw_statistical(ax, psi, columns["mu_let"], columns["let_valid"], "LET (Eq. 20)",
                     {"color": "C2", "marker": "v", "ms": 4})
    ax.set_xlabel("plasticity index ψ (–)")
    ax.set_ylabel("$\\mu_s$ (–)")
    ax.set_title(f"Static friction, G1–G9, $F^*$ = {load:g}")
    off = np.abs(columns["psi_fem"] / psi - 1.0) > PSI_TOLERANCE
    if off.any():
        ax.text(0.02, 0.02, "FEM meshed ψ: " + ", ".join(
            f"{name} {value:.3g}" for name, value in zip(columns["surface"][off],
                                                        columns["psi_fem"][off], strict=True)),
            transform=ax.transAxes, fontsize=6)
    ax.legend(fontsize=7)
    return fig, columns


def load_sweep_cases(name: str, n: int) -> list:
    """Sliding runs of surface ``name`` at the FEM loads of Figs. 26–28, then those at the
    :data:`ERROR_BAR_LOADS` on a 2x finer mesh."""
    cases = [fem_case(name, load, n) for load in FEM_LOAD_SWEEP]
    return cases + [next_mesh(case) for case in cases
                    if case.loading.load_star in ERROR_BAR_LOADS]


def load_sweep(name: str, runs):
    """mu_s vs F* for one surface: FEM, multi-scale, LET (Figs. 26–28)."""
    material = Material()
    surface = builtin_surface(name)
    scales = scale_decomposition(surface)
    psi = surface_statistics(surface, material).psi
    theory = [evaluate_theory(surface, load, material, scales=scales, psi=psi)
              for load in LOAD_SWEEP]
    loads = np.array(LOAD_SWEEP)
    mu_let = np.array([result.mu_let for result in theory])
    let_valid = np.array([result.let_valid for result in theory])
    coarse, refined = runs[:len(FEM_LOAD_SWEEP)], iter(runs[len(FEM_LOAD_SWEEP):])
    runs, errors = error_bars(coarse, [next(refined) if load in ERROR_BAR_LOADS else None
                                       for load in FEM_LOAD_SWEEP])
    fem_loads = np.array([run.load_star for run in coarse])
    psi_fem = np.array([fem_psi(run) for run in coarse])
    fig, ax = new_axes()
    mu_fem, at_least = draw_fem(ax, fem_loads, runs, errors["mu_fem_error"], fem_label(coarse))
    ax.plot(loads, [result.mu_s for result in theory], "s-", color="C0", ms=4,
            label="multi-scale")
    draw_statistical(ax, loads, mu_let, let_valid, "LET (Eq. 20)",
                     {"color": "C2", "marker": "v", "ms": 4})
    ax.set_xscale("log")
    ax.set_xlabel("$F^* = F_n / (A_n S_y)$ (–)")
    ax.set_ylabel("$\\mu_s$ (–)")
    meshed = psi_fem[np.isfinite(psi_fem)]
    title = f"Static friction vs load, {surface_title(name)}, ψ = {psi:.3g}"
    if meshed.size and abs(meshed[0] / psi - 1.0) > PSI_TOLERANCE:
        title += f"\n(FEM meshed ψ = {meshed[0]:.3g})"
    ax.set_title(title)
    ax.legend(fontsize=7)
    notes = ["" if valid else "outside its range" for valid in let_valid]
    fem_notes = ["" if np.isfinite(mu) else
                 f"failed before sliding inception: mu_s >= {bound:.4g}" if np.isfinite(bound)
                 else "no sliding inception" for mu, bound in zip(mu_fem, at_least, strict=True)]
    columns = {
        "model": np.array(["fem"] * len(runs) + ["multiscale"] * len(loads) + ["let"] * len(loads)),
        "load_star": np.concatenate([fem_loads, loads, loads]),
        "psi_fem": np.concatenate([psi_fem, np.full(2 * len(loads), np.nan)]),
        "mu_s": np.concatenate([mu_fem, [result.mu_s for result in theory], mu_let]),
        **{key: np.concatenate([values, np.full(2 * len(loads),
                                                "" if values.dtype.kind == "U" else np.nan)])
           for key, values in errors.items()},
        "fem_pressure_over_Sy": np.concatenate([[fem_contact_pressure(run) for run in runs],
                                                np.full(2 * len(loads), np.nan)]),
        "fem_cells_per_patch": np.concatenate([[fem_cells_per_patch(run) for run in runs],
                                               np.full(2 * len(loads), np.nan)]),
        "note": np.array(fem_notes + [""] * len(loads) + notes),
    }
    return fig, columns
