"""solver.equilibrium: the iterate, its load steps (Newton with Uzawa updates) and the path
predictor, on whole runs."""

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402
from roughfriction.case import FemCase, Loading, SolverOptions  # noqa: E402
from roughfriction.geometry.generate import builtin_surface  # noqa: E402
from roughfriction.geometry.surface import Surface, surface_on_fem_grid  # noqa: E402
from roughfriction.solver import newton as newton_module  # noqa: E402
from roughfriction.solver.contact import FRICTIONLESS, RigidFlat, Tangent, Trial  # noqa: E402
from roughfriction.solver.equilibrium import Equilibrium  # noqa: E402
from roughfriction.solver.newton import Control, LoadStep, NewtonSolve  # noqa: E402
from roughfriction.solver.reduced_system import ReducedSystem  # noqa: E402
from roughfriction.solver.run import run  # noqa: E402
from roughfriction.solver.stepping import LoadPath  # noqa: E402

pytestmark = pytest.mark.fem


def test_a_converged_step_is_one_newton_increment_from_the_solution(monkeypatch):
    """Every load step a Newton solve accepts (preload and sliding of a random 16 x 16
    surface, a residual tolerance loose enough for the increment test to decide, Newton stopping
    at looser tolerances between Uzawa updates) is within its increment tolerance of the
    solution (the looser one for a step that marks the path): one more exact Newton step moves
    no node further. A step that marks the path is one Newton solve, judged with the
    multipliers it was solved with: an update it carries is the next step's to absorb."""
    solve = Equilibrium.solve
    moves, loose = [], []

    def checked(self, step):
        solved_with = self.flat.multiplier
        report = solve(self, step)
        carried = self.flat.multiplier
        if step.marks_path:
            self.flat.multiplier = solved_with
        if report.converged and report.iterations > 0:
            self.assemble(step.flat_slide, Trial(step.frictional))
            self.assemble_tangent(report.contact)
            force_error = (0.0 if step.hold_height
                           else self.flat.normal_force(report.contact) - step.normal_force)
            self.system.bordered_solve(force_error, 1e-12, step.hold_height)
            tolerance = (newton_module.DEFAULT_OPTIONS.uzawa_increment_tolerance if step.marks_path
                         else self.options.increment_tolerance)
            moves.append(self.system.x1.norm(PETSc.NormType.NORM_INFINITY)
                         / (tolerance * self.spacing))
            loose.append(step.marks_path)
        self.flat.multiplier = carried
        return report

    monkeypatch.setattr(Equilibrium, "solve", checked)
    heights = np.random.default_rng(7).normal(0.0, 1e-7, (16, 16))
    case = FemCase(Surface(heights, 1e-6, "test"), Loading(0.5),
                   solver=SolverOptions(residual_tolerance=1e-5))
    result = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
    assert result.converged, result.message
    assert len(moves) > 5 and not all(loose) and any(loose)
    assert max(moves) <= 1.0, f"a converged step moved {max(moves):.3g} x the tolerance"


def test_the_path_slope_is_the_derivative_of_the_held_force(monkeypatch, only_mark_the_path):
    """Equilibrium.path_slope, dF_n/dh along the equilibrium path of a held flat, matches the
    finite difference of the force carried at two held heights 0.1 % of the load apart, at
    every held preload step of an elastic random 16 x 16 surface (the tangent uses the
    penalty, the held solves converge their multipliers: measured within 0.07 % with tight held
    solves)."""
    aim_height = LoadPath._aim_height
    slopes = []

    def checked(self, aim):
        equilibrium = self.equilibrium
        slope = equilibrium.path_slope()
        height_change = 1e-3 * self.normal_force / slope
        equilibrium.flat_height += height_change  # (u from the committed step: Newton's work)
        report = equilibrium.solve(LoadStep(aim, control=Control.HEIGHT))
        assert report.converged, report.reason
        force = equilibrium.flat.normal_force(report.contact)
        slopes.append(((force - self.normal_force) / height_change, slope))
        equilibrium.restore()
        aim_height(self, aim)

    monkeypatch.setattr(LoadPath, "_aim_height", checked)
    # held steps end at the loose tolerances between Uzawa updates and carry their last update
    # into the next step: solve them to the solver's tolerances and multipliers, so that the
    # finite difference over 0.1 % of the load is neither the residual nor that update
    only_mark_the_path(lambda marks_path, friction, hold_height: False)
    heights = np.random.default_rng(3).normal(0.0, 1e-7, (16, 16))
    case = FemCase(Surface(heights, 1e-6, "test"), Loading(0.5, normal_only=True),
                   solver=SolverOptions(elastic=True, normal_increments=8))
    result = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
    assert result.converged, result.message
    assert len(slopes) >= 2
    for finite_difference, slope in slopes:
        assert slope < 0.0
        assert finite_difference == pytest.approx(slope, rel=0.01)


def test_the_preload_holds_the_flat_until_its_last_step():
    """Every preload step but the last holds the flat at a height aimed at a load (the force it
    carries is below the target, not an aim); the last is force-controlled and carries F_n. G5
    re-gridded to 32 x 32 at F* = 0.155, whose first contact on 6 nodes the force-controlled
    preload of version 0.6 reached only after a cut, preloads without one."""
    case = FemCase(surface_on_fem_grid(builtin_surface("G5"), 32), Loading(0.155, normal_only=True))
    result = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
    assert result.converged, result.message
    normal = [record for record in result.records if record.phase == "normal"]
    assert len(normal) >= 3
    assert all(record.cuts == 0 for record in normal)
    target = case.nominal_area * 0.155 * case.material.Sy
    assert normal[-1].normal_force == pytest.approx(target, rel=1e-6)
    forces = [record.normal_force for record in normal]
    assert all(0 < a < b for a, b in zip(forces[:-1], forces[1:], strict=True))


def test_sliding_steps_before_inception_only_mark_the_path(only_mark_the_path):
    """The sliding steps before inception end at the looser tolerances of the solves between
    Uzawa updates, the inception step at the solver's: G5 re-gridded to 16 x 16 at F* = 0.5
    (plastic, several sliding steps) gives the same mu_s to 1e-4 as with every step solved to
    the solver's tolerances (measured on 64^2: 1e-5), in fewer Newton iterations."""
    case = FemCase(surface_on_fem_grid(builtin_surface("G5"), 16), Loading(0.5))
    loose = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
    only_mark_the_path(lambda marks_path, friction, hold_height: marks_path and not friction)
    reference = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
    assert loose.converged and reference.converged, (loose.message, reference.message)
    sliding = [record for record in loose.records if record.phase == "tangential"]
    assert len(sliding) >= 4
    assert loose.mu_s == pytest.approx(reference.mu_s, rel=1e-4)
    assert (sum(record.newton_iterations for record in sliding)
            < sum(record.newton_iterations for record in reference.records
                  if record.phase == "tangential"))


def test_a_step_that_marks_the_path_carries_its_multiplier_update(monkeypatch):
    """A step that marks the path (held preload, sliding before inception) is one Newton solve:
    where a node penetrates deeper than the tolerance (within
    ``NewtonOptions.carried_penetration`` times it: all of them here), the multipliers are
    updated to its pressures, and the next step starts from them instead of a re-solve of this
    one. Steps solved to the end (the last preload step, inception) still meet the penetration
    tolerance. G5 re-gridded to 16 x 16 at F* = 0.5."""
    solve, newton = Equilibrium.solve, NewtonSolve.run
    calls, path_steps, final_steps = [0], [], []

    def counted(self):
        calls[0] += 1
        return newton(self)

    def spied(self, step):
        calls[0] = 0
        report = solve(self, step)
        penetration = self.flat.penetration(report.contact) / self.spacing
        if step.marks_path:
            updated = np.array_equal(self.flat.multiplier, report.contact.node_pressure)
            path_steps.append((calls[0], penetration, updated))
        elif report.converged:
            final_steps.append(penetration)
        return report

    monkeypatch.setattr(NewtonSolve, "run", counted)
    monkeypatch.setattr(Equilibrium, "solve", spied)
    case = FemCase(surface_on_fem_grid(builtin_surface("G5"), 16), Loading(0.5))
    result = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
    assert result.converged, result.message
    tolerance = case.solver.penetration_tolerance
    assert all(solves == 1 for solves, _, _ in path_steps)
    deep = [updated for _, penetration, updated in path_steps if penetration > tolerance]
    assert deep and all(deep), "no path step penetrated, or its update was not kept"
    assert final_steps and max(final_steps) <= tolerance


def test_sliding_goes_on_with_the_exact_tangent_where_the_symmetric_one_stalls(monkeypatch):
    """G5 re-gridded to 4 x 4 and sampled on an 8 x 8 mesh, at F* = 0.155: many slipping points
    carry less than p_r, where the symmetric tangent (without dt/dp) converges only linearly
    (alone, it cuts the steps down until the slide hits its step limit). Newton goes on with the
    exact tangent there, and the slide reaches full slip without a cut."""
    from roughfriction.studies.refinement import refined_case

    case = refined_case(FemCase(surface_on_fem_grid(builtin_surface("G5"), 4), Loading(0.155)), 2)
    exact_while_coupled = []
    respond = RigidFlat.respond

    def spy(flat, displacement, flat_height, flat_slide, trial=FRICTIONLESS):
        response = respond(flat, displacement, flat_height, flat_slide, trial)
        exact_while_coupled.append(response.coupled and trial.tangent is Tangent.EXACT)
        return response

    monkeypatch.setattr(RigidFlat, "respond", spy)
    result = run(case, MPI.COMM_SELF, progress=lambda record: None).result
    assert result.converged, result.message
    assert any(exact_while_coupled)
    assert sum(record.cuts for record in result.records) == 0
    assert result.records[-1].slipping_nodes == result.records[-1].contact_nodes


def test_a_singular_exact_tangent_gives_way_to_the_symmetric_one_for_a_step(monkeypatch):
    """The case above, with the exact tangent's dr/dh made positive once (lowering the flat
    would unload it: singular, as the ramp's coupling can make it; seen at 128^2): that Newton
    step is not taken, the next is taken with the symmetric tangent, the ones after with the
    exact tangent again, and the run converges."""
    from roughfriction.studies.refinement import refined_case

    case = refined_case(FemCase(surface_on_fem_grid(builtin_surface("G5"), 4), Loading(0.155)), 2)
    height_slope, line_search = ReducedSystem.height_slope, NewtonSolve._line_search
    flipped, symmetric_after = [], []

    def singular_once(self):
        slope = height_slope(self)
        if not self.symmetric and not flipped:
            flipped.append(True)  # the first exact tangent of the run
        return abs(slope) if flipped and not symmetric_after and not self.symmetric else slope

    def spy(self, *args, **kwargs):
        if flipped:
            symmetric_after.append(self.trial.tangent is Tangent.SYMMETRIC)
        return line_search(self, *args, **kwargs)

    monkeypatch.setattr(ReducedSystem, "height_slope", singular_once)
    monkeypatch.setattr(NewtonSolve, "_line_search", spy)
    result = run(case, MPI.COMM_SELF, progress=lambda record: None).result
    assert result.converged, result.message
    assert flipped and symmetric_after[0], "the step along the singular tangent was taken"
    assert not all(symmetric_after), "the exact tangent did not come back"


def test_a_non_symmetric_tangent_is_preconditioned_by_the_uncoupled_tangent(monkeypatch):
    """The case above: every exact (non-symmetric) tangent reaches the linear solver with a
    preconditioning matrix that is symmetric and differs from it only in the ramp's coupling
    dt/dp, the shear rows' normal columns."""
    from roughfriction.solver.linear import LinearSolver
    from roughfriction.studies.refinement import refined_case
    from scipy import sparse

    def scipy_matrix(matrix):
        if matrix.getType() == PETSc.Mat.Type.PYTHON:  # a sum operator: its assembled sum
            summed = matrix.getPythonContext().assembled()
            result = scipy_matrix(summed)
            summed.destroy()
            return result
        return sparse.csr_matrix(matrix.getValuesCSR()[::-1], shape=matrix.getSize())

    checked = []
    set_operator = LinearSolver.set_operator

    def spy(solver, matrix, symmetric=True, preconditioning=None):
        if not symmetric:
            tangent, part = scipy_matrix(matrix), scipy_matrix(preconditioning)
            scale = abs(tangent).max()
            asymmetry = abs(part - part.T).max() / scale
            coupling = sparse.csr_matrix(tangent - part)
            coupling.data[abs(coupling.data) < 1e-12 * scale] = 0.0
            coupling.eliminate_zeros()
            rows, columns = coupling.nonzero()
            checked.append((asymmetry, coupling.nnz, np.all(rows % 3 != 2),
                            np.all(columns % 3 == 2)))
        set_operator(solver, matrix, symmetric, preconditioning)

    monkeypatch.setattr(LinearSolver, "set_operator", spy)
    case = refined_case(FemCase(surface_on_fem_grid(builtin_surface("G5"), 4), Loading(0.155)), 2)
    result = run(case, MPI.COMM_SELF, progress=lambda record: None).result
    assert result.converged, result.message
    assert checked
    for asymmetry, couplings, shear_rows, normal_columns in checked:
        assert asymmetry < 1e-12 and couplings > 0 and shear_rows and normal_columns


def test_the_frictionless_newton_steps_descend_the_energy(monkeypatch):
    """Without friction the step problem minimises a convex energy whose gradient is (R, -r):
    every Newton step of a preload, held or force-controlled, is a descent direction,
    s(0) = du.R - dh r < 0, so its line search is the energy's (no fallback to halving)."""
    slopes = {True: [], False: []}
    original = NewtonSolve._line_search

    def recorded(self, height_increment):
        if not self.step.frictional:
            slopes[self.step.hold_height].append(
                self.system.x1.dot(self.system.residual)
                - height_increment * self.state.force_error)
        return original(self, height_increment)

    monkeypatch.setattr(NewtonSolve, "_line_search", recorded)
    heights = np.random.default_rng(7).normal(0.0, 1e-7, (16, 16))
    for load in (0.05, 0.5):  # at 0.05 a step has du.R > 0 > du.R - dh r
        case = FemCase(Surface(heights, 1e-6, "test"), Loading(load, normal_only=True))
        result = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
        assert result.converged, result.message
    assert len(slopes[True]) > 3 and len(slopes[False]) > 3
    assert max(slopes[True] + slopes[False]) < 0.0


def test_a_failed_step_returns_to_the_committed_state():
    """A random 8 x 8 surface preloaded, then pressed further by a step that is thrown away:
    restore brings the displacement, the flat's height, the plastic and the contact history
    back to the committed step exactly; after a later commit, resume returns to the older
    committed state."""
    heights = np.random.default_rng(4).normal(0.0, 1e-7, (8, 8))
    case = FemCase(Surface(heights, 1e-6, "test"), Loading(0.3, normal_only=True))
    equilibrium = run(case, MPI.COMM_WORLD, progress=lambda record: None).equilibrium
    committed = equilibrium.committed_state()
    displacement = equilibrium.displacement.copy()
    height, plastic = equilibrium.flat_height, equilibrium.solid.committed
    history = equilibrium.flat.committed
    further = equilibrium.solve(LoadStep(2.0 * case.normal_force))  # moves u, h and lambda
    assert equilibrium.flat_height != height
    assert not np.array_equal(equilibrium.flat.multiplier, history.multiplier)
    equilibrium.restore()
    assert equilibrium.flat_height == height and equilibrium.solid.committed is plastic
    assert equilibrium.flat.committed is history
    np.testing.assert_array_equal(equilibrium.flat.multiplier, history.multiplier)
    np.testing.assert_array_equal(equilibrium.displacement.array, displacement.array)
    equilibrium.flat_height += 1e-9  # a later step, committed
    equilibrium.commit(further.contact)
    assert equilibrium.committed.flat_height != height
    assert equilibrium.flat.committed is not history
    equilibrium.resume(committed)
    assert equilibrium.flat_height == height and equilibrium.flat.committed is history
    assert equilibrium.solid.committed is plastic
    np.testing.assert_array_equal(equilibrium.displacement.array, displacement.array)
    equilibrium.destroy()
    displacement.destroy()
