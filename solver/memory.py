"""The memory model of an FEM run: the size of a block counted from its layout, the estimate
that gates a run or a refinement level before anything is allocated, and the memory available
to it. Every estimate of a block's dofs or memory is made here.

A gate, not physics: it refuses a run, it never changes one, so this module is outside the run
cache's physics key (``studies.cache.SOLVER_OUTPUT_MODULES``) and its fit can follow the
benchmarks without discarding runs. The fit and its error against measured peaks are in
docs/benchmarks.md (memory).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from roughfriction.case import MeshOptions
from roughfriction.errors import InputError
from roughfriction.geometry.adaptive import AdaptiveLayout, CellSizes, block_layout

if TYPE_CHECKING:  # the counts and estimates import without MPI and PETSc
    from mpi4py import MPI

#: Peak memory of a run, summed over ranks: MEMORY_PER_RANK_GB per rank, plus
#: CONTACT_MEMORY_PER_NODE_GB per surface grid node a rank evaluates (:func:`contact_memory_gb`),
#: plus MEMORY_PER_DOF_GB per reduced dof [GB] (a fit of ``make bench-fem``'s peaks, N = 128
#: to 512 on 2 ranks).
MEMORY_PER_RANK_GB = 0.2
CONTACT_MEMORY_PER_NODE_GB = 6.5e-6
MEMORY_PER_DOF_GB = 4.6e-6
#: Grid rows beyond its own slab whose faces a rank evaluates (two rings on either side) [-].
CONTACT_HALO_ROWS = 8
#: Offsets of the 3 other finest cells at a grid point (i, j) besides cell (i, j): cells
#: i - 1 .. i, j - 1 .. j have the point as a corner.
CELLS_AT_A_POINT = ((1, 0), (0, 1), (1, 1))


def layer_size(cells: CellSizes, layer: int) -> tuple[int, int]:
    """Cells of one cell layer, and its free nodes: the grid points (i, j < N) that are a corner
    of each of the (up to 4) cells around them, not hanging on a wider cell's edge [-].

    The node layer above a cell layer holds its own dofs at exactly these points: the layers
    coarsen downward, so its nodes are the corners of the finer cells above, and the corners
    of this layer's cells under them that are free here are free there. At level 0 every cell
    is the stride wide, (N / stride)^2 cells with a free node each; else, every cell corner
    lying on the grid of the layer's stride, only that grid is searched.
    """
    stride = int(cells.layer_stride[layer])
    if cells.level == 0:  # counted, not searched: the gate sizes any N
        count = (cells.grid_size // stride) ** 2
        return count, count
    index = np.arange(0, cells.grid_size, stride)
    width = cells.size(layer, index[:, None], index[None, :])  # of the cell at each point
    widest = width.copy()
    for shift in CELLS_AT_A_POINT:  # (periodic: the last row's cells are the first's)
        np.maximum(widest, np.roll(width, shift, axis=(0, 1)), out=widest)

    def corners(size: np.ndarray) -> int:
        return int(np.count_nonzero((index[:, None] % size == 0) & (index[None, :] % size == 0)))
    return corners(width), corners(widest)


def block_size(layout: AdaptiveLayout) -> tuple[int, int]:
    """Hexahedra and reduced dofs of the block of ``layout`` (3 per node above the bottom that
    is neither a periodic image nor hanging), counted without building it (:func:`layer_size`;
    cell layers of one stride have the same cells) [-]."""
    strides, first, repeats = np.unique(layout.cells.layer_stride, return_index=True,
                                        return_counts=True)
    sizes = np.array([layer_size(layout.cells, int(layer)) for layer in first])
    cells, free_nodes = repeats @ sizes
    return int(cells), 3 * int(free_nodes)


def contact_memory_gb(n: int, ranks: int) -> float:
    """The contact's share of the peak, summed over ``ranks`` ranks [GB]: each rank evaluates
    its slab of the n x n surface nodes and a halo of :data:`CONTACT_HALO_ROWS` rows."""
    return CONTACT_MEMORY_PER_NODE_GB * n * (n + CONTACT_HALO_ROWS * ranks)


def memory_gb(grid_size: int, dofs: int, ranks: int) -> float:
    """Estimated peak memory of a run with ``dofs`` reduced dofs on a ``grid_size`` squared
    finest surface grid, summed over ``ranks`` ranks [GB]."""
    return (ranks * MEMORY_PER_RANK_GB + contact_memory_gb(grid_size, ranks)
            + MEMORY_PER_DOF_GB * dofs)


def layout_memory_gb(layout: AdaptiveLayout, ranks: int) -> float:
    """:func:`memory_gb` of the block of ``layout`` (its reduced dofs, :func:`block_size`; the
    contact as if every face were finest) [GB]."""
    return memory_gb(layout.grid_size, block_size(layout)[1], ranks)


def available_memory_gb(comm: MPI.Comm) -> float:
    """Memory available to new allocations on the nodes that ``comm``'s ranks run on (Linux
    MemAvailable, each node counted once) [GB]; infinite where it cannot be read."""
    from mpi4py import MPI
    from roughfriction.solver.linear import node_memory_available_gb

    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    available = node_memory_available_gb() if node.rank == 0 else 0.0
    node.Free()
    return comm.allreduce(available, op=MPI.SUM)


def check_memory(n: int, options: MeshOptions, comm: MPI.Comm, spacing: float = 1.0) -> None:
    """Refuse, before allocating anything, an n x n surface whose FEM block
    (``geometry.adaptive.block_layout`` of ``options``; the grid spacing h [m] matters only
    through round-off) would not fit in the memory available to the run
    (:func:`memory_gb`)."""
    layout = block_layout(n, spacing, options)
    dofs = block_size(layout)[1]
    needed = memory_gb(layout.grid_size, dofs, comm.size)
    available = available_memory_gb(comm)
    if needed > available:
        what = f"N = {n}" + (f" refined to level {layout.level}" if layout.level else "")
        raise InputError(f"{what}: the FEM run needs about {needed:.3g} GB ({dofs:.3g} dofs), "
                         f"{available:.3g} GB are available; use a smaller --n, less "
                         "refinement or more nodes")
