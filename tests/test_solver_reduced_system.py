"""solver.reduced_system: the tangent and the bordered Newton direction at every iteration
of whole runs."""

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402
from roughfriction.case import FemCase, Loading  # noqa: E402
from roughfriction.geometry.surface import Surface  # noqa: E402
from roughfriction.solver import reduced_system as reduced_system_module  # noqa: E402
from roughfriction.solver.reduced_system import ReducedSystem  # noqa: E402
from roughfriction.solver.run import run  # noqa: E402

pytestmark = pytest.mark.fem


def test_the_bordered_newton_direction_meets_its_krylov_tolerance(monkeypatch):
    """At every Newton iteration of a random 16 x 16 surface's preload and sliding, the
    direction (du, dh) of the bordered system leaves a linear residual ||K du + b dh + R|| of at
    most 2 x the forcing term x (||R|| + |r|) (x1's and x2's residuals, each within it): the
    height column, scaled by dh, would otherwise dominate it near convergence."""
    bordered_solve = ReducedSystem.bordered_solve
    ratios = []

    def checked(self, force_error, tolerance, hold_height):
        residual_norm = self.residual.norm() + abs(force_error)
        height_increment, krylov = bordered_solve(self, force_error, tolerance, hold_height)
        if not hold_height and residual_norm > 0.0:
            linear = self.x1.duplicate()
            self.tangent.mult(self.x1, linear)  # K du
            linear.axpy(height_increment, self.height_column)  # + b dh
            linear.axpy(1.0, self.residual)  # + R
            ratios.append(linear.norm() / (tolerance * residual_norm))
            linear.destroy()
        return height_increment, krylov

    monkeypatch.setattr(ReducedSystem, "bordered_solve", checked)
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
    monkeypatch.setattr(reduced_system_module, "WHOLE_MESH_YIELDING", whole_mesh_yielding)
    from dolfinx.fem import petsc as fem_petsc

    assemble_tangent = ReducedSystem.assemble_tangent
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

    monkeypatch.setattr(ReducedSystem, "assemble_tangent", checked)
    heights = np.random.default_rng(7).normal(0.0, 1e-7, (16, 16))
    case = FemCase(Surface(heights, 1e-6, "test"), Loading(0.5))
    result = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
    assert result.converged, result.message
    assert plastic_iterations[0] > 10 and len(differences) > 20
    assert max(differences) < 1e-13, f"the tangent differs by {max(differences):.2e} (Frobenius)"
