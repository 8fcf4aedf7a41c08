"""The Newton system of the reduced unknowns in PETSc: the residual R of the periodic solid and
the flat, the height column b = dR/dh, the force row c = dr/du, the tangent K, and the solve of
the bordered system

    [ K    b ] [du]     [R]          d = dr/dh = -sum_k c_k
    [ c^T  d ] [dh] = - [r]

with one operator: K x1 = -R, K x2 = -b, dh = -(r + c.x1) / (c.x2 + d), du = x1 + dh x2
(r = sum_k p_k a_k - F_n, the force condition; c = -b on the z rows; b also has x-y entries
where a slipping point's shear cap follows its pressure, see :mod:`solver.contact`).
"""

from __future__ import annotations

import ctypes
import functools
from dataclasses import dataclass

import numpy as np
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc
from roughfriction.case import SolverOptions
from roughfriction.solver.contact import ContactResponse, RigidFlat
from roughfriction.solver.linear import LinearSolver
from roughfriction.solver.periodic import PeriodicReduction
from roughfriction.solver.solid import Solid

#: Above this fraction of the cells yielding, the plastic correction is reduced with the elastic
#: part on the whole mesh (P^T K P with its pattern reused), below it on the yielding cells'
#: couplings alone (whose cost grows with them; measured crossover 15-20 % at N = 64) [-].
WHOLE_MESH_YIELDING = 0.15
#: The tightest relative Krylov tolerance asked of a linear solve [-].
SMALLEST_TOLERANCE = 1e-10


@functools.cache
def _petsc_function(name: str):
    """The C function ``name`` of the PETSc library petsc4py is linked to (ctypes), or None."""
    return getattr(ctypes.CDLL(PETSc.__file__), name, None)


def free_product_data(matrix: PETSc.Mat) -> None:
    """Drop what PETSc keeps with the result of a matrix product (P^T K P) to repeat it: its
    intermediate products and its references to the factors, so that a factor the caller
    destroys is freed at once (MatProductClear, which petsc4py does not wrap; a no-op where
    the library lacks it)."""
    clear = _petsc_function("MatProductClear")
    if clear is not None and clear(ctypes.c_void_p(matrix.handle)) != 0:
        raise RuntimeError("MatProductClear failed")


@dataclass
class TangentAdditions:
    """What the tangent holds beyond P^T K_elastic P, to be taken back at the next assembly:
    the reduced plastic correction's rows (row pointer, columns, values [N/m], global rows) and
    the contact's node blocks (nodes, 3 x 3 blocks [N/m]); None where nothing was added."""

    plastic: tuple | None = None
    node_blocks: tuple | None = None


class ReducedSystem:
    """R, b, c and K of the reduced system, assembled at an iterate, and its bordered solve.

    Parameters
    ----------
    solid : Solid
        The deformable block.
    reduction : PeriodicReduction
        u = P u_red.
    flat : RigidFlat
        Contact nodes owned by this rank.
    options : SolverOptions
        The linear-solver choice.

    Attributes
    ----------
    residual : petsc4py.PETSc.Vec
        R [N] at the last :meth:`assemble`.
    tangent : petsc4py.PETSc.Mat
        K [N/m] at the last :meth:`assemble_tangent`.
    x1 : petsc4py.PETSc.Vec
        The Newton direction du [m] after :meth:`bordered_solve`.
    x2 : petsc4py.PETSc.Vec
        du/dh [-] after :meth:`solve_height_column`.
    symmetric, coupled : bool
        The last tangent is symmetric; some slipping point's cap followed its pressure there.
    """

    def __init__(self, solid: Solid, reduction: PeriodicReduction, flat: RigidFlat,
                 options: SolverOptions):
        self.solid, self.reduction, self.flat = solid, reduction, flat
        self.comm = solid.V.mesh.comm
        self._residual_full = fem_petsc.create_vector(solid.residual_forms[0])
        self._tangent_full = None  # K_elastic + K_plastic on the whole mesh, once needed
        self._solid_tangent = None  # its P^T K P
        self.tangent = None  # P^T K P + contact, created at the first assembly
        self._additions = None  # what the tangent holds beyond P^T K_elastic P (None: unknown)
        self._uncoupled_tangent = None  # the tangent without dt/dp, once it is not symmetric
        self.symmetric = True
        self.coupled = False
        self.residual = reduction.create_reduced_vector()
        self.height_column = reduction.create_reduced_vector()  # b = dR/dh
        self.force_row = reduction.create_reduced_vector()  # c = dr/du
        self.x1 = reduction.create_reduced_vector()
        self.x2 = reduction.create_reduced_vector()

        num_dofs = 3 * reduction.num_reduced_global
        method = options.linear_solver
        if method == "auto":
            method = "direct" if num_dofs <= options.direct_limit else "iterative"
        self.linear_solver = LinearSolver(self.comm, method)
        self._near_nullspace = (reduction.near_nullspace(solid.V.tabulate_dof_coordinates())
                                if method == "iterative" else None)
        self._index_contact_rows()

    def _index_contact_rows(self) -> None:
        """Reduced rows of the owned surface nodes and the reduced nodes of their 25 neighbours
        on the periodic surface grid (the columns of the contact tangent)."""
        flat, n = self.flat, self.flat.grid_size
        node_reduced = flat.gather_nodes(self.reduction.reduced_node[flat.nodes])
        neighbours = flat.neighbours[flat.owned_grid]  # -1: padding (ignored by PETSc)
        self._contact_rows = (3 * node_reduced[flat.owned_grid][:, None]
                              + np.arange(3)).astype(PETSc.IntType)
        self._contact_columns = np.where(neighbours >= 0, node_reduced[neighbours],
                                         -1).astype(PETSc.IntType)
        self._owned_position = np.full(n * n, -1)  # grid node -> owned surface node, or -1
        self._owned_position[flat.owned_grid] = np.arange(len(flat.owned_grid))

    # --- assembly -------------------------------------------------------------------------

    def assemble(self, displacement: PETSc.Vec, flat_height: float, flat_slide: float,
                 friction: bool, predictor: bool = False, active: np.ndarray | None = None
                 ) -> ContactResponse:
        """Stress update, R, b and c at the reduced displacement u_red [m] and the flat at
        height h [m] and slide U [m] (the contact arguments as in :meth:`RigidFlat.respond`).
        The tangent is assembled separately (:meth:`assemble_tangent`), only where a linear
        solve needs it: line-search trials need the residual alone."""
        solid = self.solid
        self.reduction.expand(displacement, solid.displacement)
        solid.update_stress()
        with self._residual_full.localForm() as local:
            local.set(0.0)
        for form in solid.residual_forms:
            fem_petsc.assemble_vector(self._residual_full, form)
        self._residual_full.ghostUpdate(PETSc.InsertMode.ADD_VALUES, PETSc.ScatterMode.REVERSE)
        self.reduction.restrict(self._residual_full, self.residual)

        contact = self.flat.respond(solid.displacement.x.array.reshape(-1, 3), flat_height,
                                    flat_slide, friction, predictor, active)
        owned = self.flat.owned_grid
        self.residual.setValues(self._contact_rows.ravel(), contact.node_force[owned].ravel(),
                                addv=PETSc.InsertMode.ADD_VALUES)
        self.residual.assemble()
        self.height_column.set(0.0)
        height_derivative = contact.node_height_derivative[owned]
        self.height_column.setValues(self._contact_rows.ravel(), height_derivative.ravel())
        self.height_column.assemble()
        self.force_row.set(0.0)  # r = sum p a - F_n: dr/du_z = eps a = -dR_z/dh
        self.force_row.setValues(self._contact_rows[:, 2], -height_derivative[:, 2])
        self.force_row.assemble()
        return contact

    def assemble_tangent(self, contact: ContactResponse) -> None:
        """K = P^T K_elastic P + P^T K_plastic P plus the contact's 3 x 3 blocks of each surface
        node and its 25 neighbours, at the iterate of the last :meth:`assemble` (whose
        ``contact`` response is passed).

        The reduced elastic part is built once, in a matrix with the contact's pattern as well
        (:meth:`_system_matrix`), which then holds the tangent: each assembly takes back what
        the last one added to it (:class:`TangentAdditions`) and adds the new terms, so no
        second matrix of the system's size is kept. The plastic correction is assembled and
        reduced on the couplings of the yielding cells alone and added row by row while few
        cells yield (``WHOLE_MESH_YIELDING``), else in the whole mesh's pattern (kept, with its
        P^T K P, and reused). The blocks of the nodes that touch are added row by row.
        """
        if self.tangent is None:
            self._create_tangent()
        plastic = self.solid.plastic_tangent_form()
        if plastic is not None and self.solid.yielding_fraction() > WHOLE_MESH_YIELDING:
            self._reduce_whole_mesh(plastic)
            self._additions = None
        else:
            self._restore_elastic_part()
            if plastic is not None:
                self._additions.plastic = self._add_plastic_correction(plastic)
        self._add_node_blocks(self.tangent, *contact.node_blocks)
        if self._additions is not None:
            self._additions.node_blocks = contact.node_blocks
        self.tangent.assemble()
        self.symmetric = self.comm.allreduce(contact.symmetric, op=MPI.LAND)
        self.coupled = self.comm.allreduce(contact.coupled, op=MPI.LOR)
        if not self.symmetric:
            self._assemble_uncoupled_tangent(contact)

    def _create_tangent(self) -> None:
        """The tangent matrix, holding the reduced elastic part in the system's pattern (the
        full-mesh elastic tangent is freed as soon as it is reduced)."""
        full = self._assemble_full(self.solid.elastic_tangent_forms)
        full.assemble()
        elastic = self.reduction.reduce_matrix(full)
        free_product_data(elastic)  # else PETSc keeps the full matrix alive with it
        full.destroy()
        self.tangent = self._system_matrix(elastic)
        elastic.destroy()
        self._additions = TangentAdditions()
        if self._near_nullspace is not None:
            self.tangent.setNearNullSpace(self._near_nullspace)

    def _restore_elastic_part(self) -> None:
        """Bring the tangent back to P^T K_elastic P: subtract the last additions, or after a
        whole-mesh tangent, reduce the elastic part again in the whole mesh's kept pattern."""
        if self._additions is not None:
            if self._additions.plastic is not None:
                self._add_rows(*self._additions.plastic, scale=-1.0)
            if self._additions.node_blocks is not None:
                self._add_node_blocks(self.tangent, *self._additions.node_blocks, scale=-1.0)
            self.tangent.assemble()
        else:
            self._reduce_whole_mesh(None)
        self._additions = TangentAdditions()

    def _add_node_blocks(self, matrix: PETSc.Mat, nodes: np.ndarray, blocks: np.ndarray,
                         scale: float = 1.0) -> None:
        """Add ``scale`` times the contact's 3 x 3 ``blocks`` [N/m] of the surface ``nodes``
        (grid nodes) and their 25 neighbours to ``matrix``: one block row (3 x 75 values,
        row-major) per owned node."""
        owned = self._owned_position[nodes]
        touching = owned >= 0
        if np.any(touching):
            owned = owned[touching]
            matrix.setValuesBlockedRCV(
                self._contact_rows[owned, :1] // 3, self._contact_columns[owned],
                scale * blocks[touching].transpose(0, 2, 1, 3).reshape(len(owned), -1),
                addv=PETSc.InsertMode.ADD_VALUES)

    def _assemble_uncoupled_tangent(self, contact: ContactResponse) -> None:
        """The preconditioning matrix of a non-symmetric tangent: the tangent without the
        ramp's coupling dt/dp (:attr:`ContactResponse.coupling_blocks`), i.e. the symmetric
        positive definite tangent of :attr:`RigidFlat.symmetric_tangent`."""
        if self._uncoupled_tangent is None:
            self._uncoupled_tangent = self.tangent.duplicate(copy=True)
            if self._near_nullspace is not None:
                self._uncoupled_tangent.setNearNullSpace(self._near_nullspace)
        else:
            self.tangent.copy(self._uncoupled_tangent,
                              structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        self._add_node_blocks(self._uncoupled_tangent, *contact.coupling_blocks, scale=-1.0)
        self._uncoupled_tangent.assemble()

    def _add_plastic_correction(self, plastic) -> tuple:
        """Add P^T K_plastic P to the tangent, assembled and reduced on the couplings of the
        yielding cells (the ``plastic`` form's cells) alone, row by row; return its rows as
        :meth:`_add_rows` takes them."""
        correction = fem_petsc.assemble_matrix(plastic)
        correction.assemble()
        reduced = self.reduction.reduce_matrix(correction)
        row_pointer, columns, values = reduced.getValuesCSR()
        rows = np.flatnonzero(np.diff(row_pointer))
        added = (np.append(row_pointer[rows], row_pointer[-1]), columns, values,
                 (rows + reduced.getOwnershipRange()[0]).astype(PETSc.IntType))
        correction.destroy()
        reduced.destroy()
        self._add_rows(*added)
        return added

    def _add_rows(self, row_pointer: np.ndarray, columns: np.ndarray, values: np.ndarray,
                  rows: np.ndarray, scale: float = 1.0) -> None:
        """Add ``scale`` times the compressed ``rows`` (global reduced rows with their row
        pointer, columns and values) to the tangent."""
        if len(rows):  # (petsc4py divides by the number of values)
            self.tangent.setValuesIJV(row_pointer, columns, scale * values,
                                      addv=PETSc.InsertMode.ADD_VALUES, rowmap=rows)

    def _reduce_whole_mesh(self, plastic) -> None:
        """Set the tangent to P^T (K_elastic + K_plastic) P (``plastic`` None: the elastic
        part alone), assembled and reduced on the whole mesh (the full matrix and its P^T K P
        kept, their patterns reused; the elastic part is assembled again each time rather than
        kept in a second full-mesh matrix)."""
        if self._tangent_full is None:
            self._tangent_full = self._assemble_full(self.solid.elastic_tangent_forms)
        else:
            self._tangent_full.zeroEntries()
            for form in self.solid.elastic_tangent_forms:
                fem_petsc.assemble_matrix(self._tangent_full, form)
        if plastic is not None:
            fem_petsc.assemble_matrix(self._tangent_full, plastic)
        self._tangent_full.assemble()
        self._solid_tangent = self.reduction.reduce_matrix(self._tangent_full,
                                                           self._solid_tangent)
        self.tangent.zeroEntries()
        self.tangent.axpy(1.0, self._solid_tangent,
                          structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)

    def _assemble_full(self, forms) -> PETSc.Mat:
        """The bilinear ``forms`` summed on the whole mesh, unassembled (forms may follow)."""
        matrix = fem_petsc.create_matrix(self.solid.elastic_tangent_forms[0])
        for form in forms:
            fem_petsc.assemble_matrix(matrix, form)
        return matrix

    def _system_matrix(self, solid: PETSc.Mat) -> PETSc.Mat:
        """``solid`` (P^T K P) in a matrix with the nonzeros of the contact blocks as well: the
        rows of each owned surface node gain the columns of its 25 neighbours. PETSc forms the
        union (a sum with a zero matrix of the contact pattern), so no copy of the pattern is
        made outside the new matrix."""
        start, end = solid.getOwnershipRange()
        contact_rows = self._contact_rows - start  # (m, 3) local rows
        if np.any((contact_rows < 0) | (contact_rows >= end - start)):
            raise RuntimeError("a surface node's reduced rows are owned by another rank")
        column_start, column_end = solid.getOwnershipRangeColumn()
        columns = (3 * self._contact_columns[:, :, None] + np.arange(3)).reshape(
            len(contact_rows), -1)  # (m, 3 x widest row); negative: padding, ignored by PETSc
        padded = self._contact_columns[:, :, None].repeat(3, axis=2).reshape(columns.shape) < 0
        local = ~padded & (columns >= column_start) & (columns < column_end)
        diagonal = np.zeros(end - start, dtype=PETSc.IntType)  # nonzeros per local row
        diagonal[contact_rows] = np.count_nonzero(local, axis=1)[:, None]
        off_diagonal = np.zeros(end - start, dtype=PETSc.IntType)
        off_diagonal[contact_rows] = np.count_nonzero(~padded & ~local, axis=1)[:, None]
        matrix = PETSc.Mat().createAIJ(solid.getSizes(), bsize=solid.getBlockSize(),
                                       nnz=(diagonal, off_diagonal), comm=self.comm)
        matrix.setValuesRCV(self._contact_rows.astype(PETSc.IntType),
                            np.where(padded, -1, columns).astype(PETSc.IntType),
                            np.zeros((len(contact_rows), 3 * columns.shape[1])))
        matrix.assemble()
        matrix.axpy(1.0, solid, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        matrix.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        return matrix

    # --- solves ---------------------------------------------------------------------------

    def set_operator(self) -> None:
        """Hand the last assembled tangent to the linear solver, with the uncoupled tangent to
        build the preconditioner from if it is not symmetric."""
        self.linear_solver.set_operator(
            self.tangent, self.symmetric,
            preconditioning=None if self.symmetric else self._uncoupled_tangent)

    def bordered_solve(self, force_error: float, tolerance: float, hold_height: bool
                       ) -> tuple[float, int]:
        """Solve the bordered Newton system at the force error r [N] to the relative
        ``tolerance``: du into x1; return (dh [m], Krylov iterations). With the height held,
        K du = -R alone (dh = 0).

        du = x1 + dh x2 with K x1 = -R and K x2 = -b, so x2's residual enters du's times dh:
        x2 is solved again, tighter, until dh ||K x2 + b|| <= ``tolerance`` (||R|| + |r|)
        (||b|| dh, the force of moving the flat, can be far above them near convergence)."""
        c = self.force_row
        self.set_operator()
        self.residual.scale(-1.0)
        krylov = self.linear_solver.solve(self.residual, self.x1, relative_tolerance=tolerance)
        self.residual.scale(-1.0)  # R again, for the line search
        if hold_height:
            return 0.0, krylov
        allowed = (tolerance * (self.residual.norm() + abs(force_error))
                   / self.height_column.norm())  # bound on dh x x2's relative tolerance
        height_tolerance = tolerance
        while True:
            krylov += self.solve_height_column(height_tolerance)
            height_increment = -(force_error + c.dot(self.x1)) / self.height_slope()
            if (abs(height_increment) * height_tolerance <= allowed
                    or height_tolerance <= SMALLEST_TOLERANCE):
                break
            height_tolerance = max(SMALLEST_TOLERANCE, 0.5 * allowed / abs(height_increment))
        self.x1.axpy(height_increment, self.x2)
        return height_increment, krylov

    def solve_height_column(self, tolerance: float) -> int:
        """x2 = du/dh = -K^-1 b to the relative ``tolerance``, warm-started (x2 changes little
        from one iterate to the next); return the Krylov iterations."""
        b = self.height_column
        b.scale(-1.0)
        krylov = self.linear_solver.solve(b, self.x2, warm_start=True,
                                          relative_tolerance=tolerance)
        b.scale(-1.0)
        return krylov

    def height_slope(self) -> float:
        """dr/dh along the solution: c.x2 + d with d = dr/dh = -sum c [N/m]."""
        c = self.force_row
        return c.dot(self.x2) - c.sum()

    def destroy(self) -> None:
        """Free the PETSc objects (matrices, vectors, the KSP); unusable afterwards."""
        for item in (self._tangent_full, self._solid_tangent,
                     self._residual_full, self.tangent,
                     self._uncoupled_tangent, self.residual, self.height_column, self.force_row,
                     self.x1, self.x2, self._near_nullspace):
            if item is not None:
                item.destroy()
        self.linear_solver.destroy()
