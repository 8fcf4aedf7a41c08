"""The load path: preload steps (solver.stepping)."""

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import pytest
from mpi4py import MPI  # noqa: E402
from roughfriction.case import FemCase, Loading, SolverOptions  # noqa: E402
from roughfriction.geometry.generate import builtin_surface  # noqa: E402
from roughfriction.geometry.surface import surface_on_fem_grid  # noqa: E402
from roughfriction.solver.equilibrium import Equilibrium  # noqa: E402
from roughfriction.solver.progress import StepCut  # noqa: E402
from roughfriction.solver.run import run  # noqa: E402
from roughfriction.studies.paper import fem_surface  # noqa: E402

pytestmark = pytest.mark.fem


def test_a_held_preload_step_adds_at_most_the_increment_cap():
    """G7's 32^2 window at F* = 0.06: from first contact (0.09 F_n) the path slope is far too
    soft and a held step aimed along it carried 0.74 F_n (version 0.12.0). Such a step is cut
    and re-aimed from the attempt, so no step adds more than max_preload_increment F_n."""
    cuts = []
    case = FemCase(fem_surface("G7", 32), Loading(0.06, normal_only=True))
    result = run(case, MPI.COMM_SELF,
                 progress=lambda item: cuts.append(item) if isinstance(item, StepCut) else None
                 ).result
    assert result.converged, result.message
    loads = [record.normal_force for record in result.records]  # from first contact on
    largest = max(after - before for before, after in zip(loads, loads[1:], strict=False))
    assert largest <= case.solver.max_preload_increment * loads[-1]
    assert any("carries" in cut.reason for cut in cuts)


def test_the_load_increments_stay_within_the_solver_options():
    """The largest preload and sliding increments are solver options (``bench path`` runs a
    finer path with them): G5 re-gridded to 16 x 16 at F* = 0.5, whose default path takes
    preload steps of up to 0.32 F_n and slides of 0.25 tau_c H / G, keeps to 0.2 F_n and
    0.05 tau_c H / G with those options."""
    options = SolverOptions(max_preload_increment=0.2, max_slide_increment=0.05)
    case = FemCase(surface_on_fem_grid(builtin_surface("G5"), 16), Loading(0.5), solver=options)
    result = run(case, MPI.COMM_SELF, progress=lambda item: None).result
    assert result.converged, result.message
    normal = [record.normal_force for record in result.records if record.phase == "normal"]
    slides = [0.0] + [record.slide for record in result.records if record.phase == "tangential"]
    material = case.material
    scale = material.tau_c * result.sizes["depth_m"] / material.shear_modulus  # tau_c H / G
    assert max(b - a for a, b in zip(normal, normal[1:], strict=False)) <= 0.2 * normal[-1]
    assert max(b - a for a, b in zip(slides, slides[1:], strict=False)) <= 0.05 * scale * (
        1 + 1e-12)


def test_the_preload_is_solved_to_the_end_only_where_the_run_ends_there(monkeypatch,
                                                                       only_mark_the_path):
    """The preload's last step marks the path where sliding follows from it, and is solved to
    the solver's tolerances where a normal-only run ends there. G5 re-gridded to 16 x 16 at
    F* = 0.5: the sliding run gives the same mu_s as with that step solved to the end, in
    fewer preload Newton iterations; the normal-only run ends within the penetration
    tolerance."""
    solve = Equilibrium.solve
    calls = []

    def spied(self, step):
        report = solve(self, step)
        if not step.frictional:
            calls.append((step.marks_path,
                          self.flat.penetration(report.contact) / self.spacing))
        return report

    monkeypatch.setattr(Equilibrium, "solve", spied)
    surface = surface_on_fem_grid(builtin_surface("G5"), 16)
    loose = run(FemCase(surface, Loading(0.5)), MPI.COMM_SELF, progress=lambda item: None).result
    assert loose.converged, loose.message
    assert calls and all(marks_path for marks_path, _ in calls)

    calls.clear()
    normal = FemCase(surface, Loading(0.5, normal_only=True))
    result = run(normal, MPI.COMM_SELF, progress=lambda item: None).result
    assert result.converged, result.message
    marks_path, penetration = calls[-1]
    assert not marks_path and penetration <= normal.solver.penetration_tolerance

    only_mark_the_path(lambda marks_path, friction, hold_height:
                       marks_path and (friction or hold_height))
    tight = run(FemCase(surface, Loading(0.5)), MPI.COMM_SELF, progress=lambda item: None).result
    assert tight.converged, tight.message

    def preload_iterations(result):
        return sum(record.newton_iterations + record.cut_iterations
                   for record in result.records if record.phase == "normal")

    assert loose.mu_s == pytest.approx(tight.mu_s, rel=1e-4)
    assert preload_iterations(loose) < preload_iterations(tight)
