"""FEM runs drawn as the paper's Figs. 8–10, 15, 20, 21 and 29 (contact maps, patch counts,
contact area and tangential load along the loading), and one run's pictures for
``roughfriction post RUN --plot DIR``. Values come from the runs' results files through
``studies.post``; a run whose preload (or sliding) did not finish gives NaN there."""

import math
from pathlib import Path

import numpy as np
from roughfriction.errors import InputError
from roughfriction.geometry.generate import builtin_surface
from roughfriction.geometry.statistics import surface_statistics
from roughfriction.geometry.surface import Surface
from roughfriction.material import Material
from roughfriction.scripts.figures import PNG_DPI, new_axes, pyplot, save_png
from roughfriction.studies.post import interference, preload_state, tangential_curve

UM = 1e-6
NM = 1e-9
MPA = 1e6


def builtin_psi(name: str) -> float:
    """Plasticity index psi of built-in surface ``name`` on its own 128 x 128 grid [-]."""
    return surface_statistics(builtin_surface(name), Material()).psi


def fem_psi(run) -> float:
    """Plasticity index psi of the surface the run meshed (its N x N heights) [-]; NaN if the
    run did not record them."""
    heights = getattr(run, "maps", {}).get("surface_heights")
    if heights is None:
        return float("nan")
    return surface_statistics(Surface(heights, run.spacing), Material()).psi


def preload_value(run, key: str) -> float:
    """Column ``key`` of the step that completed the preload (NaN if it did not finish)."""
    state = preload_state(run)
    return float("nan") if state is None else float(state[key])


def fem_mu(run) -> float:
    """mu_s of a run [-]; NaN unless it converged to sliding inception."""
    mu_s = run.summary.get("mu_s")
    return float("nan") if mu_s is None else float(mu_s)


def fem_mu_at_least(run) -> float:
    """The largest F_t/F_n [-] a sliding run reached before it failed short of sliding
    inception (its mu_s is at least this); NaN for a run with a mu_s or without a sliding
    step."""
    if run.summary.get("mu_s") is not None or run.inputs["loading"]["normal_only"]:
        return float("nan")
    ratios = tangential_curve(run)["Ft_over_Fn"]
    return float(np.max(ratios)) if len(ratios) > 1 else float("nan")


def fem_contact_pressure(run) -> float:
    """Mean contact pressure at sliding inception over the yield strength, F_n / (A_s S_y) [-]
    (NaN without inception). Fully plastic contact of a blunt asperity carries about 3 S_y
    (Tabor's hardness); hardening allows more, so a value far above it is a hint, not proof,
    that the mesh does not resolve the patches (docs/verification.md)."""
    summary = run.summary
    if summary.get("mu_s") is None or not summary.get("area_ratio_sliding"):
        return float("nan")
    nominal_area = (run.n * run.spacing) ** 2
    return float(summary["Fn"] / (summary["area_ratio_sliding"] * nominal_area
                                  * run.inputs["material"]["Sy"]))


def fem_cells_per_patch(run) -> float:
    """Contact area per patch in grid cells at inception (else at the end of the preload) [-];
    fewer than 4 is the paper's inaccurate range (4 contact nodes per patch, its Fig. 10)."""
    value = run.summary.get("cells_per_patch")
    return float("nan") if value is None else float(value)


def fem_label(runs) -> str:
    """``FEM, N = 32`` (the runs' grid)."""
    return f"FEM, N = {runs[0].n}"


def patch_columns(runs) -> dict:
    """End-of-preload contact nodes, patches and nodes per patch of each run (Figs. 9, 10)."""
    return {
        "load_star": np.array([run.load_star for run in runs]),
        "contact_nodes": np.array([preload_value(run, "contact_nodes") for run in runs]),
        "contact_patches": np.array([preload_value(run, "contact_patches") for run in runs]),
        "nodes_per_patch": np.array([preload_value(run, "nodes_per_patch") for run in runs]),
    }


def map_extent(n: int, spacing: float) -> tuple:
    """imshow extent [µm] of an n x n map whose pixel (i, j) is centred on node x_i = i h,
    y_j = j h (``spacing`` h in m)."""
    h = spacing / UM
    return (-h / 2, (n - 0.5) * h) * 2


#: Least side of a map panel in the PNG [px] (at least one pixel per grid cell above it).
MAP_PANEL_PX = 600
#: Margins of a row of map panels [in]: left of the first, right of the last panel or colour
#: bar, below, above (titles), between panels, from the last panel to the first colour bar.
MAP_MARGINS_IN = {"left": 0.75, "right": 0.25, "bottom": 0.6, "top": 1.0, "between": 0.8,
                  "to_bar": 0.25}
#: Drawing order of maps: above the axes frame (2.5), which would hide a row of edge cells.
MAP_ZORDER = 3
#: Width of a colour bar [in], and the space each takes with its ticks and label [in].
COLOUR_BAR_IN = (0.15, 1.1)


def cell_pixels(n: int) -> int:
    """Whole PNG pixels per cell side of an n x n map [px]: panels of at least
    :data:`MAP_PANEL_PX`, and never less than one pixel per cell, so that no cell vanishes."""
    return max(1, math.ceil(MAP_PANEL_PX / n))


def map_figure(n: int, panels: int, colour_bars: int = 0):
    """A figure with a row of ``panels`` square axes for n x n maps, each exactly
    n :func:`cell_pixels` PNG pixels a side at whole-pixel positions (:data:`PNG_DPI`), and
    ``colour_bars`` axes for colour bars at the right.

    Returns
    -------
    fig, list of map axes, list of colour-bar axes
    """
    side = n * cell_pixels(n)
    margin = {key: round(inches * PNG_DPI) for key, inches in MAP_MARGINS_IN.items()}
    bar_width, bar_space = (round(inches * PNG_DPI) for inches in COLOUR_BAR_IN)
    bars_left = margin["left"] + panels * side + (panels - 1) * margin["between"] \
        + margin["to_bar"]
    width = bars_left + colour_bars * bar_space + margin["right"]
    height = margin["bottom"] + side + margin["top"]
    fig = pyplot().figure(figsize=(width / PNG_DPI, height / PNG_DPI), dpi=PNG_DPI)

    def column(left: int, wide: int):
        return fig.add_axes((left / width, margin["bottom"] / height, wide / width,
                             side / height))

    axes = [column(margin["left"] + k * (side + margin["between"]), side) for k in range(panels)]
    bars = [column(bars_left + k * bar_space, bar_width) for k in range(colour_bars)]
    for bar in bars:
        bar.grid(False)  # a colour bar draws no grid (the figures' style turns grids on)
    return fig, axes, bars


def show_map(ax, values: np.ndarray, spacing: float, **style):
    """Draw an n x n map ([i, j] at x = i h, y = j h; ``spacing`` h [m]) on ``ax`` in µm, one
    block of whole pixels per cell (nearest, not smoothed) above the axes frame: a single
    contact cell stays visible, also at the edge; ``style`` goes to imshow. Returns the
    image."""
    ax.grid(False)
    ax.set_xlabel("x (µm)")
    ax.set_ylabel("y (µm)")
    return ax.imshow(values.T, origin="lower", extent=map_extent(values.shape[0], spacing),
                     interpolation="nearest", aspect="auto", zorder=MAP_ZORDER, **style)


def contact_maps(runs):
    """Contact under the normal preload on the topography, one panel per run (Fig. 8)."""
    heights = runs[0].maps["surface_heights"]
    fig, axes, _ = map_figure(heights.shape[0], len(runs))
    i, j = np.indices(heights.shape)
    columns = {"x_m": (i * runs[0].spacing).ravel(), "y_m": (j * runs[0].spacing).ravel(),
               "z_m": heights.ravel()}
    from matplotlib.colors import ListedColormap

    for ax, run in zip(axes, runs, strict=True):
        contact = run.maps["contact_normal"]
        show_map(ax, heights / UM, run.spacing, cmap="Greys")
        show_map(ax, np.ma.masked_where(~contact, contact), run.spacing,
                 cmap=ListedColormap(["red"]))
        ax.set_title(f"{run.surface_name}, $F^*$ = {run.load_star:g}: "
                     f"{int(contact.sum())} contact nodes")
        columns[f"contact_F{run.load_star:g}"] = contact.ravel().astype(int)
    fig.suptitle(f"Contact (red) under normal load over the heights (dark = high), "
                 f"{fem_label(runs)}")
    return fig, columns


def tangential_curves(runs, normalised: bool):
    """F_t/F_n along the tangential loading of each run, against u_x/omega_0 (``normalised``,
    Fig. 21) or u_x (Fig. 29)."""
    fig, ax = new_axes()
    columns = {"surface": [], "psi": [], "psi_fem": [], "ux_m": [], "ux_over_omega0": [],
               "Ft_over_Fn": []}
    for run in runs:
        curve = tangential_curve(run)
        omega_0 = interference(run) or float("nan")
        psi = builtin_psi(run.surface_name)
        x = curve["ux_m"] / omega_0 if normalised else curve["ux_m"] / UM
        failed = "" if run.converged else " (failed)"
        ax.plot(x, curve["Ft_over_Fn"], ".-", ms=3,
                label=f"{run.surface_name}, ψ = {psi:.3g}{failed}")
        count = len(curve["ux_m"])
        columns["surface"] += [run.surface_name] * count
        columns["psi"] += [psi] * count
        columns["psi_fem"] += [fem_psi(run)] * count
        columns["ux_m"] += list(curve["ux_m"])
        columns["ux_over_omega0"] += list(curve["ux_m"] / omega_0)
        columns["Ft_over_Fn"] += list(curve["Ft_over_Fn"])
    ax.set_xlabel("$u_x / \\omega_0$ (–)" if normalised else "$u_x$ (µm)")
    ax.set_ylabel("$F_t / F_n$ (–)")
    ax.set_title(f"Tangential loading, $F^*$ = {runs[0].load_star:g}, {fem_label(runs)}")
    ax.legend(fontsize=7, ncols=2)
    return fig, {key: np.array(values) for key, values in columns.items()}


# --- one run's pictures (roughfriction post RUN --plot DIR) ---------------------------------


def last_step(run, phase: str) -> int | None:
    """Index of the run's last step of ``phase`` ("normal" or "tangential"), None without
    one."""
    steps = np.flatnonzero(run.steps["phase"] == phase)
    return int(steps[-1]) if steps.size else None


def contact_stages(run) -> list[tuple[str, str]]:
    """(map phase, panel title) of each contact state the run recorded: the end of the preload
    and sliding inception (or the last sliding step of a run that stopped short of it)."""
    steps = run.steps
    stages = []
    normal = last_step(run, "normal")
    if "contact_normal" in run.maps and normal is not None:
        reached = "End of preload" if preload_state(run) is not None else "Preload (unfinished)"
        stages.append(("normal", f"{reached}: $F_n$ = {steps['normal_force'][normal]:.3g} N"))
    sliding = last_step(run, "tangential")
    if "contact_sliding" in run.maps and sliding is not None:
        reached = ("Sliding inception" if run.summary.get("mu_s") is not None
                   else "Last sliding step (no inception)")
        ratio = steps["tangential_force"][sliding] / steps["normal_force"][sliding]
        stages.append(("sliding", f"{reached}: $u_x$ = {steps['slide'][sliding] / NM:.4g} nm, "
                       f"$F_t/F_n$ = {ratio:.3g}"))
    return stages


def run_contact_figure(run):
    """The contact pressure [MPa] at each recorded contact state (:func:`contact_stages`), one
    panel each, over the surface heights [µm] in grey, with a colour bar for each."""
    from matplotlib.colors import Normalize

    stages = contact_stages(run)
    heights = run.maps["surface_heights"] / UM
    fig, axes, bars = map_figure(heights.shape[0], len(stages), colour_bars=2)
    pressures = [run.maps[f"pressure_{phase}"] / MPA for phase, _ in stages]
    scale = Normalize(0.0, max(float(np.max(p)) for p in pressures))
    for ax, (phase, title), pressure in zip(axes, stages, pressures, strict=True):
        contact = run.maps[f"contact_{phase}"]
        topography = show_map(ax, heights, run.spacing, cmap="Greys", alpha=0.6)
        image = show_map(ax, np.ma.masked_where(~contact, pressure), run.spacing,
                         cmap="plasma", norm=scale)
        area = run.maps.get(f"contact_fraction_{phase}")
        area_text = f", $A_r/A_n$ = {np.mean(area):.3g}" if area is not None else ""
        ax.set_title(f"{title}\n{int(contact.sum())} contact nodes{area_text}", fontsize=9)
    fig.colorbar(image, cax=bars[0], label="contact pressure $p$ (MPa)")
    fig.colorbar(topography, cax=bars[1], label="surface height $z$ (µm)")
    fig.suptitle(f"Contact pressure over the surface heights: {run_label(run)}")
    return fig


def run_label(run) -> str:
    """``G5, F* = 0.155, N = 16`` (surface, load and grid of a run)."""
    return f"{run.surface_name}, $F^*$ = {run.load_star:g}, N = {run.n}"


def run_tangential_figure(run):
    """F_t/F_n [-] against the slide u_x [nm] from the end of the preload, with mu_s."""
    curve = tangential_curve(run)
    fig, ax = new_axes()
    ax.plot(curve["ux_m"] / NM, curve["Ft_over_Fn"], "o-", ms=3, label="FEM steps")
    mu_s = run.summary.get("mu_s")
    if mu_s is not None:
        ax.axhline(mu_s, color="C3", ls="--", lw=1, label=f"$\\mu_s$ = {mu_s:.3g} (inception)")
    ax.set_xlabel("slide of the flat $u_x$ (nm)")
    ax.set_ylabel("$F_t / F_n$ (–)")
    ax.set_ylim(bottom=0.0)
    ax.set_title(f"Tangential loading: {run_label(run)}")
    ax.legend(fontsize=8, loc="lower right")
    return fig


def write_run_plots(run, directory) -> list[Path]:
    """Draw a run (``roughfriction post RUN --plot DIR``): ``<run>_contact.png`` (contact at
    the end of the preload and at inception, :func:`run_contact_figure`) and
    ``<run>_tangential.png`` (:func:`run_tangential_figure`, if the run slid), each written
    atomically into ``directory``; return the files written.

    Raises
    ------
    InputError
        The run recorded neither a contact state nor a sliding step.
    """
    directory = Path(directory)
    figures = {}
    if contact_stages(run) and "surface_heights" in run.maps:
        figures["contact"] = run_contact_figure(run)
    if len(tangential_curve(run)["ux_m"]) > 1:
        figures["tangential"] = run_tangential_figure(run)
    if not figures:
        raise InputError(f"{run.path}: nothing to draw (no contact state and no sliding step "
                         "recorded)")
    return [save_png(fig, directory / f"{run.path.stem}_{name}.png")
            for name, fig in figures.items()]
