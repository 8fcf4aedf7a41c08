"""Fig. 9: number of contact patches and contact nodes vs F* under normal load, surface 8L."""

from roughfriction.scripts.fem_views import fem_label, patch_columns
from roughfriction.scripts.figures import new_axes
from roughfriction.studies.paper import PATCH_LOADS, fem_case

SURFACE = "8L"


def fem_cases(n):
    return [fem_case(SURFACE, load, n, normal_only=True) for load in PATCH_LOADS]


def make(runs):
    columns = patch_columns(runs)
    fig, ax = new_axes()
    ax.semilogy(columns["load_star"], columns["contact_nodes"], "o-", label="contact nodes")
    ax.semilogy(columns["load_star"], columns["contact_patches"], "s-",
                label="contact patches (local contact areas)")
    ax.set_xlabel("$F^* = F_n / (A_n S_y)$ (–)")
    ax.set_ylabel("count (–)")
    ax.set_title(f"Contact nodes and patches, {SURFACE}, {fem_label(runs)}")
    ax.legend(fontsize=8)
    return fig, columns
