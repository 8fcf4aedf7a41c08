"""3-D view and contour map of a surface (the paper's Figs. 3–6)."""

import numpy as np
from roughfriction.geometry.generate import builtin_surface
from roughfriction.scripts.figures import new_axes, pyplot

UM = 1e-6


def _grid(name: str):
    surface = builtin_surface(name)
    x = np.arange(surface.n) * surface.spacing / UM
    return surface, x, surface.heights / UM


def _columns(surface, heights_um):
    """The height map as long-format columns: x [m], y [m], z [m]."""
    i, j = np.meshgrid(np.arange(surface.n), np.arange(surface.n), indexing="ij")
    return {"x_m": i.ravel() * surface.spacing, "y_m": j.ravel() * surface.spacing,
            "z_m": heights_um.ravel() * UM}


def surface_3d(name: str):
    """Three-dimensional plot of built-in surface ``name`` (Figs. 3 and 5)."""
    surface, x, z = _grid(name)
    fig = pyplot().figure(figsize=(5.0, 3.8), constrained_layout=True)
    ax = fig.add_subplot(projection="3d")
    xx, yy = np.meshgrid(x, x, indexing="ij")
    ax.plot_surface(xx, yy, z, cmap="viridis", linewidth=0, rcount=128, ccount=128)
    ax.set_xlabel("x (µm)")
    ax.set_ylabel("y (µm)")
    ax.set_zlabel("z (µm)")
    ax.set_title(f"Surface {name}, $R_q$ = {z.std():.3g} µm")
    return fig, _columns(surface, z)


def surface_contour(name: str):
    """Topographical contour plot of built-in surface ``name`` (Figs. 4 and 6)."""
    surface, x, z = _grid(name)
    fig, ax = new_axes(5.0, 4.1)
    filled = ax.contourf(x, x, z.T, levels=20, cmap="viridis")  # rows of z.T are y
    fig.colorbar(filled, ax=ax, label="z (µm)")
    ax.set_aspect("equal")
    ax.grid(False)
    ax.set_xlabel("x (µm)")
    ax.set_ylabel("y (µm)")
    ax.set_title(f"Surface {name}")
    return fig, _columns(surface, z)
