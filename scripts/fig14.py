"""Fig. 14: contact area vs number of scale levels considered, at several loads, surface 2L,
with the FEM contact area under the same loads (normal load only) at the right."""

import numpy as np
from roughfriction.geometry.generate import builtin_surface
from roughfriction.material import Material
from roughfriction.multiscale.scales import scale_decomposition
from roughfriction.multiscale.stacking import normal_contact
from roughfriction.scripts.fem_views import fem_label, preload_value
from roughfriction.scripts.figures import new_axes
from roughfriction.studies.paper import fem_case

SURFACE = "2L"
LOADS = (0.06, 0.155, 0.5, 0.93, 1.86)


def fem_cases(n):
    return [fem_case(SURFACE, load, n, normal_only=True) for load in LOADS]


def make(runs):
    scales = scale_decomposition(builtin_surface(SURFACE))
    material = Material()
    fig, ax = new_axes(6.2, 3.6)
    load_col, level_col, area_col, fem_col = [], [], [], []
    for color, load, run in zip((f"C{k}" for k in range(len(LOADS))), LOADS, runs, strict=True):
        contact = normal_contact(scales, load, material)
        levels = np.arange(1, len(contact.area_ratios) + 1)
        fem_area = preload_value(run, "area_ratio")
        ax.semilogy(levels, contact.area_ratios, color=color, label=f"$F^*$ = {load}")
        ax.semilogy([levels[-1] + 3], [fem_area], "*", color=color, ms=9)
        load_col += [load] * len(levels)
        level_col += list(levels)
        area_col += list(contact.area_ratios)
        fem_col += [fem_area] * len(levels)
    ax.plot([], [], "k*", ms=9, label=f"{fem_label(runs)} (right)")
    ax.set_xlabel("scale levels considered, $i$")
    ax.set_ylabel("contact area $A_i / A_n$ (–)")
    ax.set_title(f"Normal contact, surface {SURFACE} (stand-in)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig, {"load_star": np.array(load_col), "scale_level": np.array(level_col),
                 "area_ratio": np.array(area_col), "fem_area_ratio": np.array(fem_col)}
