"""Fig. 19: tangential load vs load iteration of the multi-scale friction model, 2L, F* = 0.5."""

import numpy as np
from roughfriction.geometry.generate import builtin_surface
from roughfriction.material import Material
from roughfriction.multiscale.friction import static_friction
from roughfriction.multiscale.scales import scale_decomposition
from roughfriction.scripts.figures import new_axes

SURFACE = "2L"
LOAD = 0.5


def make():
    material = Material()
    result = static_friction(scale_decomposition(builtin_surface(SURFACE)), LOAD, material)
    ft_star = np.asarray(result.history) / (result.nominal_area * material.Sy)
    iterations = np.arange(1, len(ft_star) + 1)
    fig, ax = new_axes()
    ax.plot(iterations, ft_star, "o-")
    ax.set_xlabel("load iteration $j$")
    ax.set_ylabel("$F_t / (A_n S_y)$ (–)")
    ax.set_title(f"Load iteration, {SURFACE} (stand-in), $F^*$ = {LOAD}")
    ax.xaxis.get_major_locator().set_params(integer=True)
    return fig, {"iteration": iterations, "Ft_star": ft_star}
