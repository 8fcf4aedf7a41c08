"""FEM runs drawn as the paper's Figs. 8–10, 15, 20, 21 and 29: contact maps, patch counts,
contact area and tangential load along the loading. Values come from the runs' results files
through ``studies.post``; a run whose preload (or sliding) did not finish gives NaN there."""

import numpy as np
from roughfriction.geometry.generate import builtin_surface
from roughfriction.geometry.statistics import surface_statistics
from roughfriction.geometry.surface import Surface
from roughfriction.material import Material
from roughfriction.scripts.figures import new_axes
from roughfriction.studies.post import interference, preload_state, tangential_curve

UM = 1e-6


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


def contact_maps(runs):
    """Contact under the normal preload on the topography, one panel per run (Fig. 8)."""
    fig, axes = new_axes(4.2 * len(runs), 3.6, ncols=len(runs))
    heights = runs[0].maps["surface_heights"]
    i, j = np.indices(heights.shape)
    columns = {"x_m": (i * runs[0].spacing).ravel(), "y_m": (j * runs[0].spacing).ravel(),
               "z_m": heights.ravel()}
    from matplotlib.colors import ListedColormap

    h = runs[0].spacing / UM
    extent = (-h / 2, (heights.shape[0] - 0.5) * h) * 2  # pixel (i, j) centred on node x_i, y_j
    for ax, run in zip(np.atleast_1d(axes), runs, strict=True):
        contact = run.maps["contact_normal"]
        ax.imshow(heights.T / UM, origin="lower", extent=extent, cmap="Greys")
        ax.imshow(np.ma.masked_where(~contact.T, contact.T), origin="lower", extent=extent,
                  cmap=ListedColormap(["red"]))
        ax.grid(False)
        ax.set_xlabel("x (µm)")
        ax.set_ylabel("y (µm)")
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
