"""Newton loop of solver.equilibrium: convergence of its steps."""

from types import SimpleNamespace

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402
from roughfriction.case import FemCase, Loading, SolverOptions  # noqa: E402
from roughfriction.geometry.generate import builtin_surface  # noqa: E402
from roughfriction.geometry.surface import Surface, surface_on_fem_grid  # noqa: E402
from roughfriction.solver import equilibrium as equilibrium_module  # noqa: E402
from roughfriction.solver.contact import RigidFlat  # noqa: E402
from roughfriction.solver.equilibrium import Equilibrium  # noqa: E402
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

    def checked(self, normal_force, flat_slide, friction, hold_height=False, predictor=True,
                marks_path=False, exact_tangent=False):
        solved_with = self.flat.multiplier
        report = solve(self, normal_force, flat_slide, friction, hold_height, predictor,
                       marks_path, exact_tangent)
        carried = self.flat.multiplier
        if marks_path:
            self.flat.multiplier = solved_with
        if report.converged and report.iterations > 0:
            self.assemble(flat_slide, friction)
            self.assemble_tangent(report.contact)
            force_error = (0.0 if hold_height
                           else self.flat.normal_force(report.contact) - normal_force)
            self._bordered_solve(force_error, 1e-12)
            tolerance = (equilibrium_module.UZAWA_INCREMENT_TOLERANCE if marks_path
                         else self.options.increment_tolerance)
            moves.append(self._x1.norm(PETSc.NormType.NORM_INFINITY)
                         / (tolerance * self.spacing))
            loose.append(marks_path)
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
        report = equilibrium.solve(aim, 0.0, False, hold_height=True)
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
    where a node penetrates deeper than the tolerance (within ``CARRIED_PENETRATION`` times
    it: all of them here), the multipliers are updated to its pressures, and the next step
    starts from them instead of a re-solve of this one. Steps solved to the end (the last
    preload step, inception) still meet the penetration tolerance. G5 re-gridded to 16 x 16
    at F* = 0.5."""
    solve, newton = Equilibrium.solve, Equilibrium._newton
    calls, path_steps, final_steps = [0], [], []

    def counted(self, *args, **kwargs):
        calls[0] += 1
        return newton(self, *args, **kwargs)

    def spied(self, normal_force, flat_slide, friction, hold_height=False, predictor=True,
              marks_path=False, exact_tangent=False):
        calls[0] = 0
        report = solve(self, normal_force, flat_slide, friction, hold_height, predictor,
                       marks_path, exact_tangent)
        penetration = self.flat.penetration(report.contact) / self.spacing
        if marks_path:
            updated = np.array_equal(self.flat.multiplier, report.contact.node_pressure)
            path_steps.append((calls[0], penetration, updated))
        elif report.converged:
            final_steps.append(penetration)
        return report

    monkeypatch.setattr(Equilibrium, "_newton", counted)
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

    def spy(flat, *args, **kwargs):
        response = respond(flat, *args, **kwargs)
        exact_while_coupled.append(response.coupled and not flat.symmetric_tangent)
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
    height_slope, line_search = Equilibrium._height_slope, Equilibrium._line_search
    flipped, symmetric_after = [], []

    def singular_once(self):
        slope = height_slope(self)
        if not self._symmetric and not flipped:
            flipped.append(True)  # the first exact tangent of the run
        return abs(slope) if flipped and not symmetric_after and not self._symmetric else slope

    def spy(self, *args, **kwargs):
        if flipped:
            symmetric_after.append(self.flat.symmetric_tangent)
        return line_search(self, *args, **kwargs)

    monkeypatch.setattr(Equilibrium, "_height_slope", singular_once)
    monkeypatch.setattr(Equilibrium, "_line_search", spy)
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


def test_the_forcing_term_is_never_tighter_than_the_newton_tolerance_needs():
    """Far from the solution the Krylov tolerance is 0.1 x the relative residual, at most 1e-3;
    near it, half the Newton tolerance over the relative residual (at most 0.1): a solve to
    1e-6 F_n from 2e-6 F_n needs only a linear residual below 0.5e-6 F_n."""
    forcing = equilibrium_module.forcing_term
    contact = None
    assert forcing(equilibrium_module._Iterate(contact, 1.0, 0.0), 1.0, 1e-6) == 1e-3
    assert forcing(equilibrium_module._Iterate(contact, 1e-3, 0.0), 1.0, 1e-8) == (
        pytest.approx(1e-4))
    assert forcing(equilibrium_module._Iterate(contact, 1e-3, 0.0), 1.0, 1e-6) == (
        pytest.approx(5e-4))
    assert forcing(equilibrium_module._Iterate(contact, 1e-5, 1e-5), 1.0, 1e-6) == (
        pytest.approx(0.025))
    assert forcing(equilibrium_module._Iterate(contact, 1e-6, 1e-6), 1.0, 1e-6) == 0.1


def test_the_bordered_newton_direction_meets_its_krylov_tolerance(monkeypatch):
    """At every Newton iteration of a random 16 x 16 surface's preload and sliding, the
    direction (du, dh) of the bordered system leaves a linear residual ||K du + b dh + R|| of at
    most 2 x the forcing term x (||R|| + |r|) (x1's and x2's residuals, each within it): the
    height column, scaled by dh, would otherwise dominate it near convergence."""
    bordered_solve = Equilibrium._bordered_solve
    ratios = []

    def checked(self, force_error, tolerance):
        residual_norm = self.residual.norm() + abs(force_error)
        height_increment, krylov = bordered_solve(self, force_error, tolerance)
        if not self._hold_height and residual_norm > 0.0:
            linear = self._x1.duplicate()
            self.tangent.mult(self._x1, linear)  # K du
            linear.axpy(height_increment, self._height_column)  # + b dh
            linear.axpy(1.0, self.residual)  # + R
            ratios.append(linear.norm() / (tolerance * residual_norm))
            linear.destroy()
        return height_increment, krylov

    monkeypatch.setattr(Equilibrium, "_bordered_solve", checked)
    heights = np.random.default_rng(7).normal(0.0, 1e-7, (16, 16))
    case = FemCase(Surface(heights, 1e-6, "test"), Loading(0.5))
    result = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
    assert result.converged, result.message
    assert len(ratios) > 20
    assert max(ratios) <= 2.0, f"linear residual {max(ratios):.3g} x the forcing term"


@pytest.mark.parametrize("whole_mesh_yielding", [1.0, 0.0])
def test_the_tangent_is_the_reduced_solid_tangent_plus_the_contact_blocks(monkeypatch,
                                                                         whole_mesh_yielding):
    """At every Newton iteration of a random 16 x 16 surface's preload and sliding (yielding
    cells and touching nodes from the first steps on), the system matrix built from the reduced
    elastic part, the plastic correction reduced on its own cells (or, with any cell yielding,
    the whole tangent reduced on the whole mesh) and the blocks of the touching nodes equals
    P^T (K_elastic + K_plastic) P plus the blocks of every surface node, assembled on the full
    mesh, to round-off."""
    monkeypatch.setattr(equilibrium_module, "WHOLE_MESH_YIELDING", whole_mesh_yielding)
    from dolfinx.fem import petsc as fem_petsc

    assemble_tangent = Equilibrium.assemble_tangent
    differences, plastic_iterations = [], [0]

    def checked(self, contact):
        assemble_tangent(self, contact)
        full = self._elastic_tangent.duplicate(copy=True)
        plastic = self.solid.plastic_tangent_form()
        if plastic is not None:
            plastic_iterations[0] += 1
            fem_petsc.assemble_matrix(full, plastic)
        full.assemble()
        reduced = self.reduction.reduce_matrix(full)
        reference = self._system_matrix(reduced)
        reference.axpy(1.0, reduced, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        blocks = contact.node_stiffness[self.flat.owned_grid].transpose(0, 2, 1, 3)
        reference.setValuesBlockedRCV(self._contact_rows[:, :1] // 3, self._contact_columns,
                                      blocks.reshape(len(blocks), -1),
                                      addv=PETSc.InsertMode.ADD_VALUES)
        reference.assemble()
        scale = reference.norm(PETSc.NormType.FROBENIUS)
        reference.axpy(-1.0, self.tangent, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        differences.append(reference.norm(PETSc.NormType.FROBENIUS) / scale)
        for matrix in (full, reduced, reference):
            matrix.destroy()

    monkeypatch.setattr(Equilibrium, "assemble_tangent", checked)
    heights = np.random.default_rng(7).normal(0.0, 1e-7, (16, 16))
    case = FemCase(Surface(heights, 1e-6, "test"), Loading(0.5))
    result = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
    assert result.converged, result.message
    assert plastic_iterations[0] > 10 and len(differences) > 20
    assert max(differences) < 1e-13, f"the tangent differs by {max(differences):.2e} (Frobenius)"


class ScriptedNewton(Equilibrium):
    """The Newton loop of :class:`Equilibrium` over scripted iterates: each line search returns
    the next (step length, ||R|| / F_n) of ``script``; F_n = 1, h = 1, the contact set fixed,
    and every full step ``increment`` long [h].
    ``law`` maps a number of line searches done to ||R|| / F_n under the free contact law there
    (else the same as under the frozen set)."""

    def __init__(self, start: float, script: list, law: dict | None = None,
                 increment: float = 5e-5):
        self.options, self.spacing = SolverOptions(), 1.0
        self.linear_solver = SimpleNamespace(method="iterative")
        self.flat = SimpleNamespace(symmetric_tangent=True, count=np.count_nonzero)
        self._active, self._hold_height, self._coupled = None, True, False
        self._x1 = SimpleNamespace(norm=lambda kind: increment)  # max |du| of a full step [h]
        self._state = self._iterate(start)
        self._script = list(script)
        self._law, self._done = law or {}, 0

    @staticmethod
    def _iterate(residual: float):
        contact = SimpleNamespace(node_active=np.ones(4, dtype=bool))
        return equilibrium_module._Iterate(contact, residual, 0.0)

    def _evaluate(self, normal_force, flat_slide, friction, predictor):
        if self._active is None and self._done in self._law:
            return self._iterate(self._law[self._done])
        return self._state

    def assemble_tangent(self, contact):
        pass

    def _bordered_solve(self, force_error, tolerance):
        return 0.0, 1

    def _line_search(self, height_increment, current, normal_force, flat_slide, friction,
                     full_step):
        step, residual = self._script.pop(0)
        self._state = self._iterate(residual)
        self._done += 1
        return step, self._state


HALVING = [(0.5, 1.2e-5), (0.5, 6e-6), (0.5, 3e-6), (0.5, 1.5e-6), (1.0, 8e-7)]
FROZEN = [(0.5, 5e-5), (0.5, 3e-5), (0.5, 2e-5)] + HALVING


@pytest.mark.parametrize("start, script, law, tolerance, iterations, residual", [
    # tight: accepted at the first iterate within RESIDUAL_FLOOR after a cut step
    (2.5e-5, HALVING, None, 1e-6, 2, 6e-6),
    # ... also in the frozen round (from the 4th iteration), judged under the law
    (1e-4, FROZEN, None, 1e-6, 5, 6e-6),
    # ... where the law's residual is above the floor, the frozen round goes on
    (1e-4, FROZEN, {5: 5e-5}, 1e-6, 6, 3e-6),
    # a full step into the floor is Newton's quadratic regime: no early stop
    (2.5e-5, [(1.0, 6e-6), (1.0, 8e-7)], None, 1e-6, 2, 8e-7),
    # the path's loose solves (1e-4 F_n) go on to their tolerance: their floor would move
    # the path
    (2.5e-3, [(step, 100 * residual) for step, residual in HALVING], None, 1e-4, 5, 8e-5),
])
def test_a_tight_newton_solve_settles_at_the_floor_once_a_step_is_cut(
        start, script, law, tolerance, iterations, residual):
    """Equilibrium._newton accepts an iterate within RESIDUAL_FLOOR times its tolerances as soon
    as the line search has cut a step, in a solve tighter than the path's, judged under the
    contact law itself; otherwise it goes on to its tolerances."""
    newton = ScriptedNewton(start, script, law)
    report = newton._newton(1.0, 0.0, True, False, tolerance, 1e-4, False)
    assert report.converged
    assert report.iterations == iterations
    assert report.residual == pytest.approx(residual)


@pytest.mark.parametrize("tolerance, increment, iterations", [
    # tight: the forces meet their tolerance, the increment is within the floor: accepted
    (1e-6, 5e-4, 2),
    # ... an increment above the floor goes on (here to the iteration limit)
    (1e-6, 2e-3, None),
    # the path's loose solves (1e-4 F_n) go on to their tolerances
    (1e-4, 5e-4, None),
])
def test_a_tight_newton_solve_whose_forces_are_converged_settles_at_the_floor(
        tolerance, increment, iterations):
    """In a solve tighter than the path's, Equilibrium._newton accepts an iterate whose
    residuals meet their tolerance with an increment up to RESIDUAL_FLOOR times its own: full
    Newton steps whose increments do not shrink while the residual falls run along a direction
    the forces hardly constrain (G1 at F* = 0.155 on 256^2: 7.5e-4 h at 3.6e-8 F_n, 15
    iterations and a cut). Otherwise it goes on to its tolerances."""
    scale = tolerance / 1e-6
    script = [(1.0, scale * 2e-6 * 0.4**k) for k in range(20)]
    newton = ScriptedNewton(scale * 2.5e-5, script, increment=increment)
    report = newton._newton(1.0, 0.0, True, False, tolerance, 1e-4, False)
    assert report.converged == (iterations is not None), report.reason
    if iterations is not None:
        assert report.iterations == iterations
    else:
        assert "iteration limit" in report.reason


def kinked_slope(kink: float, soft: float, stiff: float, calls: list):
    """s(a) of a Newton step whose energy is quadratic with slope ``soft`` [J per unit step]
    up to a node touching the flat at a = ``kink``, ``stiff`` beyond; s(0) = -1 J. Records the
    step lengths it is called at."""
    def slope(step):
        calls.append(step)
        return -1.0 + soft * step + stiff * max(step - kink, 0.0)
    return slope


def test_a_line_search_takes_the_full_step_where_the_energy_is_quadratic():
    """An exact Newton step on a quadratic energy lands on its minimum: s(1) = 0."""
    calls = []
    step = equilibrium_module.line_search_step(kinked_slope(2.0, 1.0, 0.0, calls), -1.0)
    assert step == 1.0 and calls == [1.0]


@pytest.mark.parametrize("kink, stiff", [(0.3, 1e3), (0.05, 1e5), (0.9, 50.0)])
def test_a_line_search_stops_near_the_least_energy_past_a_contact_kink(kink, stiff):
    """A node that touches the flat part-way along the step (the penalty ~1e3 times stiffer
    than the solid): the step ends where |s| <= LINE_SEARCH_SLACK |s(0)|, just past the kink,
    within the trial budget, and the iterate is left there (the last call)."""
    calls = []
    slope = kinked_slope(kink, 0.5, stiff, calls)
    step = equilibrium_module.line_search_step(slope, -1.0)
    assert abs(slope(step)) <= equilibrium_module.LINE_SEARCH_SLACK
    assert calls[-2] == step and len(calls) - 1 <= 1 + equilibrium_module.LINE_SEARCH_TRIALS
    halved = 1.0  # what halving while the merit s^2 grows would have taken
    while kinked_slope(kink, 0.5, stiff, [])(halved) ** 2 >= 1.0 and halved > 1 / 32:
        halved /= 2
    assert abs(kinked_slope(kink, 0.5, stiff, [])(halved)) > abs(slope(step))


def test_a_line_search_bisects_where_the_residual_is_not_finite():
    """Past a = 0.6 the residual is not finite (inf); the root of s at a = 0.5 is found."""
    def slope(step):
        return np.inf if step > 0.6 else -1.0 + 2.0 * step
    step = equilibrium_module.line_search_step(slope, -1.0)
    assert abs(slope(step)) <= equilibrium_module.LINE_SEARCH_SLACK


def test_the_frictionless_newton_steps_descend_the_energy(monkeypatch):
    """Without friction the step problem minimises a convex energy whose gradient is (R, -r):
    every Newton step of a preload, held or force-controlled, is a descent direction,
    s(0) = du.R - dh r < 0, so its line search is the energy's (no fallback to halving)."""
    slopes = {True: [], False: []}
    original = Equilibrium._line_search

    def recorded(self, height_increment, current, normal_force, flat_slide, friction,
                 full_step):
        if not friction:
            slopes[self._hold_height].append(
                self._x1.dot(self.residual) - height_increment * current.force_error)
        return original(self, height_increment, current, normal_force, flat_slide, friction,
                        full_step)

    monkeypatch.setattr(Equilibrium, "_line_search", recorded)
    heights = np.random.default_rng(7).normal(0.0, 1e-7, (16, 16))
    for load in (0.05, 0.5):  # at 0.05 a step has du.R > 0 > du.R - dh r
        case = FemCase(Surface(heights, 1e-6, "test"), Loading(load, normal_only=True))
        result = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
        assert result.converged, result.message
    assert len(slopes[True]) > 3 and len(slopes[False]) > 3
    assert max(slopes[True] + slopes[False]) < 0.0
