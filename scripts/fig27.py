"""Fig. 27: mu_s vs F* for surface 8L: FEM, multi-scale, LET."""

from functools import partial

from roughfriction.scripts.comparison import load_sweep, load_sweep_cases
from roughfriction.studies.paper import LOAD_SWEEP_SURFACES

SURFACE = LOAD_SWEEP_SURFACES[1]
fem_cases = partial(load_sweep_cases, SURFACE)


def make(runs):
    """The figure, with the meshed-psi note of its title on a second line (fits the width)."""
    fig, columns = load_sweep(SURFACE, runs)
    ax = fig.axes[0]
    ax.set_title(ax.get_title().replace(" (FEM meshed", "\n(FEM meshed"))
    return fig, columns
