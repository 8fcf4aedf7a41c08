"""Fig. 14: contact area vs number of scale levels considered, at several loads, surface 2L."""

import numpy as np

from geometry.generate import builtin_surface
from multiscale.scales import scale_decomposition
from multiscale.stacking import normal_contact
from scripts.figures import new_axes
from solver.material import Material

SURFACE = "2L"
LOADS = (0.06, 0.155, 0.5, 0.93, 1.86)


def make():
    scales = scale_decomposition(builtin_surface(SURFACE))
    material = Material()
    fig, ax = new_axes()
    load_col, level_col, area_col = [], [], []
    for load in LOADS:
        contact = normal_contact(scales, load, material)
        levels = np.arange(1, len(contact.area_ratios) + 1)
        ax.semilogy(levels, contact.area_ratios, label=f"$F^*$ = {load}")
        load_col += [load] * len(levels)
        level_col += list(levels)
        area_col += list(contact.area_ratios)
    ax.set_xlabel("scale levels considered, $i$")
    ax.set_ylabel("contact area $A_i / A_n$ (–)")
    ax.set_title(f"Normal contact, surface {SURFACE} (stand-in)")
    ax.legend(fontsize=8)
    return fig, {"load_star": np.array(load_col), "scale_level": np.array(level_col),
                 "area_ratio": np.array(area_col)}
