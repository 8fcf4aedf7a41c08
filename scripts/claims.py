"""The paper's statements about Figs. 15 and 20-29, checked against our figures' CSVs.

``roughfriction figure claims`` reads ``figures/figNN.csv`` (written by ``make figures``) and
writes ``figures/claims.md``: one row per statement, with the paper's words, our numbers and
whether they agree. A figure whose CSV is missing, or whose FEM values are missing, gives a row
that says so instead of a verdict. Where a FEM point has a certificate (``mu_fem_error``), a
comparison of the FEM with the model is decided only by the points that differ beyond their
bars; the rest give "within the bars".
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from roughfriction.scripts.figures import read_table

#: Junction growth of the paper's 2L at F* = 0.5 (Fig. 15) [-].
PAPER_JUNCTION_GROWTH = 0.1875
#: A_r/A_n at or above which a surface counts as completely flattened [-].
COMPLETE_CONTACT = 0.99
#: Largest max/min ratio of mu_s over the loads for "nearly constant" [-].
NEARLY_CONSTANT = 1.25
#: Loads F* at or below which "low load" holds (the paper: FEM above the model there) [-].
LOW_LOAD = 0.155


def _falls(values: np.ndarray) -> str:
    """'k of m steps fall' along ``values`` (finite ones, in order)."""
    values = values[np.isfinite(values)]
    steps = np.diff(values)
    return f"{int(np.sum(steps < 0))} of {len(steps)} steps fall"


def _series(values: np.ndarray) -> str:
    return " / ".join("–" if not np.isfinite(v) else f"{v:.3g}" for v in values)


def _row(figure: str, paper: str, ours: str, agrees: bool | str | None) -> tuple:
    """A claims row; ``agrees`` True, False, None (no verdict) or a verdict of its own."""
    verdict = agrees if isinstance(agrees, str) else {True: "yes", False: "no", None: "—"}[agrees]
    return figure, paper, ours, verdict


#: Verdict of a comparison that the FEM points' bars leave open.
WITHIN_BARS = "within the bars"


def _with_bars(values: np.ndarray, bars: np.ndarray) -> str:
    """'0.206±0.003 / ...' (a value without a finite bar alone)."""
    return " / ".join("–" if not np.isfinite(v) else f"{v:.3g}" if not np.isfinite(e)
                      else f"{v:.3g}±{e:.2g}" for v, e in zip(values, bars, strict=True))


def above_model(fem: np.ndarray, bars: np.ndarray, theory: np.ndarray) -> dict:
    """How many FEM points [-] lie above the model beyond their bar, within it, and below it
    beyond it (a point without a bar counts by its value alone)."""
    bars = np.nan_to_num(bars)
    finite = np.isfinite(fem) & np.isfinite(theory)
    return {"above": int(np.sum(finite & (fem - bars > theory))),
            "within": int(np.sum(finite & (np.abs(fem - theory) <= bars))),
            "below": int(np.sum(finite & (fem + bars < theory)))}


def _fem_errors(t: dict) -> np.ndarray:
    """The FEM points' certificates [-] (NaN where none, or the CSV has none)."""
    if "mu_fem_error" in t:
        return np.asarray(t["mu_fem_error"], float)
    return np.full(len(t.get("mu_fem", t.get("mu_s"))), np.nan)


def junction_growth(t: dict) -> list[tuple]:
    """Fig. 15: the 2L contact area grows from the preload to sliding inception."""
    area = t["area_ratio"]
    growth = area[-1] / area[0] - 1.0 if len(area) > 1 and area[0] > 0 else np.nan
    return [_row("15", f"2L junction growth {100 * PAPER_JUNCTION_GROWTH:.2f} %",
                 f"{100 * growth:+.1f} % (2L stand-in)",
                 None if not np.isfinite(growth) else bool(growth > 0))]


def area_trends(t: dict) -> list[tuple]:
    """Fig. 20: A_r/A_n falls with psi at each load; G1 flattened at F* = 1.86."""
    rows = []
    for load in np.unique(t["load_star"]):
        here = t["load_star"] == load
        areas = t["area_ratio"][here][np.argsort(t["psi"][here])]
        falls = np.sum(np.diff(areas) < 0)
        rows.append(_row("20", f"F* = {load:g}: A_r/A_n lower for larger ψ in most cases",
                         f"G1→G9: {_series(areas)} ({_falls(areas)})",
                         bool(falls > (len(areas) - 1) / 2)))
    at = (t["load_star"] == 1.86) & (t["surface"] == "G1")
    if at.any():
        area = float(t["area_ratio"][at][0])
        rows.append(_row("20", "G1 in complete contact at F* = 1.86", f"A_r/A_n = {area:.3f}",
                         area >= COMPLETE_CONTACT))
    return rows


def psi_sweep(t: dict, figure: str) -> list[tuple]:
    """Figs. 22-25: mu_s falls with psi (FEM and multi-scale); the multi-scale model lies
    below the FEM (Fig. 24: except the first point)."""
    fem, theory = t["mu_fem"], t["mu_multiscale"]
    rows = []
    for label, values in (("FEM", fem), ("multi-scale", theory)):
        finite = values[np.isfinite(values)]
        agrees = None if len(finite) < 2 else bool(finite[-1] < finite[0])
        rows.append(_row(figure, f"μ_s decreases as ψ increases ({label})",
                         f"G1→G9: {_series(values)} ({_falls(values)})", agrees))
    bars = _fem_errors(t)
    count = above_model(fem, bars, theory)
    points = sum(count.values())
    rows.append(_row(figure, "multi-scale below the FEM"
                     + (" except the first point" if figure == "24" else ""),
                     f"below at {count['above']} of {points} FEM points beyond their bars "
                     f"({count['within']} within, FEM below at {count['below']}); FEM/multi-scale "
                     f"{_with_bars(fem / theory, bars / theory)}",
                     model_below_verdict(count)))
    return rows


def model_below_verdict(count: dict) -> bool | str:
    """'multi-scale below the FEM' from :func:`above_model`'s counts: yes if it is below beyond
    the bars at all points but one, no if the FEM lies below it beyond them at two or more,
    else :data:`WITHIN_BARS`."""
    points = sum(count.values())
    if count["above"] >= points - 1:
        return True
    return False if count["below"] >= 2 else WITHIN_BARS


def psi_pair(t: dict) -> list[tuple]:
    """Fig. 22: mu_s of psi = 16.59 (G6) above that of psi = 13.20 (G5)."""
    g5, g6 = (np.flatnonzero(t["surface"] == name) for name in ("G5", "G6"))
    if not (len(g5) and len(g6)):
        return []
    rows = []
    for label, key in (("FEM", "mu_fem"), ("multi-scale", "mu_multiscale")):
        low, high = t[key][g5[0]], t[key][g6[0]]
        rows.append(_row("22", f"μ_s(ψ = 16.59) > μ_s(ψ = 13.20) ({label})",
                         f"G6 {high:.4g} vs G5 {low:.4g}", bool(high > low)))
    return rows


def load_sweep(t: dict, figure: str, name: str) -> list[tuple]:
    """Figs. 26-28: the multi-scale mu_s nearly constant in F*; the FEM approaching it at high
    load (Fig. 26: the FEM's mu_s falling with load)."""
    fem, theory = t["model"] == "fem", t["model"] == "multiscale"
    mu_theory = t["mu_s"][theory]
    spread = np.nanmax(mu_theory) / np.nanmin(mu_theory)
    rows = [_row(figure, f"{name}: multi-scale μ_s nearly constant in F*",
                 f"max/min {spread:.2f} over F* = {t['load_star'][theory].min():g}–"
                 f"{t['load_star'][theory].max():g}", bool(spread <= NEARLY_CONSTANT))]
    loads, mu_fem = t["load_star"][fem], t["mu_s"][fem]
    if figure == "26":
        rows.append(_row("26", "2L: FEM μ_s decreases with load",
                         f"F* {_series(loads)}: {_series(mu_fem)} ({_falls(mu_fem)})",
                         bool(np.nanargmax(mu_fem) < np.nanargmin(mu_fem))))
    model = np.interp(loads, t["load_star"][theory], mu_theory)
    bars = _fem_errors(t)[fem]
    rows += approach_rows(figure, name, loads, mu_fem, bars, model)
    low = loads <= LOW_LOAD
    if low.any():
        count = above_model(mu_fem[low], bars[low], model[low])
        rows.append(_row(figure, f"{name}: FEM above the model at low load",
                         f"F* {_series(loads[low])}: FEM/multi-scale "
                         f"{_with_bars(mu_fem[low] / model[low], bars[low] / model[low])} "
                         f"(above beyond the bar at {count['above']} of {sum(count.values())})",
                         above_verdict(count)))
    return rows


def approach_rows(figure: str, name: str, loads, mu_fem, bars, model) -> list[tuple]:
    """Figs. 26-28: |FEM/model - 1| at the lowest and highest FEM load, with the bars; yes or no
    where the two gaps differ beyond their bars, else :data:`WITHIN_BARS`."""
    gap, gap_bar = np.abs(mu_fem / model - 1.0), bars / model
    finite = np.flatnonzero(np.isfinite(gap))
    if len(finite) < 2:
        return []
    first, last = finite[0], finite[-1]
    bar = np.nan_to_num(gap_bar)  # a point without a bar counts by its value alone
    verdict = (True if gap[last] + bar[last] < gap[first] - bar[first]
               else False if gap[last] - bar[last] > gap[first] + bar[first] else WITHIN_BARS)
    return [_row(figure, f"{name}: FEM approaches the model at high load",
                 f"abs(FEM/multi-scale − 1) {_with_bars(gap[[first]], gap_bar[[first]])} at "
                 f"F* = {loads[first]:g}, {_with_bars(gap[[last]], gap_bar[[last]])} at "
                 f"{loads[last]:g}", verdict)]


def above_verdict(count: dict) -> bool | str:
    """'FEM above the model' from :func:`above_model`'s counts: yes if above beyond the bars at
    every point, no if below beyond them at any, else :data:`WITHIN_BARS`."""
    points = sum(count.values())
    if count["above"] == points:
        return True
    return False if count["below"] else WITHIN_BARS


def stiffness_order(t: dict, figure: str) -> list[tuple]:
    """Figs. 21 and 29: the first-step slope of F_t/F_n rises with psi against u_x/omega_0
    (Fig. 21) and falls with psi against u_x (Fig. 29)."""
    normalised = figure == "21"
    key = "ux_over_omega0" if normalised else "ux_m"
    names = list(dict.fromkeys(t["surface"]))
    slopes, psi = [], []
    for name in names:
        mine = t["surface"] == name
        x, y = t[key][mine], t["Ft_over_Fn"][mine]
        slopes.append(y[1] / x[1] if len(x) > 1 and x[1] > 0 else np.nan)
        psi.append(t["psi"][mine][0])
    trend = np.array(slopes)[np.argsort(psi)]
    rises = np.sum(np.diff(trend[np.isfinite(trend)]) > 0)
    steps = max(np.sum(np.isfinite(trend)) - 1, 0)
    agrees = rises > steps / 2 if normalised else rises < steps / 2
    return [_row(figure, ("higher ψ: larger initial tangential stiffness (normalised by ω_0)"
                          if normalised else
                          "lower ψ: larger initial tangential stiffness (not normalised)"),
                 f"G1→G9 first-step slope{'' if normalised else ' per m'}: {_series(trend)}",
                 bool(agrees))]


def claims(directory: Path) -> list[tuple]:
    """Every checked statement as (figure, the paper's claim, ours, agrees)."""
    tables = {number: read_table(path) for number in (15, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29)
              if (path := Path(directory) / f"fig{number}.csv").exists()}
    rows = junction_growth(tables[15]) if 15 in tables else []
    rows += area_trends(tables[20]) if 20 in tables else []
    for number in (22, 23, 24, 25):
        rows += (psi_sweep(tables[number], str(number)) if number in tables
                 else [_row(str(number), "(figure not drawn)", "", None)])
    rows += psi_pair(tables[22]) if 22 in tables else []
    if 22 in tables and 25 in tables:
        gaps = [np.nanmedian(np.abs(tables[k]["mu_fem"] / tables[k]["mu_multiscale"] - 1.0))
                for k in (22, 25)]
        rows.append(_row("22–25", "FEM and multi-scale closer at high load",
                         f"median |FEM/multi-scale − 1|: {gaps[0]:.2f} at 0.155, "
                         f"{gaps[1]:.2f} at 1.86", bool(gaps[1] < gaps[0])))
    for number, name in ((26, "2L"), (27, "8L"), (28, "G5")):
        rows += load_sweep(tables[number], str(number), name) if number in tables else []
    for number in (21, 29):
        rows += stiffness_order(tables[number], str(number)) if number in tables else []
    return rows


def write_claims(directory: Path) -> Path:
    """Write ``directory/claims.md`` (a Markdown table of :func:`claims`); return its path."""
    from roughfriction.files import atomic_write

    lines = ["| Fig. | the paper | ours | agrees |", "|---|---|---|---|"]
    lines += [f"| {figure} | {paper} | {ours} | {verdict} |"
              for figure, paper, ours, verdict in claims(directory)]
    path = Path(directory) / "claims.md"
    atomic_write(path, lambda tmp: Path(tmp).write_text("\n".join(lines) + "\n"))
    return path
