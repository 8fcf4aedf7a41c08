"""The memory model of an FEM run: the estimate that gates a run or a refinement level before
anything is allocated, and the memory available to it.

A gate, not physics: it refuses a run, it never changes one, so this module is outside the run
cache's physics key (``studies.cache.SOLVER_OUTPUT_MODULES``) and its fit can follow the
benchmarks without discarding runs. The fit and its error against measured peaks are in
docs/benchmarks.md (memory).
"""

from __future__ import annotations

from mpi4py import MPI
from roughfriction.case import MeshOptions
from roughfriction.errors import InputError
from roughfriction.geometry.adaptive import AdaptiveLayout, layout_dofs
from roughfriction.geometry.mesh import mesh_size
from roughfriction.solver.linear import node_memory_available_gb

#: Peak memory of a run, summed over ranks: MEMORY_PER_RANK_GB per rank, plus
#: CONTACT_MEMORY_PER_NODE_GB per surface grid node a rank evaluates (:func:`contact_memory_gb`),
#: plus MEMORY_PER_DOF_GB per reduced dof [GB] (a fit of ``make bench-fem``'s peaks, N = 128
#: to 512 on 2 ranks).
MEMORY_PER_RANK_GB = 0.2
CONTACT_MEMORY_PER_NODE_GB = 6.5e-6
MEMORY_PER_DOF_GB = 4.6e-6
#: Grid rows beyond its own slab whose faces a rank evaluates (two rings on either side) [-].
CONTACT_HALO_ROWS = 8


def contact_memory_gb(n: int, ranks: int) -> float:
    """The contact's share of the peak, summed over ``ranks`` ranks [GB]: each rank evaluates
    its slab of the n x n surface nodes and a halo of :data:`CONTACT_HALO_ROWS` rows."""
    return CONTACT_MEMORY_PER_NODE_GB * n * (n + CONTACT_HALO_ROWS * ranks)


def memory_gb(grid_size: int, dofs: int, ranks: int) -> float:
    """Estimated peak memory of a run with ``dofs`` reduced dofs on a ``grid_size`` squared
    finest surface grid, summed over ``ranks`` ranks [GB]."""
    return (ranks * MEMORY_PER_RANK_GB + contact_memory_gb(grid_size, ranks)
            + MEMORY_PER_DOF_GB * dofs)


def structured_memory_gb(n: int, options: MeshOptions, ranks: int) -> float:
    """:func:`memory_gb` of the uniform block of an n x n surface [GB]."""
    return memory_gb(n, mesh_size(n, options)[1], ranks)


def adaptive_memory_gb(layout: AdaptiveLayout, ranks: int, dofs: int | None = None) -> float:
    """:func:`memory_gb` of the adaptive block (its reduced ``dofs``, default
    ``geometry.adaptive.layout_dofs``; the contact as if every face were finest) [GB]."""
    return memory_gb(layout.grid_size, layout_dofs(layout) if dofs is None else dofs, ranks)


def available_memory_gb(comm: MPI.Comm) -> float:
    """Memory available to new allocations on the nodes that ``comm``'s ranks run on (Linux
    MemAvailable, each node counted once) [GB]; infinite where it cannot be read."""
    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    available = node_memory_available_gb() if node.rank == 0 else 0.0
    node.Free()
    return comm.allreduce(available, op=MPI.SUM)


def check_memory(n: int, options: MeshOptions, comm: MPI.Comm,
                 layout: AdaptiveLayout | None = None) -> None:
    """Refuse, before allocating anything, an n x n surface whose FEM block would not fit in
    the memory available to the run (:func:`structured_memory_gb`, or
    :func:`adaptive_memory_gb` for the adaptive ``layout``)."""
    if layout is None:
        dofs, what = mesh_size(n, options)[1], f"N = {n}"
        needed = structured_memory_gb(n, options, comm.size)
    else:
        dofs, what = layout_dofs(layout), f"N = {n} refined to level {layout.level}"
        needed = adaptive_memory_gb(layout, comm.size, dofs)
    available = available_memory_gb(comm)
    if needed > available:
        raise InputError(f"{what}: the FEM run needs about {needed:.3g} GB ({dofs:.3g} dofs), "
                         f"{available:.3g} GB are available; use a smaller --n, less "
                         "refinement or more nodes")
