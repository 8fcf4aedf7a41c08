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

from dataclasses import dataclass, field

import numpy as np
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc
from roughfriction.case import SolverOptions
from roughfriction.solver.contact import FRICTIONLESS, ContactResponse, RigidFlat, Trial
from roughfriction.solver.linear import LinearSolver
from roughfriction.solver.periodic import PeriodicReduction
from roughfriction.solver.reduced_assembly import ReducedAssembler, add_rows, compressed_rows
from roughfriction.solver.solid import Solid
from roughfriction.solver.stages import ELASTIC_TANGENT, RESIDUAL, SYSTEM_SETUP, TANGENT, stage

#: The tightest relative Krylov tolerance asked of a linear solve [-].
SMALLEST_TOLERANCE = 1e-10


@dataclass
class TangentAdditions:
    """What the tangent holds beyond P^T K_elastic P, to be taken back at the next assembly:
    the reduced plastic correction's rows (row pointer, columns, values [N/m], global rows) and
    the contact's node blocks (nodes, 3 x 3 blocks [N/m], scale), None or empty where nothing
    was added."""

    plastic: tuple | None = None
    node_blocks: list = field(default_factory=list)


class SumOperator:
    """The Newton operator as the sum of assembled matrices, y = sum_i A_i x (a PETSc python
    matrix context): the symmetric tangent and the contact's coupling dt/dp, which is held in
    a matrix of the coupled nodes' rows alone rather than in a copy of the tangent."""

    def __init__(self, parts: list[PETSc.Mat]):
        self.parts = parts

    def mult(self, matrix, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """y = sum_i A_i x."""
        self.parts[0].mult(x, y)
        for part in self.parts[1:]:
            part.multAdd(x, y, y)

    def assembled(self, into: PETSc.Mat | None = None) -> PETSc.Mat:
        """The sum as one matrix with the first part's pattern (the others' lie in it): new,
        or written into ``into`` (an earlier result)."""
        if into is None:
            into = self.parts[0].duplicate(copy=True)
        else:
            self.parts[0].copy(into, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        for part in self.parts[1:]:
            into.axpy(1.0, part, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        return into


def sum_operator(parts: list[PETSc.Mat]) -> PETSc.Mat:
    """A PETSc matrix that applies the sum of ``parts`` (:class:`SumOperator`)."""
    operator = PETSc.Mat().createPython(parts[0].getSizes(), SumOperator(parts),
                                        comm=parts[0].getComm())
    operator.setUp()
    return operator


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
        K [N/m] at the last :meth:`assemble_tangent`, without the contact's coupling dt/dp
        (symmetric positive definite; the preconditioner is built from it).
    operator : petsc4py.PETSc.Mat
        K with the coupling: a :class:`SumOperator` of ``tangent`` and, while it is not
        symmetric, the coupling (one object for the whole run).
    x1 : petsc4py.PETSc.Vec
        The Newton direction du [m] after :meth:`bordered_solve`.
    x2 : petsc4py.PETSc.Vec
        du/dh [-] after :meth:`solve_height_column`.
    symmetric, coupled : bool
        The last tangent is symmetric; some slipping point's cap followed its pressure there.
    """

    @stage(SYSTEM_SETUP)
    def __init__(self, solid: Solid, reduction: PeriodicReduction, flat: RigidFlat,
                 options: SolverOptions):
        self.solid, self.reduction, self.flat = solid, reduction, flat
        self.comm = solid.V.mesh.comm
        self._residual_full = fem_petsc.create_vector(solid.residual_forms[0])
        self._assembler = ReducedAssembler(solid.V, reduction)
        self.tangent = None  # P^T K P + contact, created at the first assembly
        self._additions = None  # what the tangent holds beyond P^T K_elastic P
        self._coupling = None  # dt/dp of the coupled nodes' rows, while not symmetric
        self.operator = None  # tangent (+ coupling): a SumOperator, created with the tangent
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
        node_reduced = flat.surface.gather_nodes(self.reduction.reduced_node[flat.nodes])
        neighbours = flat.surface.neighbours_of(flat.owned_grid)  # -1: padding (ignored by PETSc)
        self._contact_rows = (3 * node_reduced[flat.owned_grid][:, None]
                              + np.arange(3)).astype(PETSc.IntType)
        self._contact_columns = np.where(neighbours >= 0, node_reduced[neighbours],
                                         -1).astype(PETSc.IntType)
        self._owned_position = np.full(n * n, -1)  # grid node -> owned surface node, or -1
        self._owned_position[flat.owned_grid] = np.arange(len(flat.owned_grid))

    # --- assembly -------------------------------------------------------------------------

    @stage(RESIDUAL)
    def assemble(self, displacement: PETSc.Vec, flat_height: float, flat_slide: float,
                 trial: Trial = FRICTIONLESS) -> ContactResponse:
        """Stress update, R, b and c at the reduced displacement u_red [m] and the flat at
        height h [m] and slide U [m] (``trial`` as in :meth:`RigidFlat.respond`).
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
                                    flat_slide, trial)
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

    @stage(TANGENT)
    def assemble_tangent(self, contact: ContactResponse) -> None:
        """K = P^T K_elastic P + P^T K_plastic P plus the contact's 3 x 3 blocks of each surface
        node and its 25 neighbours, at the iterate of the last :meth:`assemble` (whose
        ``contact`` response is passed).

        The tangent matrix is created once with its whole pattern and the reduced elastic part
        (:mod:`solver.reduced_assembly`: no full-mesh matrix). Each assembly then takes back
        what the last one added (:class:`TangentAdditions`) and adds the plastic correction,
        assembled and reduced on the couplings of the yielding cells alone, and the blocks of
        the nodes that touch, row by row.
        """
        if self.tangent is None:
            self._create_tangent()
        self._restore_elastic_part()
        if self.solid.yielding_fraction() > 0.0:
            self._additions.plastic = self._add_plastic_correction()
        self.symmetric = self.comm.allreduce(contact.symmetric, op=MPI.LAND)
        self.coupled = self.comm.allreduce(contact.coupled, op=MPI.LOR)
        blocks = [(*contact.node_blocks, 1.0)]
        if not self.symmetric:
            blocks.append((*contact.coupling_blocks, -1.0))
        for nodes, values, scale in blocks:
            self._add_node_blocks(self.tangent, nodes, values, scale)
        self._additions.node_blocks = blocks
        self.tangent.assemble()
        self._set_coupling(None if self.symmetric else contact.coupling_blocks)

    @stage(ELASTIC_TANGENT)
    def _create_tangent(self) -> None:
        """The tangent matrix: the pattern of the solid and of the contact blocks (each owned
        surface node's rows gain the columns of its 25 neighbours), holding P^T K_elastic P."""
        rows = self._contact_rows[:, 0] // 3
        width = self._contact_columns.shape[1]
        self.tangent = self._assembler.create_matrix(np.repeat(rows, width),
                                                     self._contact_columns.ravel())
        start, end = self.tangent.getOwnershipRange()
        if np.any((self._contact_rows < start) | (self._contact_rows >= end)):
            raise RuntimeError("a surface node's reduced rows are owned by another rank")
        self._add_node_blocks(self.tangent, self.flat.owned_grid,
                              np.zeros((len(rows), width, 3, 3)))
        self._assembler.add(self.tangent, self.solid.elastic_tangent_forms_on)
        self.tangent.assemble()
        self.operator = sum_operator([self.tangent])
        self._additions = TangentAdditions()
        if self._near_nullspace is not None:
            self.tangent.setNearNullSpace(self._near_nullspace)

    def _restore_elastic_part(self) -> None:
        """Bring the tangent back to P^T K_elastic P: subtract the last additions."""
        additions = self._additions
        if additions.plastic is not None:
            add_rows(self.tangent, *additions.plastic, scale=-1.0)
        for nodes, values, scale in additions.node_blocks:
            self._add_node_blocks(self.tangent, nodes, values, -scale)
        self.tangent.assemble()
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

    def _set_coupling(self, coupling_blocks: tuple | None) -> None:
        """The operator's parts: the tangent alone, or (``coupling_blocks`` given: nodes,
        blocks) the tangent and a matrix of those blocks, preallocated for the coupled nodes'
        rows. The operator stays one object (the linear solver's preconditioner may hold it);
        the last coupling is released to PETSc, which frees it."""
        self._coupling = None
        if coupling_blocks is not None:
            nodes, values = coupling_blocks
            owned = self._owned_position[nodes]
            start, end = self.tangent.getOwnershipRange()
            row_nonzeros = np.zeros(end - start, dtype=PETSc.IntType)
            row_nonzeros[self._contact_rows[owned[owned >= 0]] - start] = 3 * values.shape[1]
            self._coupling = PETSc.Mat().createAIJ(self.tangent.getSizes(), bsize=3,
                                                   comm=self.comm,
                                                   nnz=(row_nonzeros, row_nonzeros))
            self._add_node_blocks(self._coupling, nodes, values)
            self._coupling.assemble()
        self.operator.getPythonContext().parts = [
            part for part in (self.tangent, self._coupling) if part is not None]

    def _add_plastic_correction(self) -> tuple:
        """Add P^T K_plastic P to the tangent row by row, assembled into a reduced matrix of
        the yielding cells' couplings alone; return its rows as :func:`add_rows` takes them."""
        cells = self.solid.yielding_cells()
        correction = self._assembler.create_matrix(cells=cells)
        self._assembler.add(correction, self.solid.plastic_tangent_forms_on, cells)
        correction.assemble()
        added = compressed_rows(correction)
        correction.destroy()
        add_rows(self.tangent, *added)
        return added

    # --- solves ---------------------------------------------------------------------------

    def set_operator(self) -> None:
        """Hand the operator to the linear solver: the tangent while it is symmetric, else the
        sum operator of it and the coupling, with the preconditioner built from the tangent."""
        self.linear_solver.set_operator(self.tangent if self.symmetric else self.operator,
                                        self.symmetric, preconditioning=self.tangent)

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
        self.linear_solver.destroy()
        for item in (self.operator, self._coupling, self._residual_full, self.tangent,
                     self.residual, self.height_column, self.force_row, self.x1, self.x2,
                     self._near_nullspace):
            if item is not None:
                item.destroy()
        self._assembler.destroy()
