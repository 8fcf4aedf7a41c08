"""Fig. 15: FEM contact area along the tangential loading, surface 2L (junction growth; the
paper reports +18.75 %)."""

import numpy as np
from roughfriction.scripts.fem_views import fem_label
from roughfriction.scripts.figures import new_axes
from roughfriction.studies.paper import JUNCTION_LOAD, JUNCTION_SURFACE, fem_case
from roughfriction.studies.post import interference, junction_growth, tangential_curve


def fem_cases(n):
    return [fem_case(JUNCTION_SURFACE, JUNCTION_LOAD, n)]


def make(runs):
    (run,) = runs
    curve = tangential_curve(run)
    slide = curve["ux_m"] / (interference(run) or np.nan)
    growth = junction_growth(run)
    fig, ax = new_axes()
    ax.plot(slide, curve["area_ratio"], "o-", ms=3, label=fem_label(runs))
    if growth["growth"] is not None:
        where = "at sliding inception" if growth["inception"] else "at the last step"
        ax.annotate(f"{100 * growth['growth']:+.1f} % {where}",
                    (slide[-1], curve["area_ratio"][-1]), textcoords="offset points",
                    xytext=(-10, -25), ha="right", fontsize=8)
    ax.set_xlabel("$u_x / \\omega_0$ (–)")
    ax.set_ylabel("$A_r / A_n$ (–)")
    ax.set_title(f"Junction growth, {JUNCTION_SURFACE} (stand-in), $F^*$ = {JUNCTION_LOAD}")
    ax.legend(fontsize=8)
    return fig, {"ux_m": curve["ux_m"], "ux_over_omega0": slide,
                 "area_ratio": curve["area_ratio"]}
