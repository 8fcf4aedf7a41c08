"""Lateral periodicity, hanging nodes and the fixed bottom by algebraic reduction: u = P u_red.

P maps the reduced dofs to the full displacement dofs, built from the grid index of the nodes:
x = L <-> x = 0, y = L <-> y = 0 and the corner edge x = y = L <-> x = y = 0 follow from
i mod N, j mod N (entries 1); a hanging node takes the bilinear interpolation of the corners of
the coarse face it lies on (entries 1/2 or 1/4, ``geometry.adaptive.hanging_masters``). Bottom
nodes (u = 0) have no reduced dof: their rows of P are empty. The linear systems are
P^T K P du_red = -P^T R (MatPtAP with the pattern reused), exact in serial and in parallel.

dolfinx_mpc 0.5 is not used: with Debian's dolfinx 0.5.2 build it gave wrong periodic fields at
64^2 (docs/method.md).
"""

from __future__ import annotations

import numpy as np
from dolfinx import la
from mpi4py import MPI
from petsc4py import PETSc
from roughfriction.geometry.adaptive import hanging_masters
from roughfriction.geometry.mesh import Block
from roughfriction.solver.stages import REDUCTION, stage


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
        The mesh with its grid index (finest grid units) and cell sizes.

    Attributes
    ----------
    P : petsc4py.PETSc.Mat
        Full (rows) <- reduced (columns) matrix.
    reduced_node : numpy.ndarray
        Global reduced node of each local node of V, owned and ghost (-1 on the fixed bottom and
        at hanging nodes, which have no reduced node of their own).
    reduced_offset : int
        First global reduced node owned by this rank.
    num_reduced_owned : int
        Reduced nodes owned by this rank.
    master_node : numpy.ndarray
        Local node of V behind each owned reduced node, in reduced order.
    masters : numpy.ndarray
        Global reduced nodes each local node of V (owned and ghost) takes its displacement from,
        shape (num_nodes, 4), -1 in unused slots (one master for a node that does not hang,
        none on the fixed bottom).
    hanging : numpy.ndarray
        Local nodes of V that hang (tied to 2 or 4 masters), bool.
    """

    @stage(REDUCTION)
    def __init__(self, V, block: Block):
        comm = block.mesh.comm
        index_map = V.dofmap.index_map
        grid = dof_node_grid_index(V, block)
        n, num_owned = block.n, index_map.size_local
        masters, weights = hanging_masters(grid, block.cells)
        hanging = weights[:, 0] < 1.0

        # Masters: nodes with i < N, j < N above the bottom that are not hanging, numbered rank
        # by rank. On 2 ranks dolfinx 0.5 duplicates some vertices of the non-conforming interfaces
        # (each rank owns a copy; measured: 45 of 2280 nodes at N = 16): a grid position is
        # numbered once, by the lowest rank owning a copy, and every copy maps to that number.
        candidate = np.flatnonzero(((grid[:, 0] < n) & (grid[:, 1] < n) & (grid[:, 2] > 0)
                                    & ~hanging)[:num_owned])
        candidate_keys = _key(grid[candidate], n)
        # the master positions of all ranks, numbered compactly (a dense key space would take
        # num_layers N^2 entries on every rank: ~30 M at an 8x level of a 128^2 surface)
        positions = np.unique(np.concatenate(comm.allgather(candidate_keys)))
        candidate_position = np.searchsorted(positions, candidate_keys)
        owner = np.full(len(positions), comm.size, dtype=np.int32)
        owner[candidate_position] = comm.rank
        comm.Allreduce(MPI.IN_PLACE, owner, op=MPI.MIN)
        mine = owner[candidate_position] == comm.rank
        owned_positions, first = np.unique(candidate_position[mine], return_index=True)
        self.master_node = candidate[mine][first]
        self.num_reduced_owned = len(owned_positions)
        self.reduced_offset = comm.exscan(self.num_reduced_owned) or 0  # None on rank 0

        # Every node finds its masters' numbers through the key (k - 1, i mod N, j mod N).
        numbering = np.full(len(positions) + 1, -1, dtype=np.int64)  # the last: no master
        numbering[owned_positions] = self.reduced_offset + np.arange(len(owned_positions))
        comm.Allreduce(MPI.IN_PLACE, numbering, op=MPI.MAX)
        above_bottom = grid[:, 2] > 0
        columns = np.full(weights.shape, -1, dtype=np.int64)
        master_keys = _key(masters[above_bottom].reshape(-1, 3), n)
        columns[above_bottom] = numbering[_position(positions, master_keys)].reshape(
            -1, weights.shape[1])
        weights = np.where(above_bottom[:, None], weights, 0.0)
        self.reduced_node = np.where(above_bottom & ~hanging, columns[:, 0], -1)
        self.masters = np.where(weights > 0.0, columns, -1)
        self.hanging = hanging & above_bottom
        self.num_reduced_global = comm.allreduce(self.num_reduced_owned, op=MPI.SUM)
        self.P = self._matrix(comm, index_map, num_owned, columns[:num_owned],
                              weights[:num_owned])

    def _matrix(self, comm, index_map, num_owned: int, columns: np.ndarray,
                weights: np.ndarray) -> PETSc.Mat:
        """Assemble P (AIJ, block size 3) row by row from each owned node's master nodes
        ``columns`` (num_owned, 4) and their ``weights`` (zero weights are left out)."""
        used = weights != 0.0
        order = np.argsort(np.where(used, columns, np.iinfo(np.int64).max), axis=1)
        columns, weights, used = (np.take_along_axis(a, order, axis=1)
                                  for a in (columns, weights, used))
        row_counts = np.repeat(used.sum(axis=1), 3)
        indptr = np.concatenate([[0], np.cumsum(row_counts)]).astype(PETSc.IntType)
        # entries in row order: node, component c (column 3 master + c), master
        entry_columns = 3 * columns[:, None, :] + np.arange(3)[None, :, None]
        entry_used = np.broadcast_to(used[:, None, :], entry_columns.shape)
        entry_values = np.broadcast_to(weights[:, None, :], entry_columns.shape)
        P = PETSc.Mat().createAIJ(
            size=((3 * num_owned, 3 * index_map.size_global),
                  (3 * self.num_reduced_owned, 3 * self.num_reduced_global)),
            bsize=3,
            csr=(indptr, entry_columns[entry_used].astype(PETSc.IntType),
                 entry_values[entry_used]),
            comm=comm,
        )
        P.assemble()
        return P

    def local_to_reduced(self) -> PETSc.LGMap:
        """The map (block size 3) from each local node of V to its global reduced node, -1 at
        the fixed bottom and at hanging nodes: PETSc drops the rows and columns it maps to -1,
        so a cell without hanging nodes assembled through it adds P^T K_cell P."""
        return PETSc.LGMap().create(self.reduced_node.astype(PETSc.IntType), bsize=3,
                                    comm=self.P.comm)

    def destroy(self) -> None:
        """Free P."""
        self.P.destroy()

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


def _position(positions: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Index of each key in the sorted ``positions``, len(positions) where it is absent."""
    index = np.searchsorted(positions, keys)
    found = index < len(positions)
    found[found] = positions[index[found]] == keys[found]
    return np.where(found, index, len(positions))


def _key(grid: np.ndarray, n: int) -> np.ndarray:
    """Key of the periodic master of nodes (i, j, k), k >= 1: ((k - 1) N + i mod N) N + j mod N."""
    return ((grid[:, 2] - 1) * n + grid[:, 0] % n) * n + grid[:, 1] % n

