"""Fig. 20: FEM contact area A_r/A_n under normal load vs F* for G1–G9."""

import numpy as np
from roughfriction.scripts.fem_views import builtin_psi, fem_label, fem_psi, preload_value
from roughfriction.scripts.figures import new_axes
from roughfriction.studies.paper import AREA_LOADS, GAUSSIAN_SURFACES, fem_case


def fem_cases(n):
    return [fem_case(name, load, n, normal_only=True)
            for name in GAUSSIAN_SURFACES for load in AREA_LOADS]


def make(runs):
    fig, ax = new_axes()
    columns = {"surface": [], "psi": [], "psi_fem": [], "load_star": [], "area_ratio": []}
    for name in GAUSSIAN_SURFACES:
        mine = [run for run in runs if run.surface_name == name]
        loads = [run.load_star for run in mine]
        areas = [preload_value(run, "area_ratio") for run in mine]
        psi = builtin_psi(name)
        ax.plot(loads, areas, "o-", ms=3, label=f"{name}, ψ = {psi:.3g}")
        columns["surface"] += [name] * len(mine)
        columns["psi"] += [psi] * len(mine)
        columns["psi_fem"] += [fem_psi(run) for run in mine]
        columns["load_star"] += loads
        columns["area_ratio"] += areas
    ax.set_xscale("log")
    ax.set_xlabel("$F^* = F_n / (A_n S_y)$ (–)")
    ax.set_ylabel("$A_r / A_n$ (–)")
    ax.set_title(f"Contact area under normal load, {fem_label(runs)}")
    ax.legend(fontsize=7, ncols=2)
    return fig, {key: np.array(values) for key, values in columns.items()}
