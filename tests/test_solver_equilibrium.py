"""Newton loop of solver.equilibrium: convergence of its steps."""

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402
from roughfriction.case import FemCase, Loading, SolverOptions  # noqa: E402
from roughfriction.geometry.surface import Surface  # noqa: E402
from roughfriction.solver.equilibrium import Equilibrium  # noqa: E402
from roughfriction.solver.run import run  # noqa: E402

pytestmark = pytest.mark.fem


def test_a_converged_step_is_one_newton_increment_from_the_solution(monkeypatch):
    """Every load step a Newton solve accepts (preload and sliding of a random 16 x 16
    surface, a residual tolerance loose enough for the increment test to decide, Newton stopping
    at looser tolerances between Uzawa updates) is within the increment tolerance of the solution:
    one more exact Newton step moves no node further."""
    solve = Equilibrium.solve
    moves = []

    def checked(self, normal_force, flat_slide, friction):
        report = solve(self, normal_force, flat_slide, friction)
        if report.converged and report.iterations > 0:
            self.assemble(flat_slide, friction)
            self.assemble_tangent(report.contact)
            force_error = self.flat.normal_force(report.contact) - normal_force
            self._bordered_solve(force_error, 1e-12)
            moves.append(self._x1.norm(PETSc.NormType.NORM_INFINITY)
                         / (self.options.increment_tolerance * self.spacing))
        return report

    monkeypatch.setattr(Equilibrium, "solve", checked)
    heights = np.random.default_rng(7).normal(0.0, 1e-7, (16, 16))
    case = FemCase(Surface(heights, 1e-6, "test"), Loading(0.5),
                   solver=SolverOptions(residual_tolerance=1e-5))
    result = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
    assert result.converged, result.message
    assert len(moves) > 5
    assert max(moves) <= 1.0, f"a converged step moved {max(moves):.3g} x the tolerance"
