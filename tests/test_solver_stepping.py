"""The load path: preload steps (solver.stepping)."""

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
from mpi4py import MPI  # noqa: E402
from roughfriction.case import FemCase, Loading  # noqa: E402
from roughfriction.solver import stepping  # noqa: E402
from roughfriction.solver.progress import StepCut  # noqa: E402
from roughfriction.solver.run import run  # noqa: E402
from roughfriction.studies.paper import fem_surface  # noqa: E402


def test_a_held_preload_step_adds_at_most_the_increment_cap():
    """G7's 32^2 window at F* = 0.06: from first contact (0.09 F_n) the path slope is far too
    soft and a held step aimed along it carried 0.74 F_n (version 0.12.0). Such a step is cut
    and re-aimed from the attempt, so no step adds more than MAX_PRELOAD_INCREMENT F_n."""
    cuts = []
    case = FemCase(fem_surface("G7", 32), Loading(0.06, normal_only=True))
    result = run(case, MPI.COMM_SELF,
                 progress=lambda item: cuts.append(item) if isinstance(item, StepCut) else None
                 ).result
    assert result.converged, result.message
    loads = [record.normal_force for record in result.records]  # from first contact on
    largest = max(after - before for before, after in zip(loads, loads[1:], strict=False))
    assert largest <= stepping.MAX_PRELOAD_INCREMENT * loads[-1]
    assert any("carries" in cut.reason for cut in cuts)
