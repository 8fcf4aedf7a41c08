"""Fig. 10: contact nodes per contact patch vs F* under normal load, surface 8L (the paper
reads fewer than 4 nodes per patch as too coarse)."""

from roughfriction.scripts.fem_views import fem_label, patch_columns
from roughfriction.scripts.fig9 import SURFACE, fem_cases  # noqa: F401  (the same runs as Fig. 9)
from roughfriction.scripts.figures import new_axes


def make(runs):
    columns = patch_columns(runs)
    fig, ax = new_axes()
    ax.plot(columns["load_star"], columns["nodes_per_patch"], "o-", label=fem_label(runs))
    ax.axhline(4.0, color="k", ls=":", lw=1, label="4 nodes per patch")
    ax.set_yscale("log")  # patches merge at high load: ~5 to ~300 nodes per patch
    ax.set_xlabel("$F^* = F_n / (A_n S_y)$ (–)")
    ax.set_ylabel("contact nodes per patch $N_{pl} / N_A$ (–)")
    ax.set_title(f"Nodes per contact patch, {SURFACE} (stand-in)")
    ax.legend(fontsize=8)
    return fig, columns
