"""Linear solves of the reduced tangent system, chosen by size.

* direct: MUMPS Cholesky (the reduced tangent is symmetric: J2 consistent tangent, penalty
  contact, and a friction slip tangent that is symmetric because the cap tau_c does not depend on
  the pressure). One factorisation serves both solves of the bordered system.
* iterative: CG + GAMG with the rigid-body near-nullspace. The GAMG hierarchy is built at the
  first Newton iteration of a step and reused while the Krylov iteration count stays within
  ``REBUILD_FACTOR`` times the count of the freshly built preconditioner.
"""

from __future__ import annotations

from petsc4py import PETSc


class LinearSolveError(RuntimeError):
    """The Krylov solver diverged or hit its iteration limit (the Newton step is cut)."""


#: Rebuild the reused GAMG hierarchy when the iterations grow past this factor [-].
REBUILD_FACTOR = 1.5


class LinearSolver:
    """KSP for K x = b with the reduced tangent K.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator.
    method : {"direct", "iterative"}
        MUMPS Cholesky or CG + GAMG.
    relative_tolerance : float
        Krylov relative residual tolerance [-] (iterative only).
    """

    def __init__(self, comm, method: str, relative_tolerance: float = 1e-8):
        self.method = method
        self.ksp = PETSc.KSP().create(comm)
        pc = self.ksp.getPC()
        if method == "direct":
            self.ksp.setType("preonly")
            pc.setType("cholesky")
            pc.setFactorSolverType("mumps")
        elif method == "iterative":
            self.ksp.setType("cg")
            self.ksp.setTolerances(rtol=relative_tolerance, atol=0.0, max_it=1000)
            pc.setType("gamg")
            options = PETSc.Options()
            prefix = "roughfriction_gamg_"
            options[f"{prefix}pc_gamg_reuse_interpolation"] = True  # keep the aggregates
            self.ksp.setOptionsPrefix(prefix)
            self.ksp.setFromOptions()
            self.ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        else:
            raise ValueError(f"unknown linear solver {method!r}")
        self._fresh_iterations = None
        self.last_iterations = 0

    def set_operator(self, matrix: PETSc.Mat, new_step: bool) -> None:
        """Use ``matrix`` for the next solves; decide whether to rebuild the preconditioner."""
        self.ksp.setOperators(matrix)
        rebuild = (self.method == "direct" or new_step or self._fresh_iterations is None
                   or self.last_iterations > REBUILD_FACTOR * self._fresh_iterations)
        self.ksp.getPC().setReusePreconditioner(not rebuild)
        self._rebuilt = rebuild

    def solve(self, rhs: PETSc.Vec, solution: PETSc.Vec) -> int:
        """Solve into ``solution``; return the Krylov iterations (1 for a direct solve)."""
        self.ksp.solve(rhs, solution)
        if self.ksp.getConvergedReason() < 0:
            raise LinearSolveError(f"linear solver failed ({self.method}, reason "
                             f"{self.ksp.getConvergedReason()})")
        self.last_iterations = max(self.ksp.getIterationNumber(), 1)
        if self._rebuilt:
            self._fresh_iterations = self.last_iterations
            self._rebuilt = False
        return self.last_iterations
