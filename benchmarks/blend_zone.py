"""The coarse blend zone against the fine one: the calibration set's windows and loads
(``benchmarks.calibration_set``) on levels 2x and 4x with the whole surface refined and the
blend zone below the fine layers at the previous level's cells (``MeshOptions.blend_zone =
"coarse"``). With the fine blend zone that mesh is the uniform ladder's level, whose rows
are in docs/bench/calibration_ladders.csv: the difference is what the coarse zone costs.

    mpirun -n 2 python -m benchmarks.blend_zone docs/bench/blend_zone.csv 1,2

Resumable and stamped like the calibration set (same columns).
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

#: Levels run by default (1: 2x, 2: 4x) [-].
BLEND_LEVELS = (1, 2)


def coarse_blend_case(case, level: int):
    """The case of ``level`` with every own cell refined (the uniform ladder's level-L layout)
    and the coarse blend zone (level 0: the case itself)."""
    import numpy as np
    from roughfriction.case import ZoneRefinement
    from roughfriction.studies.refinement import blend_depth_layers

    if level == 0:
        return case
    n = case.surface.n
    mesh = replace(case.mesh, blend_layers=blend_depth_layers(case), blend_zone="coarse",
                   refinement=ZoneRefinement(level, np.ones((n, n), dtype=bool)))
    return replace(case, mesh=mesh)


def main(argv: list[str] | None = None) -> int:
    """Run the comparison into the table given (default docs/bench/blend_zone.csv); a second
    argument lists the levels (e.g. ``1,2``)."""
    from mpi4py import MPI

    from benchmarks.calibration_set import run_set

    argv = sys.argv[1:] if argv is None else argv
    path = Path(argv[0] if argv else "docs/bench/blend_zone.csv")
    levels = tuple(int(level) for level in argv[1].split(",")) if len(argv) > 1 else BLEND_LEVELS
    run_set(path, MPI.COMM_WORLD, levels=levels, level_case=coarse_blend_case)
    return 0


if __name__ == "__main__":
    sys.exit(main())
