"""Linear solves of solver.linear: GAMG with plain aggregation, the GMRES retry of a CG solve
that meets indefiniteness, the inexact solve kept at the iteration limit, the fallback to
factorisations."""

import math

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402
from roughfriction.solver.linear import (  # noqa: E402
    GMRES_RESTART,
    INEXACT_ACCEPTED,
    LinearSolveError,
    LinearSolver,
    factor_memory_mb,
    node_memory_available_gb,
)

pytestmark = pytest.mark.fem


def shifted_laplacian(size: int = 400, shift: float = 0.002) -> PETSc.Mat:
    """tridiag(-1, 2 - shift, -1): symmetric, with a few negative eigenvalues (the smallest
    of tridiag(-1, 2, -1) are (k pi / (size + 1))^2)."""
    matrix = PETSc.Mat().createAIJ([size, size], nnz=3, comm=MPI.COMM_SELF)
    for i in range(size):
        matrix.setValue(i, i, 2.0 - shift)
        for j in (i - 1, i + 1):
            if 0 <= j < size:
                matrix.setValue(i, j, -1.0)
    matrix.assemble()
    return matrix


def laplacian(size: int) -> PETSc.Mat:
    """tridiag(-1, 2, -1): symmetric positive definite, condition number ~ size^2."""
    return shifted_laplacian(size, shift=0.0)


def solve(matrix: PETSc.Mat) -> tuple[float, LinearSolver]:
    """Relative residual ||A x - b|| / ||b|| of the iterative solver's solution for b = 1, and
    the solver."""
    rhs = matrix.createVecLeft()
    rhs.set(1.0)
    solution, residual = rhs.duplicate(), rhs.duplicate()
    solver = LinearSolver(MPI.COMM_SELF, "iterative")
    solver.set_operator(matrix, symmetric=True)
    solver.solve(rhs, solution)
    matrix.mult(solution, residual)
    residual.axpy(-1.0, rhs)
    return residual.norm() / rhs.norm(), solver


def test_cg_meeting_an_indefinite_operator_is_retried_with_gmres():
    relative_residual, solver = solve(shifted_laplacian())
    assert relative_residual < 1e-7 and solver.fell_back == ""


def test_without_the_retry_the_solve_needs_factorisations(monkeypatch):
    monkeypatch.setattr("roughfriction.solver.linear.INDEFINITE", ())
    relative_residual, solver = solve(shifted_laplacian())
    assert "cg (iterative) DIVERGED_INDEFINITE_PC (-8)" in solver.fell_back
    assert relative_residual < 1e-7


def test_destroy_frees_the_ksp():
    solver = LinearSolver(MPI.COMM_SELF, "direct")
    solver.destroy()
    assert solver.ksp.handle == 0


def limited_solve(monkeypatch, iterations: int) -> tuple[LinearSolver, float]:
    """Unpreconditioned CG limited to ``iterations`` on a 1-D Laplacian (it reduces the
    residual slowly); return the solver and the relative residual of its solution."""
    monkeypatch.setattr("roughfriction.solver.linear.MAX_KRYLOV_ITERATIONS", iterations)
    matrix = laplacian(40)
    rhs = matrix.createVecLeft()
    rhs.setArray(np.sin(np.linspace(0.0, 40.0, 40)))
    solution, residual = rhs.duplicate(), rhs.duplicate()
    solver = LinearSolver(MPI.COMM_SELF, "iterative", relative_tolerance=1e-12)
    solver.ksp.getPC().setType("none")
    solver.set_operator(matrix, symmetric=True)
    solver.solve(rhs, solution)
    matrix.mult(solution, residual)
    residual.axpy(-1.0, rhs)
    return solver, residual.norm() / rhs.norm()


def test_a_solve_stopped_at_the_iteration_limit_is_kept_if_it_reduced_the_residual(monkeypatch):
    """35 CG iterations reduce the residual by more than INEXACT_ACCEPTED: kept as an inexact
    Newton direction, no fallback."""
    solver, relative_residual = limited_solve(monkeypatch, 35)
    assert 1e-12 < relative_residual <= INEXACT_ACCEPTED
    assert solver.fell_back == "" and solver.method == "iterative"


def test_a_failed_iterative_solve_falls_back_to_factorisations(monkeypatch):
    """2 CG iterations are not enough: the solver switches to MUMPS LU factors and solves."""
    solver, relative_residual = limited_solve(monkeypatch, 2)
    assert "DIVERGED_MAX_IT" in solver.fell_back and solver.method == "direct"
    assert relative_residual < 1e-10


def test_gamg_stays_definite_at_first_contact_of_a_refined_rough_surface(monkeypatch):
    """An 8 x 8 window of G7 on a 2x refined mesh, preloaded to F* = 0.155: a few penalised
    points on pyramid-tipped peaks. With Chebyshev bounds [0.2, 1.3] x lambda_max (10 estimate
    iterations) GAMG's smoother was indefinite there (4 failed Krylov solves, then the LU
    fallback); every solve must now converge with GAMG alone."""
    from roughfriction.case import FemCase, Loading
    from roughfriction.geometry.generate import builtin_surface
    from roughfriction.solver.run import run
    from roughfriction.studies.paper import surface_window
    from roughfriction.studies.refinement import next_mesh

    reasons = []
    apply = LinearSolver._apply

    def recorded(self, rhs, solution, fresh):
        apply(self, rhs, solution, fresh)
        reasons.append(self.ksp.getConvergedReason())

    monkeypatch.setattr(LinearSolver, "_apply", recorded)
    window = surface_window(builtin_surface("G7"), 8, 5)
    case = next_mesh(FemCase(window, Loading(0.155, normal_only=True)))
    outcome = run(case, MPI.COMM_SELF, progress=lambda record: None)
    assert outcome.result.converged and outcome.result.sizes["linear_solver_fallback"] == ""
    assert reasons and min(reasons) > 0


def skewed_laplacian(size: int, skew: float = 0.9) -> PETSc.Mat:
    """tridiag(-1 - s, 2, -1 + s): non-symmetric, far from its upper triangle's symmetric
    matrix."""
    matrix = PETSc.Mat().createAIJ([size, size], nnz=3, comm=MPI.COMM_SELF)
    for i in range(size):
        matrix.setValue(i, i, 2.0)
        if i > 0:
            matrix.setValue(i, i - 1, -1.0 - skew)
        if i < size - 1:
            matrix.setValue(i, i + 1, -1.0 + skew)
    matrix.assemble()
    return matrix

def wavy_rhs(matrix: PETSc.Mat) -> tuple[PETSc.Vec, PETSc.Vec]:
    """A smooth right-hand side sin(40 t) for ``matrix`` and a zero vector for the solution."""
    rhs = matrix.createVecLeft()
    rhs.setArray(np.sin(np.linspace(0.0, 40.0, rhs.getSize())))
    solution = rhs.duplicate()
    solution.set(0.0)
    return rhs, solution



def test_gmres_on_cholesky_factors_that_stalls_falls_back_to_lu(monkeypatch):
    """The direct method preconditions a non-symmetric operator with Cholesky factors of its
    upper triangle, which need not help: tridiag(-1 - s, 2, -1 + s) with s = 0.9 is far from
    its upper triangle's symmetric matrix, and 3 GMRES iterations on those factors do not reduce
    the residual 100x; the solver switches to LU factors and solves."""
    monkeypatch.setattr("roughfriction.solver.linear.MAX_KRYLOV_ITERATIONS", 3)
    size = 200
    matrix = skewed_laplacian(size)
    rhs, solution = wavy_rhs(matrix)
    residual = rhs.duplicate()
    solver = LinearSolver(MPI.COMM_SELF, "direct", relative_tolerance=1e-10)
    solver.set_operator(matrix, symmetric=False)
    solver.solve(rhs, solution)
    matrix.mult(solution, residual)
    residual.axpy(-1.0, rhs)
    assert "gmres (direct) DIVERGED_MAX_IT" in solver.fell_back
    assert solver.ksp.getPC().getType() == "lu"
    assert residual.norm() / rhs.norm() < 1e-10
    # the next symmetric operator gets Cholesky factors again (and solves in one iteration)
    solver.set_operator(laplacian(size), symmetric=True)
    assert solver.ksp.getPC().getType() == "cholesky" and solver.method == "direct"
    solver.solve(rhs, solution)
    assert solver.last_iterations == 1 and solver.fallbacks == 1


def test_gamg_returns_after_a_fallback_on_a_non_symmetric_operator(monkeypatch):
    """The iterative method's case (a sliding tangent at inception): GMRES with GAMG that
    stalls on a non-symmetric operator gives way to LU factors, and the next symmetric operator
    is solved with GAMG again."""
    monkeypatch.setattr("roughfriction.solver.linear.MAX_KRYLOV_ITERATIONS", 1)
    size = 200
    matrix = skewed_laplacian(size)
    rhs, solution = wavy_rhs(matrix)
    solver = LinearSolver(MPI.COMM_SELF, "iterative", relative_tolerance=1e-10)
    solver.set_operator(matrix, symmetric=False)
    solver.solve(rhs, solution)
    assert "gmres (iterative) DIVERGED_MAX_IT" in solver.fell_back
    assert solver.ksp.getPC().getType() == "lu" and solver.method == "direct"
    solver.set_operator(laplacian(size), symmetric=True)
    assert solver.ksp.getPC().getType() == "gamg" and solver.method == "iterative"
    assert solver.fallbacks == 1


def two_fields(size: int, coupling: float) -> PETSc.Mat:
    """[[L, c I], [0, L]] with L the 5-point Laplacian of a size x size grid: two fields, the
    first driven by the second (as a slipping point's shear by its pressure), non-normal for a
    large coupling c; c = 0 is its symmetric positive definite part."""
    cells = size * size
    matrix = PETSc.Mat().createAIJ([2 * cells, 2 * cells], nnz=6, comm=MPI.COMM_SELF)
    for field in range(2):
        for i, j in np.ndindex(size, size):
            row = field * cells + i * size + j
            matrix.setValue(row, row, 4.0)
            for a, b in ((i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)):
                if 0 <= a < size and 0 <= b < size:
                    matrix.setValue(row, field * cells + a * size + b, -1.0)
    if coupling:
        for row in range(cells):
            matrix.setValue(row, cells + row, coupling)
    matrix.assemble()
    return matrix


def two_field_solve(preconditioning: PETSc.Mat | None) -> LinearSolver:
    """The iterative solver after a GMRES solve of two_fields(64, 100) x = b to 1e-8, with
    the preconditioner built from ``preconditioning`` (default: the operator)."""
    matrix = two_fields(64, 100.0)
    rhs = matrix.createVecLeft()
    rhs.setArray(np.sin(np.linspace(0.0, 40.0, rhs.getSize())))
    solution, residual = rhs.duplicate(), rhs.duplicate()
    solver = LinearSolver(MPI.COMM_SELF, "iterative", relative_tolerance=1e-8)
    solver.set_operator(matrix, symmetric=False, preconditioning=preconditioning)
    solver.solve(rhs, solution)
    matrix.mult(solution, residual)
    residual.axpy(-1.0, rhs)
    assert residual.norm() / rhs.norm() < 1e-8
    return solver


def test_gmres_with_gamg_of_the_uncoupled_operator_solves_the_coupled_one():
    """The sliding tangent's case: GAMG built from the operator without its coupling (c = 0,
    symmetric positive definite) drives GMRES to the tolerance; GAMG built from the strongly
    coupled operator itself does not, and the solver falls back to LU factors."""
    uncoupled = two_fields(64, 0.0)
    solver = two_field_solve(uncoupled)
    assert solver.fallbacks == 0 and solver.ksp.getPC().getType() == "gamg"
    assert solver.ksp.getOperators()[1].handle == uncoupled.handle
    assert two_field_solve(None).fallbacks == 1


def test_gmres_keeps_its_krylov_vectors_past_petscs_default_restart(tmp_path):
    """GMRES restarts after ``GMRES_RESTART`` (PETSc's default, 30, stalls on the exact
    tangent at sliding inception) and orthogonalises again where needed, as the solver's own
    description states it."""
    solver = two_field_solve(two_fields(64, 0.0))
    viewer = PETSc.Viewer().createASCII(str(tmp_path / "ksp.txt"), comm=MPI.COMM_SELF)
    solver.ksp.view(viewer)
    viewer.destroy()
    description = (tmp_path / "ksp.txt").read_text()
    assert f"restart={GMRES_RESTART}," in description
    assert "iterative refinement when needed" in description


def test_a_new_preconditioning_matrix_rebuilds_and_lu_factors_the_operator():
    """A reused preconditioner keeps the matrix it was built from, so a new preconditioning
    matrix rebuilds it; LU factors (the fallback) are the operator's, not the symmetric
    part's."""
    size = 200
    matrix, symmetric_part = skewed_laplacian(size), laplacian(size)
    rhs, solution = wavy_rhs(matrix)
    solver = LinearSolver(MPI.COMM_SELF, "iterative", relative_tolerance=1e-6)
    for _ in range(2):
        solver.set_operator(symmetric_part, symmetric=True)
        solver.solve(rhs, solution)
    assert solver.rebuilds == 1
    solver.set_operator(matrix, symmetric=False, preconditioning=symmetric_part)
    solver.solve(rhs, solution)
    assert solver.rebuilds == 1  # the same preconditioning matrix
    solver.set_operator(matrix, symmetric=False, preconditioning=laplacian(size))
    solver.solve(rhs, solution)
    assert solver.rebuilds == 2
    solver.ksp.setTolerances(max_it=1)  # GMRES fails: LU factors
    solver.set_operator(matrix, symmetric=False, preconditioning=symmetric_part)
    solver.solve(rhs, solution)
    assert solver.ksp.getPC().getType() == "lu"
    assert solver.ksp.getOperators()[1].handle == matrix.handle
    solver.set_operator(matrix, symmetric=False, preconditioning=symmetric_part)
    assert solver.ksp.getOperators()[1].handle == matrix.handle


def test_lu_factors_over_their_memory_bound_fail_and_the_configured_method_returns(
        monkeypatch):
    """LU factors that need more than MUMPS's memory bound (here 1 MB) fail the solve
    (DIVERGED_PCSETUP_FAILED) instead of exhausting the node, and the next solves get the configured
    preconditioner; within the actual bound (:func:`factor_memory_mb`) the same fallback
    solves."""
    matrix = two_fields(64, 100.0)
    rhs = matrix.createVecLeft()
    rhs.setArray(np.sin(np.linspace(0.0, 40.0, rhs.getSize())))
    solution = rhs.duplicate()

    def solver() -> LinearSolver:
        solver = LinearSolver(MPI.COMM_SELF, "iterative", relative_tolerance=1e-8)
        solver.set_operator(matrix, symmetric=False)  # GAMG of the operator: LU fallback
        return solver

    within = solver()
    within.solve(rhs, solution)
    assert within.fallbacks == 1 and within.ksp.getPC().getType() == "lu"
    monkeypatch.setattr("roughfriction.solver.linear.factor_memory_mb", lambda comm: 1)
    over = solver()
    with pytest.raises(LinearSolveError, match="DIVERGED_PCSETUP_FAILED"):
        over.solve(rhs, solution)
    assert over.ksp.getPC().getType() == "gamg" and over.method == "iterative"


@pytest.mark.parametrize("available_gb, bound_mb", [(10.0, 8192), (0.5, 409), (math.inf, 0)])
def test_the_factors_memory_bound_is_a_share_of_the_nodes_available_memory(
        available_gb, bound_mb, monkeypatch):
    """0.8 of the node's available memory [GB] in MB, shared by the node's ranks (one here);
    no bound (0) where the memory cannot be read."""
    monkeypatch.setattr("roughfriction.solver.linear.node_memory_available_gb",
                        lambda: available_gb)
    assert factor_memory_mb(MPI.COMM_SELF) == bound_mb


def test_the_nodes_available_memory_is_read_from_proc_meminfo():
    assert 0 < node_memory_available_gb() < math.inf  # inf: unreadable (not Linux)


def test_a_fallback_on_a_symmetric_operator_keeps_the_factors(monkeypatch):
    """GAMG or CG that fail on a symmetric operator would fail again on the next: the LU
    factors stay."""
    solver, _ = limited_solve(monkeypatch, 2)
    solver.set_operator(laplacian(40), symmetric=True)
    assert solver.ksp.getPC().getType() == "lu" and solver.method == "direct"


def test_gamg_aggregates_without_smoothing_the_prolongator(tmp_path):
    """Plain aggregation (``GAMG_PROLONGATOR_SMOOTHINGS`` = 0, PETSc's default is 1), as the
    preconditioner's own description states it once built."""
    _, solver = solve(laplacian(400))
    viewer = PETSc.Viewer().createASCII(str(tmp_path / "ksp.txt"), comm=MPI.COMM_SELF)
    solver.ksp.view(viewer)
    viewer.destroy()
    description = (tmp_path / "ksp.txt").read_text()
    assert "type: gamg" in description
    assert "Number smoothing steps 0" in description


def test_an_operator_given_as_a_sum_is_solved_and_factored_as_its_sum():
    """The sliding tangent as the system passes it: GMRES on the sum of the symmetric part and
    the coupling (a python matrix, :func:`solver.reduced_system.sum_operator`), GAMG built
    from the symmetric part; when GMRES fails (here: one iteration allowed) the LU factors are
    of the assembled sum, which then solves the coupled system, and stay the same matrix for
    the next operator."""
    from roughfriction.solver.reduced_system import sum_operator

    coupled = two_fields(64, 100.0)
    coupling = coupled.duplicate(copy=True)
    symmetric_part = two_fields(64, 0.0)
    coupling.axpy(-1.0, symmetric_part, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
    uncoupled = coupled.duplicate(copy=True)  # the symmetric part, in the operator's pattern
    uncoupled.axpy(-1.0, coupling, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
    operator = sum_operator([uncoupled, coupling])
    rhs = coupled.createVecLeft()
    rhs.setArray(np.sin(np.linspace(0.0, 40.0, rhs.getSize())))
    solution, residual = rhs.duplicate(), rhs.duplicate()

    def relative_residual() -> float:
        coupled.mult(solution, residual)
        residual.axpy(-1.0, rhs)
        return residual.norm() / rhs.norm()

    solver = LinearSolver(MPI.COMM_SELF, "iterative", relative_tolerance=1e-8)
    solver.set_operator(operator, symmetric=False, preconditioning=symmetric_part)
    solver.solve(rhs, solution)
    assert solver.fallbacks == 0 and relative_residual() < 1e-8
    solver.ksp.setTolerances(max_it=1)
    solution.set(0.0)
    solver.solve(rhs, solution)
    assert solver.ksp.getPC().getType() == "lu" and relative_residual() < 1e-8
    factored = solver.ksp.getOperators()[1]
    assert factored.getType() != PETSc.Mat.Type.PYTHON
    solver.set_operator(operator, symmetric=False, preconditioning=symmetric_part)
    assert solver.ksp.getOperators()[1].handle == factored.handle


def test_the_users_petsc_options_win_over_the_solvers_defaults():
    """An option the user set under the solver's prefix (here GAMG's prolongator smoothings, 0
    by default) is left as it is; the others get their defaults."""
    from roughfriction.solver.linear import default_options

    options = PETSc.Options()
    name = "roughfriction_iterative_pc_gamg_agg_nsmooths"
    restart = "roughfriction_iterative_ksp_gmres_restart"
    saved = {key: options.getString(key) if options.hasName(key) else None
             for key in (name, restart)}
    try:
        options[name] = 1
        options.delValue(restart)
        LinearSolver(MPI.COMM_SELF, "iterative")
        assert options.getInt(name) == 1 != default_options("iterative")["pc_gamg_agg_nsmooths"]
        assert options.getInt(restart) == default_options("iterative")["ksp_gmres_restart"]
    finally:
        for key, value in saved.items():
            options.delValue(key)
            if value is not None:
                options[key] = value
