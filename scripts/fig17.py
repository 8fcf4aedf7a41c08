"""Fig. 17: contact area per scale under normal load only and at sliding inception, 2L, F* = 0.5."""

import numpy as np
from roughfriction.geometry.generate import builtin_surface
from roughfriction.material import Material
from roughfriction.multiscale.friction import static_friction
from roughfriction.multiscale.scales import scale_decomposition
from roughfriction.scripts.figures import new_axes

SURFACE = "2L"
LOAD = 0.5


def make():
    result = static_friction(scale_decomposition(builtin_surface(SURFACE)), LOAD, Material())
    levels = np.arange(1, len(result.area_ratios_normal) + 1)
    fig, ax = new_axes()
    ax.semilogy(levels, result.area_ratios_normal, "o-", ms=3, label="normal load only")
    ax.semilogy(levels, result.area_ratios_sliding, "s-", ms=3, label="sliding inception")
    ax.set_xlabel("scale level $i$")
    ax.set_ylabel("contact area $A_i / A_n$ (–)")
    ax.set_title(f"Junction growth per scale, {SURFACE} (stand-in), $F^*$ = {LOAD}")
    ax.legend()
    return fig, {"scale_level": levels, "area_ratio_normal": result.area_ratios_normal,
                 "area_ratio_sliding": result.area_ratios_sliding}
