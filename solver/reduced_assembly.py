"""Bilinear forms assembled straight into the reduced unknowns: P^T K P without a full-mesh K.

A cell whose nodes do not hang (each node is one reduced node, or fixed) adds its element matrix
to the rows and columns of its reduced nodes: dolfinx's assembler writes through a local-to-
global map that sends each node to its reduced node, and PETSc drops the fixed bottom's (-1).
A cell with a hanging node (tied to 2 or 4 masters with weights) is assembled on the full dofs
and reduced by MatPtAP, ``HANGING_CELLS_AT_ONCE`` cells at a time. The reduced matrix is
preallocated with its exact pattern, every pair of masters of a cell's nodes, so no matrix of
the whole mesh's full dofs is ever formed.
"""

from __future__ import annotations

import numpy as np
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc
from roughfriction.solver.periodic import PeriodicReduction

#: Cells with a hanging node assembled and reduced (P^T K P) at once; bounds the working
#: memory of the full-dof matrix and its product.
HANGING_CELLS_AT_ONCE = 2048
#: Cells whose node pairs are listed at once while the pattern is counted.
PATTERN_CELLS_AT_ONCE = 16384


def cell_masters(cell_nodes: np.ndarray, masters: np.ndarray) -> np.ndarray:
    """The distinct reduced nodes each cell's displacement depends on, -1-padded.

    Parameters
    ----------
    cell_nodes : numpy.ndarray
        Local nodes of each cell, shape (c, 8).
    masters : numpy.ndarray
        Reduced masters of each local node, shape (num_nodes, 4), -1 where unused.

    Returns
    -------
    numpy.ndarray
        Shape (c, w), each row's distinct masters first, then -1 (w the widest row).
    """
    nodes = np.sort(masters[cell_nodes].reshape(len(cell_nodes), -1), axis=1)
    nodes[:, 1:][nodes[:, 1:] == nodes[:, :-1]] = -1  # repeats
    nodes = -np.sort(-nodes, axis=1)  # distinct masters first, descending
    width = int(np.count_nonzero(nodes >= 0, axis=1).max(initial=0))
    return nodes[:, :width]


def pair_keys(rows: np.ndarray, columns: np.ndarray, num_nodes: int) -> np.ndarray:
    """Sorted distinct keys row N + column of node pairs with both nodes >= 0 (int64)."""
    used = (rows >= 0) & (columns >= 0)
    return np.unique(rows[used].astype(np.int64) * num_nodes + columns[used])


def cell_pair_keys(nodes: np.ndarray, num_nodes: int) -> np.ndarray:
    """Keys (:func:`pair_keys`) of every pair of the reduced ``nodes`` of each cell (c, w)."""
    width = nodes.shape[1]
    return pair_keys(np.repeat(nodes, width, axis=1), np.tile(nodes, (1, width)), num_nodes)


def owned_keys(comm: MPI.Comm, keys: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Send each key (row N + column) to the rank owning its row (rows ``offsets[r]`` up to
    ``offsets[r + 1]`` on rank r); return the distinct keys of this rank's rows (collective)."""
    num_nodes = offsets[-1]
    owner = np.searchsorted(offsets, keys // num_nodes, side="right") - 1
    order = np.argsort(owner, kind="stable")
    counts = np.bincount(owner, minlength=comm.size)
    received = np.array(comm.alltoall(counts.tolist()))
    keys_received = np.empty(received.sum(), dtype=np.int64)
    comm.Alltoallv([keys[order], counts], [keys_received, received])
    return np.unique(keys_received)


class ReducedAssembler:
    """Creates reduced matrices with the pattern of the cells' couplings and adds P^T K P of
    bilinear forms to them, cell set by cell set.

    Parameters
    ----------
    V : dolfinx.fem.FunctionSpace
        The vector P1 space of the forms.
    reduction : PeriodicReduction
        u = P u_red.
    """

    def __init__(self, V, reduction: PeriodicReduction):
        self.comm = V.mesh.comm
        self.reduction = reduction
        num_cells = V.mesh.topology.index_map(3).size_local
        self._cell_nodes = V.dofmap.list.array.reshape(-1, 8)[:num_cells]
        self._hangs = reduction.hanging[self._cell_nodes].any(axis=1)
        self._local_to_reduced = reduction.local_to_reduced()

    def create_matrix(self, rows: np.ndarray | None = None, columns: np.ndarray | None = None,
                      cells: np.ndarray | None = None) -> PETSc.Mat:
        """An empty AIJ matrix of the reduced dofs (block size 3), preallocated with the
        couplings of the owned ``cells`` (all by default) plus the node pairs (``rows``,
        ``columns``: global reduced nodes, -1 ignored; rows owned by this rank), with the
        local-to-reduced map that :meth:`add` assembles through (collective)."""
        reduction = self.reduction
        num_nodes = reduction.num_reduced_global
        cell_nodes = self._cell_nodes if cells is None else self._cell_nodes[cells]
        keys = [np.empty(0, np.int64) if rows is None else pair_keys(rows, columns, num_nodes)]
        for first in range(0, len(cell_nodes), PATTERN_CELLS_AT_ONCE):
            nodes = cell_nodes[first:first + PATTERN_CELLS_AT_ONCE]
            keys.append(cell_pair_keys(cell_masters(nodes, reduction.masters), num_nodes))
        offsets = np.array(self.comm.allgather(reduction.reduced_offset) + [num_nodes])
        keys = owned_keys(self.comm, np.unique(np.concatenate(keys)), offsets)
        first, owned = reduction.reduced_offset, reduction.num_reduced_owned
        row, column = keys // num_nodes - first, keys % num_nodes
        diagonal = np.bincount(row, weights=(column >= first) & (column < first + owned),
                               minlength=owned).astype(PETSc.IntType)
        off_diagonal = np.bincount(row, minlength=owned).astype(PETSc.IntType) - diagonal
        size = (3 * owned, 3 * num_nodes)
        matrix = PETSc.Mat().createAIJ((size, size), bsize=3, comm=self.comm,
                                       nnz=(np.repeat(3 * diagonal, 3),
                                            np.repeat(3 * off_diagonal, 3)))
        matrix.setLGMap(self._local_to_reduced, self._local_to_reduced)
        matrix.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        return matrix

    def add(self, matrix: PETSc.Mat, forms_on, cells: np.ndarray | None = None) -> None:
        """Add P^T K P of the forms ``forms_on(cells)`` (bilinear forms over the given owned
        cells) to ``matrix`` (from :meth:`create_matrix`), over ``cells`` (sorted owned cells;
        all by default), unassembled (collective)."""
        if cells is None:
            cells = np.arange(len(self._cell_nodes), dtype=np.int32)
        hanging = self._hangs[cells]
        for form in forms_on(cells[~hanging]):
            fem_petsc.assemble_matrix(matrix, form)
        cells = cells[hanging]
        chunks = self.comm.allreduce(-(-len(cells) // HANGING_CELLS_AT_ONCE), op=MPI.MAX)
        if chunks:
            for chunk in np.array_split(cells, chunks):
                add_rows(matrix, *reduced_rows(self.reduction, forms_on(chunk)))

    def destroy(self) -> None:
        """Free the local-to-reduced map."""
        self._local_to_reduced.destroy()


def reduced_rows(reduction: PeriodicReduction, forms) -> tuple:
    """P^T K P of ``forms`` assembled on the full dofs (over a few cells), as its nonempty
    rows: row pointer, columns, values and global reduced rows (collective)."""
    full = fem_petsc.create_matrix(forms[0])
    for form in forms:
        fem_petsc.assemble_matrix(full, form)
    full.assemble()
    reduced = reduction.reduce_matrix(full)
    full.destroy()
    rows = compressed_rows(reduced)
    reduced.destroy()
    return rows


def compressed_rows(matrix: PETSc.Mat) -> tuple:
    """The nonempty owned rows of an assembled ``matrix``: row pointer, columns, values and
    global rows, as :func:`add_rows` takes them."""
    row_pointer, columns, values = matrix.getValuesCSR()
    rows = np.flatnonzero(np.diff(row_pointer))
    first = matrix.getOwnershipRange()[0]
    return (np.append(row_pointer[rows], row_pointer[-1]), columns, values,
            (rows + first).astype(PETSc.IntType))


def add_rows(matrix: PETSc.Mat, row_pointer: np.ndarray, columns: np.ndarray,
             values: np.ndarray, rows: np.ndarray, scale: float = 1.0) -> None:
    """Add ``scale`` times compressed ``rows`` (global rows with their row pointer, columns and
    values, as :func:`reduced_rows` gives them) to ``matrix``."""
    if len(rows):  # (petsc4py divides by the number of values)
        matrix.setValuesIJV(row_pointer, columns, scale * values,
                            addv=PETSc.InsertMode.ADD_VALUES, rowmap=rows)
