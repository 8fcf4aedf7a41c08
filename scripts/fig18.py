"""Fig. 18: shear stress per scale level at sliding inception, surface 2L, F* = 0.5.

Two curves: the paper's diagnostic tau_i = F_t / A_i on the area *before* junction growth at
scale i (Sect. 4.2, step 4b), and F_t / A_s,i on the area *after* growth. The first can exceed
tau_c on scales that still grow; the second rises to exactly tau_c at the finest scale.
"""

import numpy as np
from roughfriction.geometry.generate import builtin_surface
from roughfriction.material import Material
from roughfriction.multiscale.friction import static_friction
from roughfriction.multiscale.scales import scale_decomposition
from roughfriction.scripts.figures import new_axes

SURFACE = "2L"
LOAD = 0.5
MPA = 1e6


def make():
    material = Material()
    result = static_friction(scale_decomposition(builtin_surface(SURFACE)), LOAD, material)
    on_sliding_area = result.Ft_max / (result.nominal_area * result.area_ratios_sliding)
    levels = np.arange(1, len(result.shear_stresses) + 1)
    fig, ax = new_axes()
    ax.plot(levels, result.shear_stresses / MPA, "o-", ms=3,
            label="$\\tau_i = F_t / A_i$ (before growth, paper)")
    ax.plot(levels, on_sliding_area / MPA, "s-", ms=3, label="$F_t / A_{s,i}$ (after growth)")
    ax.axhline(material.tau_c / MPA, color="k", ls="--", lw=1, label="$\\tau_c = S_y/\\sqrt{3}$")
    ax.set_xlabel("scale level $i$")
    ax.set_ylabel("shear stress (MPa)")
    ax.set_title(f"Shear stress per scale, {SURFACE} (stand-in), $F^*$ = {LOAD}")
    ax.legend(fontsize=8)
    return fig, {"scale_level": levels, "shear_stress_Pa": result.shear_stresses,
                 "shear_on_sliding_area_Pa": on_sliding_area}
