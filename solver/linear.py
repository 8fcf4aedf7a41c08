"""Linear solves of the reduced tangent system, with the preconditioner reused across Newton
iterations and load steps.

The reduced tangent is symmetric positive definite (J2 consistent tangent with hardening,
penalty contact, the slip tangent of the friction cap), so both methods are preconditioned CG,
except where Newton uses the exact tangent while a slipping node's cap follows its pressure
(below the ramp pressure, see :mod:`solver.contact` and :mod:`solver.equilibrium`): the
coupling dt/dp, strong (tau_c / p_r = 23 at the default ramp) and non-normal, is solved by
right-preconditioned GMRES (``GMRES_RESTART`` vectors) with the preconditioner built from the
tangent without it, the symmetric positive definite tangent Newton starts with:

* direct: the preconditioner is a MUMPS Cholesky factorisation. While it is fresh CG converges
  in one iteration; as the tangent drifts (plastic cells, contact set) the old factors keep
  preconditioning it, and they are refactorised only when CG needs more than
  ``MAX_REUSED_ITERATIONS``.
* iterative: CG + GAMG with the rigid-body near-nullspace and plain (unsmoothed) aggregation;
  the hierarchy is rebuilt when the iterations grow past ``REBUILD_FACTOR`` times the count of
  the freshly built preconditioner.

Either way a solve that fails with a reused preconditioner is retried once with a fresh one;
a CG solve that finds the fresh preconditioner or the operator indefinite is retried with
GMRES, which needs neither to be definite; a solve that stops at the iteration limit is kept if
it reduced the residual by at least ``INEXACT_ACCEPTED`` (an inexact Newton direction: the
Newton loop judges convergence by the nonlinear residual alone, so this can slow it but not
change its answer). If a fresh GAMG hierarchy still fails (GMRES breaks down on some sliding
tangents, made non-symmetric by slipping points below the ramp pressure), or GMRES on reused
Cholesky factors (restarted GMRES can stall on such a tangent), the solver switches to MUMPS LU
factors as preconditioner, reused like the direct method's: until the next symmetric operator
(:meth:`LinearSolver.set_operator`), which gets the configured preconditioner again, if a
non-symmetric operator failed; for the rest of the run if a symmetric one did. LU factors are
the operator's own, within a share of the node's memory (:func:`factor_memory_mb`): factors
that fail, or would need more, fail the solve (the Newton step is cut) and the configured
preconditioner returns.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

from mpi4py import MPI
from petsc4py import PETSc
from roughfriction.solver.stages import KRYLOV_SOLVE, LINEAR_SOLVE, stage


class LinearSolveError(RuntimeError):
    """The Krylov solver diverged or hit its iteration limit (the Newton step is cut)."""


class KrylovSolve(NamedTuple):
    """One finished :meth:`LinearSolver.solve`: whether it was warm-started, the Krylov method
    it ended with ("cg", "gmres") and its Krylov iterations [-]."""

    warm_start: bool
    krylov: str
    iterations: int


#: CG failures that GMRES, which needs neither a definite operator nor preconditioner, may cure.
INDEFINITE = (PETSc.KSP.ConvergedReason.DIVERGED_INDEFINITE_PC,
              PETSc.KSP.ConvergedReason.DIVERGED_INDEFINITE_MAT)


def converged_reason_name(reason: int) -> str:
    """PETSc's name of a KSP converged reason (e.g. -3 -> "DIVERGED_ITS")."""
    names = {value: name for name, value in vars(PETSc.KSP.ConvergedReason).items()
             if isinstance(value, int) and name.isupper()}
    return names.get(reason, str(reason))


#: Krylov iterations per solve [-].
MAX_KRYLOV_ITERATIONS = 1000
#: Krylov vectors GMRES keeps before it restarts (PETSc's default is 30) [-].
GMRES_RESTART = 200
#: A Krylov solve that hits its iteration limit is still used as an (inexact) Newton direction
#: if it reduced the residual by this factor [-].
INEXACT_ACCEPTED = 1e-2
#: Smoothing steps of GAMG's prolongator: 0 is plain aggregation (PETSc's default is 1) [-].
GAMG_PROLONGATOR_SMOOTHINGS = 0
#: Rebuild the reused GAMG hierarchy when the iterations grow past this factor [-].
REBUILD_FACTOR = 1.5
#: Refactorise the reused Cholesky factors when CG needs more iterations than this [-].
MAX_REUSED_ITERATIONS = 10
#: Share of a node's available memory that LU factors of the fallback may take [-].
FACTOR_MEMORY_SHARE = 0.8


def default_options(method: str) -> dict:
    """The PETSc options the solver sets under its prefix ``roughfriction_<method>_`` where the
    user has not set them (``-roughfriction_iterative_pc_gamg_agg_nsmooths 1`` on the command
    line wins)."""
    options = {
        # GMRES (set by _use) keeps GMRES_RESTART Krylov vectors and orthogonalises them once
        # more where classical Gram-Schmidt loses orthogonality: on the exact tangent at
        # sliding inception, strongly non-normal, it stalls with PETSc's default restart of 30
        "ksp_gmres_restart": GMRES_RESTART,
        "ksp_gmres_cgs_refinement_type": "refine_ifneeded",
    }
    if method == "iterative":
        options |= {
            "pc_gamg_reuse_interpolation": True,  # keep aggregates
            # plain aggregation: sparser coarse operators, a cheaper cycle and set-up, and no
            # more CG iterations at the Newton solves' loose tolerances (docs/benchmarks.md)
            "pc_gamg_agg_nsmooths": GAMG_PROLONGATOR_SMOOTHINGS,
            # Chebyshev smoothers on [0.2, 2.0] x the largest eigenvalue estimated in 30
            # iterations: PETSc's default ([0.1, 1.1], 10) underestimates it on the coarsened
            # blocks, and the smoother is then indefinite (CG: DIVERGED_INDEFINITE_PC) - on an
            # elastic sinusoid at N = 32, and, with [0.2, 1.3], at first contact of rough
            # surfaces on 2x refined meshes (docs/benchmarks.md)
            "mg_levels_ksp_chebyshev_esteig": "0,0.2,0,2.0",
            "mg_levels_esteig_ksp_max_it": 30,
        }
    return options


class LinearSolver:
    """KSP for K x = b with the reduced tangent K.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator.
    method : {"direct", "iterative"}
        CG preconditioned by MUMPS Cholesky factors or by GAMG.
    relative_tolerance : float
        Krylov relative residual tolerance [-].
    """

    def __init__(self, comm, method: str, relative_tolerance: float = 1e-8):
        if method not in ("direct", "iterative"):
            raise ValueError(f"unknown linear solver {method!r}")
        self.configured_method = self.method = method
        self.relative_tolerance = relative_tolerance
        self.ksp = PETSc.KSP().create(comm)
        self.ksp.setType("cg")
        self.ksp.setTolerances(rtol=relative_tolerance, atol=0.0, max_it=MAX_KRYLOV_ITERATIONS)
        prefix = f"roughfriction_{method}_"
        for name, value in default_options(method).items():
            if not PETSc.Options().hasName(f"{prefix}{name}"):  # the user's options win
                PETSc.Options()[f"{prefix}{name}"] = value
        self.ksp.setOptionsPrefix(prefix)
        self.ksp.setFromOptions()
        self.ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        self._precondition_as_configured()
        self.last_iterations = 0
        self.krylov_solves: list[KrylovSolve] = []  # every finished solve, in order
        self.rebuilds = 0
        self.fell_back = ""  # why GAMG or Cholesky last gave way to LU factors, if they did
        self.fallbacks = 0  # how many times they did
        self._symmetric = True  # the operator is
        self._preconditioning = None  # handle of the matrix the preconditioner is built from
        self._summed = None  # a sum operator's assembled sum, for LU factors
        self._factors_until_symmetric = False  # LU factors only for non-symmetric operators

    def set_operator(self, matrix: PETSc.Mat, symmetric: bool = True,
                     preconditioning: PETSc.Mat | None = None) -> None:
        """Use ``matrix`` (new values, same pattern) for the next solves; CG if it is
        ``symmetric``, else GMRES, with the preconditioner built from the symmetric positive
        definite ``preconditioning`` matrix if given (not from LU factors, which are the
        operator's: an operator given as a sum of matrices is then summed into one). A
        symmetric operator ends an LU fallback that a non-symmetric one started."""
        self._symmetric = symmetric
        if symmetric and self._factors_until_symmetric:
            self._factors_until_symmetric = False
            self._precondition_as_configured()
        self._use("cg" if symmetric else "gmres")
        if self.ksp.getPC().getType() == "lu":
            matrix = preconditioning = self._factorable(matrix)
        elif preconditioning is None:
            preconditioning = matrix
        if preconditioning.handle != self._preconditioning:
            # a reused preconditioner keeps its matrix: build it from the new one
            self._preconditioning = preconditioning.handle
            self._rebuild = True
        self.ksp.setOperators(matrix, preconditioning)
        if self._fresh_iterations is not None:
            limit = (MAX_REUSED_ITERATIONS if self.method == "direct"
                     else REBUILD_FACTOR * self._fresh_iterations)
            self._rebuild = self._rebuild or self.last_iterations > limit

    def _factorable(self, matrix: PETSc.Mat) -> PETSc.Mat:
        """``matrix``, or for a sum of matrices (a python matrix with an ``assembled`` context,
        :class:`solver.reduced_system.SumOperator`) their sum, kept and updated in place."""
        if matrix.getType() != PETSc.Mat.Type.PYTHON:
            return matrix
        self._summed = matrix.getPythonContext().assembled(self._summed)
        return self._summed

    def _use(self, krylov: str) -> None:
        """Switch to CG (left-preconditioned) or GMRES (right-preconditioned)."""
        if self.ksp.getType() != krylov:
            self.ksp.setType(krylov)
            self.ksp.setPCSide(PETSc.PC.Side.LEFT if krylov == "cg" else PETSc.PC.Side.RIGHT)
            self.ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
            if krylov == "gmres":
                self.ksp.setFromOptions()  # the prefix's GMRES options (__init__)

    @stage(LINEAR_SOLVE)
    def solve(self, rhs: PETSc.Vec, solution: PETSc.Vec, warm_start: bool = False,
              relative_tolerance: float | None = None) -> int:
        """Solve into ``solution`` (starting from its content if ``warm_start``, else from 0) to
        ``relative_tolerance`` (default: the solver's); return the Krylov iterations, also
        noted in :attr:`krylov_solves`."""
        iterations = self._solve(rhs, solution, warm_start, relative_tolerance)
        self.krylov_solves.append(KrylovSolve(warm_start, self.ksp.getType(), iterations))
        return iterations

    def _solve(self, rhs: PETSc.Vec, solution: PETSc.Vec, warm_start: bool,
               relative_tolerance: float | None) -> int:
        """:meth:`solve`, retried with a fresh preconditioner, GMRES or LU factors."""
        fresh = self._rebuild
        self.ksp.setTolerances(rtol=relative_tolerance or self.relative_tolerance)
        self.ksp.setInitialGuessNonzero(warm_start)
        self._apply(rhs, solution, fresh)
        if self.ksp.getConvergedReason() < 0 and not fresh:
            fresh = True
            self.ksp.setInitialGuessNonzero(False)
            self._apply(rhs, solution, fresh)
        if self.ksp.getConvergedReason() in INDEFINITE:
            self._use("gmres")  # until the next set_operator
            self.ksp.setInitialGuessNonzero(False)
            self._apply(rhs, solution, fresh=False)
        if self.ksp.getConvergedReason() < 0 and not self._good_enough(rhs):
            reason = self.ksp.getConvergedReason()
            failure = (f"Krylov solver {self.ksp.getType()} ({self.method}) "
                       f"{converged_reason_name(reason)} ({reason}) after "
                       f"{self.ksp.getIterationNumber()} iterations")
            if self.ksp.getPC().getType() == "lu":
                # the factors failed too (or hit their memory bound): the configured
                # preconditioner again for the cut step's solves
                self._factors_until_symmetric = False
                self._precondition_as_configured()
                raise LinearSolveError(failure)
            self.fell_back = failure
            self.fallbacks += 1
            self._factors_until_symmetric = not self._symmetric
            operator = self._factorable(self.ksp.getOperators()[0])
            self._preconditioning = operator.handle
            self.ksp.setOperators(operator, operator)
            self._precondition_with_factors()
            return self._solve(rhs, solution, False, relative_tolerance)
        self.last_iterations = max(self.ksp.getIterationNumber(), 1)
        if fresh:
            self._fresh_iterations = self.last_iterations
        return self.last_iterations

    def _precondition_as_configured(self) -> None:
        """Precondition with MUMPS Cholesky factors (direct) or GAMG (iterative), built afresh
        at the next solve."""
        self.method = self.configured_method
        pc = self.ksp.getPC()
        if self.method == "direct":
            pc.setType("cholesky")
            pc.setFactorSolverType("mumps")
        else:
            pc.setType("gamg")
        pc.setFromOptions()  # the options of the prefix (GAMG's above), and the user's
        self._rebuild, self._fresh_iterations = True, None

    def _precondition_with_factors(self) -> None:
        """Precondition with MUMPS LU factors of the operator, reused as the direct method
        reuses its Cholesky factors (LU: the operator may be non-symmetric)."""
        self.method = "direct"
        pc = self.ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        self._rebuild, self._fresh_iterations = True, None

    def _good_enough(self, rhs: PETSc.Vec) -> bool:
        """The failed solve stopped at its iteration limit with the (unpreconditioned)
        residual reduced by at least :data:`INEXACT_ACCEPTED`."""
        if self.ksp.getConvergedReason() != PETSc.KSP.ConvergedReason.DIVERGED_MAX_IT:
            return False
        norm = rhs.norm()
        return norm == 0.0 or self.ksp.getResidualNorm() <= INEXACT_ACCEPTED * norm

    def destroy(self) -> None:
        """Free the KSP (petsc4py does not free PETSc objects that reference each other)."""
        self.ksp.destroy()
        if self._summed is not None:
            self._summed.destroy()

    @stage(KRYLOV_SOLVE)
    def _apply(self, rhs: PETSc.Vec, solution: PETSc.Vec, fresh: bool) -> None:
        """One KSP solve, rebuilding the preconditioner if ``fresh`` (LU factors within
        :func:`factor_memory_mb`)."""
        pc = self.ksp.getPC()
        pc.setReusePreconditioner(not fresh)
        if fresh:
            self.rebuilds += 1
            self._rebuild = False
            if pc.getType() == "lu":
                pc.setFactorSetUpSolverType()
                pc.getFactorMatrix().setMumpsIcntl(23, factor_memory_mb(self.ksp.comm.tompi4py()))
        self.ksp.solve(rhs, solution)


def node_memory_available_gb() -> float:
    """Memory available to new allocations on this rank's node (Linux MemAvailable) [GB];
    infinite where it cannot be read."""
    try:
        meminfo = Path("/proc/meminfo").read_text().splitlines()
        line = next(line for line in meminfo if line.startswith("MemAvailable:"))
        return int(line.split()[1]) / 2**20  # kB -> GB
    except (OSError, StopIteration, ValueError):
        return math.inf


def factor_memory_mb(comm: MPI.Comm) -> int:
    """MUMPS's bound on the working memory of each rank for LU factors (its ICNTL(23)) [MB]:
    ``FACTOR_MEMORY_SHARE`` of the memory available on the rank's node, divided among the
    node's ranks; 0 (no bound) where it cannot be read. Factors that would need more fail
    (DIVERGED_PCSETUP_FAILED) instead of exhausting the node."""
    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    # the least any rank of the node saw, so that they all set the same bound
    available = node.allreduce(node_memory_available_gb(), op=MPI.MIN)
    share = FACTOR_MEMORY_SHARE * available / node.size
    node.Free()
    return 0 if math.isinf(share) else int(share * 1024)
