"""Linear solves of solver.linear: the GMRES retry of a CG solve that meets indefiniteness, the
inexact solve kept at the iteration limit."""

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402
from roughfriction.solver.linear import (  # noqa: E402
    INEXACT_ACCEPTED,
    LinearSolveError,
    LinearSolver,
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


def solve(matrix: PETSc.Mat) -> float:
    """Relative residual ||A x - b|| / ||b|| of the iterative solver's solution for b = 1."""
    rhs = matrix.createVecLeft()
    rhs.set(1.0)
    solution, residual = rhs.duplicate(), rhs.duplicate()
    solver = LinearSolver(MPI.COMM_SELF, "iterative")
    solver.set_operator(matrix, symmetric=True)
    solver.solve(rhs, solution)
    matrix.mult(solution, residual)
    residual.axpy(-1.0, rhs)
    return residual.norm() / rhs.norm()


def test_cg_meeting_an_indefinite_operator_is_retried_with_gmres():
    assert solve(shifted_laplacian()) < 1e-7


def test_without_the_retry_the_same_solve_fails(monkeypatch):
    monkeypatch.setattr("roughfriction.solver.linear.INDEFINITE", ())
    with pytest.raises(LinearSolveError, match=r"cg \(iterative\) DIVERGED_INDEFINITE_PC \(-8\)"):
        solve(shifted_laplacian())


def test_destroy_frees_the_ksp():
    solver = LinearSolver(MPI.COMM_SELF, "direct")
    solver.destroy()
    assert solver.ksp.handle == 0


@pytest.mark.parametrize("iterations", [2, 35])
def test_a_solve_stopped_at_the_iteration_limit_is_kept_if_it_reduced_the_residual(
        monkeypatch, iterations):
    """Unpreconditioned CG on a 1-D Laplacian reduces the residual slowly: after 2 iterations by
    less than INEXACT_ACCEPTED (refused), after 35 by more (kept as an inexact Newton step)."""
    monkeypatch.setattr("roughfriction.solver.linear.MAX_KRYLOV_ITERATIONS", iterations)
    matrix = laplacian(40)
    rhs = matrix.createVecLeft()
    rhs.setArray(np.sin(np.linspace(0.0, 40.0, 40)))
    solution, residual = rhs.duplicate(), rhs.duplicate()
    solver = LinearSolver(MPI.COMM_SELF, "iterative", relative_tolerance=1e-12)
    solver.ksp.getPC().setType("none")
    solver.set_operator(matrix, symmetric=True)
    if iterations == 2:
        with pytest.raises(LinearSolveError, match="DIVERGED_MAX_IT"):
            solver.solve(rhs, solution)
        return
    solver.solve(rhs, solution)
    matrix.mult(solution, residual)
    residual.axpy(-1.0, rhs)
    assert 1e-12 < residual.norm() / rhs.norm() <= INEXACT_ACCEPTED
