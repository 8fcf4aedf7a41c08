"""How well a refinement zone built from one mesh's contact holds the contact of a mesh twice as
fine: the evidence behind the adaptive ladder's zone rule (``solver.run.near_flat``,
``studies.refinement.adaptive_level_case``).

From a coarse run and a run on a mesh twice as fine (uniform, the same bilinear surface), the
zone is the coarse grid's cells at the coarse run's contact nodes (at the preload or at
inception) dilated by a margin of cells (``geometry.adaptive.cells_at_nodes``): alone, with
the nodes the rigid flat overlaps on the undeformed surface at its lowest position, or (the
adaptive ladder's rule, ``geometry.adaptive.refinement_after``) with the cells at the nodes near
the flat (``solver.results.near_flat_nodes``) undilated. A fine contact node is *uncovered*
when a surface cell around it would stay coarse (``geometry.adaptive.uncovered_nodes``):
refining that zone alone would have missed it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from roughfriction.errors import InputError
from roughfriction.files import atomic_write
from roughfriction.geometry.adaptive import (
    overlapped_nodes,
    refinement_after,
    surface_levels,
    uncovered_nodes,
)
from roughfriction.solver.results import near_flat_nodes, touched_nodes

from benchmarks.fem import write_csv

#: Margins [cells of the coarse grid] tried by default.
MARGINS = (0, 1, 2, 3, 4, 5)
#: Zone rules: the margin dilates the contact (with the overlapped nodes), the ladder's rule
#: (last) adds the nodes near the flat undilated.
RULES = ("contact", "contact + overlap", "contact + near the flat")
#: Columns of the coverage table.
FIELDS = ("case", "rule", "margin", "zone_share", "uncovered", "fine_contact_nodes",
          "lowest_flat_m", "overlap_share", "physics")


def coverage_rows(coarse, fine, margins=MARGINS, label: str | None = None) -> list[dict]:
    """One row per zone rule and margin: the zone's share of the coarse cells [-] and the fine
    run's contact nodes it leaves uncovered [-]; with the coarse run's lowest flat height above
    the mean plane [m] and the share of its nodes the flat overlaps there [-].

    Parameters
    ----------
    coarse, fine : studies.post.RunFile
        Runs of one case on an N x N grid and on the 2N x 2N grid of the same surface, each
        with its ``surface_heights`` map.
    margins : sequence of int
        Margins [coarse cells].
    label : str, optional
        The case's name in the rows (default: surface, F* and the two grids).
    """
    if "surface_heights" not in coarse.maps or "surface_heights" not in fine.maps:
        raise InputError("both runs need their surface_heights map (results files written "
                         "by roughfriction fem or the run cache)")
    if "gap_normal" not in coarse.maps:
        raise InputError("the coarse run has no gap maps (results files of version 0.21 on): "
                         "run it again")
    heights = np.asarray(coarse.maps["surface_heights"], dtype=float)
    fine_heights = np.asarray(fine.maps["surface_heights"], dtype=float)
    n = heights.shape[0]
    if fine_heights.shape != (2 * n, 2 * n):
        raise InputError(f"the fine run's grid must be twice the coarse run's: "
                         f"{fine_heights.shape} against {heights.shape}")
    if not np.allclose(fine_heights[::2, ::2] - fine_heights.mean(), heights - heights.mean(),
                       rtol=0.0, atol=1e-9 * np.ptp(heights)):
        raise InputError("the two runs do not mesh the same surface")
    lowest = float(np.min(coarse.steps["flat_height"]))
    touched, overlapped = touched_nodes(coarse.maps), overlapped_nodes(heights, 0, lowest)
    near = near_flat_nodes(coarse.maps, heights, lowest)
    # per rule: the nodes dilated by the margin, and those that join undilated
    seeds = dict(zip(RULES, ((touched, None), (touched | overlapped, None), (touched, near)),
                     strict=True))
    fine_contact = touched_nodes(fine.maps)
    if label is None:
        label = (f"{coarse.inputs['surface']['name']} "
                 f"F*={coarse.inputs['loading']['load_star']:g}, {n}² -> {2 * n}²")
    common = {"fine_contact_nodes": int(np.count_nonzero(fine_contact)),
              "lowest_flat_m": lowest,
              "overlap_share": float(overlapped.mean())}
    rows = []
    for rule, (dilated, undilated) in seeds.items():
        for margin in margins:
            zone = refinement_after(None, dilated, margin, undilated).zone
            uncovered = uncovered_nodes(surface_levels(n, 1, zone), 1, fine_contact)
            rows.append({"case": label, "rule": rule, "margin": margin,
                         "zone_share": float(zone.mean()),
                         "uncovered": int(np.count_nonzero(uncovered)), **common})
    return rows


def write_rows(rows: list[dict], path: Path) -> Path:
    """Write the coverage rows as CSV, whole or not at all (``core.files.atomic_write``)."""
    atomic_write(path, lambda temporary: write_csv(rows, temporary, FIELDS))
    return Path(path)
