"""solver.reduced_system: the tangent and the bordered Newton direction at every iteration
of whole runs."""

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402
from roughfriction.case import FemCase, Loading  # noqa: E402
from roughfriction.geometry.surface import Surface  # noqa: E402
from roughfriction.solver.reduced_system import ReducedSystem  # noqa: E402
from roughfriction.solver.run import run  # noqa: E402

pytestmark = pytest.mark.fem


def _run_random_surface() -> None:
    """Preload and slide a random 16 x 16 surface at F* = 0.5 (to convergence)."""
    heights = np.random.default_rng(7).normal(0.0, 1e-7, (16, 16))
    case = FemCase(Surface(heights, 1e-6, "test"), Loading(0.5))
    result = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
    assert result.converged, result.message


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
            self.operator.mult(self.x1, linear)  # K du
            linear.axpy(height_increment, self.height_column)  # + b dh
            linear.axpy(1.0, self.residual)  # + R
            ratios.append(linear.norm() / (tolerance * residual_norm))
            linear.destroy()
        return height_increment, krylov

    monkeypatch.setattr(ReducedSystem, "bordered_solve", checked)
    _run_random_surface()
    assert len(ratios) > 20
    assert max(ratios) <= 2.0, f"linear residual {max(ratios):.3g} x the forcing term"


def test_the_tangent_is_the_reduced_solid_tangent_plus_the_contact_blocks(monkeypatch):
    """At every Newton iteration of a random 16 x 16 surface's preload and sliding (yielding
    cells and touching nodes from the first steps on; at the end over a third of the cells
    yield), the system matrix, updated in place from the reduced elastic part with the plastic
    correction reduced on its own cells and the blocks of the touching nodes, equals
    P^T (K_elastic + K_plastic) P plus the blocks of every surface node, assembled on the full
    mesh, to round-off."""
    from dolfinx.fem import petsc as fem_petsc

    assemble_tangent = ReducedSystem.assemble_tangent
    differences, plastic_iterations, yielding = [], [0], []

    def checked(self, contact):
        assemble_tangent(self, contact)
        full = fem_petsc.create_matrix(self.solid.elastic_tangent_forms[0])
        for form in self.solid.elastic_tangent_forms:
            fem_petsc.assemble_matrix(full, form)
        yielding.append(self.solid.yielding_fraction())
        if yielding[-1] > 0.0:
            plastic_iterations[0] += 1
            plastic = self.solid.plastic_tangent_forms_on(self.solid.yielding_cells())[0]
            fem_petsc.assemble_matrix(full, plastic)
        full.assemble()
        reduced = self.reduction.reduce_matrix(full)
        reference = self.tangent.duplicate()  # the system's pattern, zeros
        reference.axpy(1.0, reduced, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        blocks = contact.node_stiffness[self.flat.owned_grid].transpose(0, 2, 1, 3)
        reference.setValuesBlockedRCV(self._contact_rows[:, :1] // 3, self._contact_columns,
                                      blocks.reshape(len(blocks), -1),
                                      addv=PETSc.InsertMode.ADD_VALUES)
        reference.assemble()
        scale = reference.norm(PETSc.NormType.FROBENIUS)
        operator = self.operator.getPythonContext().assembled()
        reference.axpy(-1.0, operator, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        differences.append(reference.norm(PETSc.NormType.FROBENIUS) / scale)
        for matrix in (full, reduced, reference, operator):
            matrix.destroy()

    monkeypatch.setattr(ReducedSystem, "assemble_tangent", checked)
    _run_random_surface()
    assert plastic_iterations[0] > 10 and len(differences) > 20
    assert max(yielding) > 0.3
    assert max(differences) < 1e-13, f"the tangent differs by {max(differences):.2e} (Frobenius)"


def _reduced_system(n: int = 16) -> ReducedSystem:
    """The reduced system of a random n x n surface (one rank's share), before any assembly."""
    from roughfriction.solver.block import build_block
    from roughfriction.solver.equilibrium import Equilibrium
    from roughfriction.solver.periodic import PeriodicReduction
    from roughfriction.solver.run import surface_contact, with_blend_layers_needed
    from roughfriction.solver.solid import Solid

    heights = np.random.default_rng(7).normal(0.0, 1e-7, (n, n))
    case = with_blend_layers_needed(FemCase(Surface(heights, 1e-6, "test"), Loading(0.5)),
                                    lambda record: None)
    block = build_block(heights, 1e-6, case.mesh, MPI.COMM_WORLD)
    solid = Solid(block.mesh, case.material)
    reduction = PeriodicReduction(solid.V, block)
    flat = surface_contact(solid, block, case, reduction)
    return Equilibrium(solid, reduction, flat, case.solver, block.spacing).system


def _union_pattern(system: ReducedSystem, solid: PETSc.Mat) -> tuple:
    """(row pointer, columns) of the nonzeros of ``solid`` and of every owned surface node's
    rows with the 3 x 75 columns of its 25 neighbours, by sorting all (row, column) pairs."""
    start, end = solid.getOwnershipRange()
    row_pointer, columns, _ = solid.getValuesCSR()
    rows = [np.repeat(np.arange(end - start), np.diff(row_pointer))]
    cols = [columns.astype(np.int64)]
    node_columns = (3 * system._contact_columns[:, :, None] + np.arange(3)).reshape(
        len(system._contact_rows), -1)
    for component in range(3):
        rows.append(np.repeat(system._contact_rows[:, component] - start,
                              node_columns.shape[1]))
        cols.append(node_columns.ravel())
    size = solid.getSize()[1]
    rows, cols = np.concatenate(rows).astype(np.int64), np.concatenate(cols)
    kept = cols >= 0  # not the padding of a contact row
    pairs = np.unique(rows[kept] * size + cols[kept])
    rows, columns = np.divmod(pairs, size)
    return np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=end - start))]), columns


def _full_mesh_reduced_elastic(system: ReducedSystem) -> PETSc.Mat:
    """P^T K_elastic P by MatPtAP of the elastic tangent assembled on the whole mesh."""
    from dolfinx.fem import petsc as fem_petsc

    full = fem_petsc.create_matrix(system.solid.elastic_tangent_forms[0])
    for form in system.solid.elastic_tangent_forms:
        fem_petsc.assemble_matrix(full, form)
    full.assemble()
    elastic = system.reduction.reduce_matrix(full)
    full.destroy()
    return elastic


def test_the_system_matrix_has_the_solid_and_contact_pattern_within_a_memory_budget(
        monkeypatch):
    """The system matrix of a 16 x 16 surface, assembled straight into the reduced unknowns
    (the cells with hanging nodes and the pattern's cell pairs 64 cells at a time), has
    exactly the nonzeros of P^T K_elastic P (MatPtAP of the whole mesh's K) and of the contact
    blocks of every surface node (a union of all (row, column) pairs as the reference),
    P^T K P's values to round-off and zeros elsewhere, and building it takes at most 8 bytes
    of NumPy working memory per nonzero beyond the cells at once (the matrix itself takes 12
    in PETSc): sorting all (row, column) pairs of nonzeros as 64-bit keys takes more."""
    import tracemalloc

    from roughfriction.solver import reduced_assembly

    monkeypatch.setattr(reduced_assembly, "PATTERN_CELLS_AT_ONCE", 64)
    monkeypatch.setattr(reduced_assembly, "HANGING_CELLS_AT_ONCE", 64)
    system = _reduced_system()
    tracemalloc.start()
    try:
        system._create_tangent()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    matrix, elastic = system.tangent, _full_mesh_reduced_elastic(system)
    row_pointer, columns, _ = matrix.getValuesCSR()
    reference_pointer, reference_columns = _union_pattern(system, elastic)
    np.testing.assert_array_equal(row_pointer, reference_pointer)
    np.testing.assert_array_equal(columns, reference_columns)
    scale = elastic.norm(PETSc.NormType.FROBENIUS)
    matrix.axpy(-1.0, elastic, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
    assert matrix.norm(PETSc.NormType.FROBENIUS) <= 1e-14 * scale  # P^T K P, zeros elsewhere
    nonzeros = len(columns)
    assert peak <= 8 * nonzeros, f"{peak / nonzeros:.1f} bytes per nonzero"
    elastic.destroy()
    system.destroy()


def test_no_full_mesh_matrix_is_kept(monkeypatch):
    """Through a random 16 x 16 surface's preload and sliding, the system keeps no matrix of
    the full mesh's size and one matrix with the solid's couplings, the tangent (the operator
    is the tangent itself, or its sum with the coupling, a matrix of the coupled surface
    nodes' rows alone)."""
    assemble_tangent = ReducedSystem.assemble_tangent
    held = []

    def noted(self, contact):
        assemble_tangent(self, contact)
        full_size = self.reduction.P.getSize()[0]
        matrices = {item.handle: item for item in vars(self).values()
                    if isinstance(item, PETSc.Mat) and item.getType() != PETSc.Mat.Type.PYTHON}
        solid = [matrix for matrix in matrices.values()
                 if matrix.getInfo()["nz_used"] > 0.5 * self.tangent.getInfo()["nz_used"]]
        held.append((sum(m.getSize()[0] == full_size for m in matrices.values()), len(solid)))

    monkeypatch.setattr(ReducedSystem, "assemble_tangent", noted)
    _run_random_surface()
    assert len(held) > 20
    assert max(full for full, _ in held) == 0, "a full-mesh matrix is kept"
    assert max(solid for _, solid in held) == 1
