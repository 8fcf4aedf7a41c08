"""Lateral periodicity and the fixed bottom by algebraic reduction: u = P u_red.

P is a 0/1 matrix from the full displacement dofs to the reduced ones, built by matching the
structured grid index of the nodes (x = L <-> x = 0, y = L <-> y = 0, and the corner edge
x = y = L <-> x = y = 0 follow from i mod N, j mod N). Bottom nodes (u = 0) have no reduced
dof: their rows of P are empty. The linear systems are P^T K P du_red = -P^T R (MatPtAP with the
pattern reused), exact in serial and in parallel.

dolfinx_mpc 0.5 is not used: it silently drops constraints on this machine's build (see the
field notes).
"""

from __future__ import annotations

import numpy as np
from dolfinx import la
from mpi4py import MPI
from petsc4py import PETSc

from geometry.mesh import Block


def dof_node_grid_index(V, block: Block) -> np.ndarray:
    """(i, j, k) of every local node of the vector P1 space V (owned then ghost nodes).

    P1 dofs and the (linear) geometry nodes sit at the same cell corners in the same local
    order, which maps one onto the other.
    """
    dof_nodes = V.dofmap.list.array.reshape(-1, 8)
    geometry_nodes = block.mesh.geometry.dofmap.array.reshape(-1, 8)
    index_map = V.dofmap.index_map
    geometry_of_dof = np.empty(index_map.size_local + index_map.num_ghosts, dtype=np.int64)
    geometry_of_dof[dof_nodes] = geometry_nodes
    return block.grid_index[geometry_of_dof]


class PeriodicReduction:
    """The reduction matrix P and the maps between full and reduced dofs.

    Parameters
    ----------
    V : dolfinx.fem.FunctionSpace
        Vector P1 space (block size 3) on the block.
    block : Block
        The mesh with its structured grid index.

    Attributes
    ----------
    P : petsc4py.PETSc.Mat
        Full (rows) <- reduced (columns) 0/1 matrix.
    reduced_node : numpy.ndarray
        Global reduced node of each local node of V (-1 on the fixed bottom), owned and ghost.
    reduced_offset : int
        First global reduced node owned by this rank.
    num_reduced_owned : int
        Reduced nodes owned by this rank.
    master_node : numpy.ndarray
        Local node of V behind each owned reduced node, in reduced order.
    """

    def __init__(self, V, block: Block):
        comm = block.mesh.comm
        index_map = V.dofmap.index_map
        grid = dof_node_grid_index(V, block)
        n, num_owned = block.n, index_map.size_local

        # Masters: nodes with i < N, j < N above the bottom; numbered rank by rank.
        master = (grid[:, 0] < n) & (grid[:, 1] < n) & (grid[:, 2] > 0)
        owned_master = np.flatnonzero(master[:num_owned])
        self.master_node = owned_master
        self.num_reduced_owned = len(owned_master)
        self.reduced_offset = comm.exscan(self.num_reduced_owned) or 0  # None on rank 0

        # Every node finds its master's number through the key (k - 1, i mod N, j mod N).
        num_keys = block.num_layers * n * n
        numbering = np.full(num_keys, -1, dtype=np.int64)
        numbering[_key(grid[owned_master], n)] = self.reduced_offset + np.arange(len(owned_master))
        comm.Allreduce(MPI.IN_PLACE, numbering, op=MPI.MAX)
        self.reduced_node = np.full(len(grid), -1, dtype=np.int64)
        above_bottom = grid[:, 2] > 0
        self.reduced_node[above_bottom] = numbering[_key(grid[above_bottom], n)]
        self.num_reduced_global = comm.allreduce(self.num_reduced_owned, op=MPI.SUM)
        self.P = self._matrix(comm, index_map, num_owned)

    def _matrix(self, comm, index_map, num_owned: int) -> PETSc.Mat:
        """Assemble P (AIJ, block size 3) row by row: one 1 per constrained-free dof."""
        columns_of_node = self.reduced_node[:num_owned]
        has_column = columns_of_node >= 0
        row_counts = np.repeat(has_column.astype(np.int32), 3)
        indptr = np.concatenate([[0], np.cumsum(row_counts)]).astype(PETSc.IntType)
        columns = (3 * columns_of_node[has_column, None] + np.arange(3)).ravel()
        P = PETSc.Mat().createAIJ(
            size=((3 * num_owned, 3 * index_map.size_global),
                  (3 * self.num_reduced_owned, 3 * self.num_reduced_global)),
            bsize=3,
            csr=(indptr, columns.astype(PETSc.IntType), np.ones(len(columns))),
            comm=comm,
        )
        P.assemble()
        return P

    def create_reduced_vector(self) -> PETSc.Vec:
        """A zero vector in the reduced layout (block size 3)."""
        vector = self.P.createVecRight()
        vector.set(0.0)
        return vector

    def expand(self, reduced: PETSc.Vec, function) -> None:
        """Set a dolfinx Function (full dofs, ghosts included) to P times a reduced vector."""
        self.P.mult(reduced, function.vector)
        function.x.scatter_forward()

    def restrict(self, full: PETSc.Vec, reduced: PETSc.Vec) -> None:
        """reduced = P^T full (full must have had its ghost contributions summed)."""
        self.P.multTranspose(full, reduced)

    def reduce_matrix(self, full: PETSc.Mat, reduced: PETSc.Mat | None = None) -> PETSc.Mat:
        """P^T K P; pass the previous result to reuse its pattern."""
        if reduced is None:
            reduced = full.PtAP(self.P)
        else:
            full.PtAP(self.P, result=reduced)
        return reduced

    def near_nullspace(self, node_coordinates: np.ndarray) -> PETSc.NullSpace:
        """Rigid-body modes (3 translations, 3 rotations) on the reduced nodes, for GAMG.

        Parameters
        ----------
        node_coordinates : numpy.ndarray
            Coordinates [m] of the local nodes of V, shape (num_nodes, 3).
        """
        x = node_coordinates[self.master_node]
        x = x - x.mean(axis=0)
        modes = []
        for k in range(6):
            mode = self.create_reduced_vector()
            values = mode.array.reshape(-1, 3)
            if k < 3:
                values[:, k] = 1.0
            else:
                a, b = [(0, 1), (1, 2), (2, 0)][k - 3]
                values[:, a], values[:, b] = -x[:, b], x[:, a]
            modes.append(mode)
        la.orthonormalize(modes)
        return PETSc.NullSpace().create(vectors=modes, comm=self.P.comm)


def _key(grid: np.ndarray, n: int) -> np.ndarray:
    """Key of the periodic master of nodes (i, j, k), k >= 1: ((k - 1) N + i mod N) N + j mod N."""
    return ((grid[:, 2] - 1) * n + grid[:, 0] % n) * n + grid[:, 1] % n

