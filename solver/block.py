"""The block as a dolfinx mesh: the gmsh model of ``geometry.mesh`` read through
``dolfinx.io.gmshio`` on rank 0, distributed in fixed x-slabs, every cell's Jacobian checked.

The slab partition (:func:`slab_partitioner`) gives every rank the columns of cells of one
x-slab: the same partition at every run (dolfinx 0.5's graph partitioner is not repeatable,
and a different partition changes the round-off of every solve). ``gmshio.model_to_mesh`` takes
no partitioner in dolfinx 0.5 and computes the facet tags, which takes minutes on a coarsened
block (below), so the mesh is made from gmshio's geometry and topology extraction and
``create_mesh`` with the slab partitioner.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI
from roughfriction.case import MeshOptions
from roughfriction.errors import InputError
from roughfriction.geometry.adaptive import AdaptiveLayout, block_layout, block_nodes
from roughfriction.geometry.mesh import (
    GMSH_HEXAHEDRON,
    MIN_JACOBIAN_RATIO,
    Block,
    BlockNodes,
    add_block_to_gmsh,
    blend_layers_needed,
    corner_jacobians,
    gmsh_model,
)
from roughfriction.geometry.mesh_file import write_msh


def build_block(heights: np.ndarray, spacing: float, options: MeshOptions, comm) -> Block:
    """Mesh the periodic block under a height map, its surface on the heights.

    Parameters
    ----------
    heights : numpy.ndarray
        Surface heights [m], shape (N, N), ``heights[i, j]`` at x = i h, y = j h; the block's
        period is N h and node N repeats node 0 (periodic closure). The mean is removed.
    spacing : float
        Grid spacing h [m].
    options : MeshOptions
        Layering and refinement: the block of ``geometry.adaptive.block_layout`` on the
        bilinear surface of the heights.
    comm : mpi4py.MPI.Comm
        Communicator the mesh is distributed over.

    Returns
    -------
    Block
        Grid index, ``n`` and ``spacing`` of the finest grid (h / 2^L at refinement level L).

    Raises
    ------
    InputError
        If a moved cell is inverted or too distorted (names the cells and a layer count that
        fixes it).
    """
    heights = np.asarray(heights, dtype=float)
    layout = block_layout(heights.shape[0], spacing, options)  # a bad zone fails on every rank
    nodes = block_nodes(layout, heights) if comm.rank == 0 else None
    block = distributed_block(nodes, layout, comm)
    check_jacobians(block, heights - heights.mean(), options.blend_layers, spacing)
    return block


def distributed_block(nodes: BlockNodes | None, layout: AdaptiveLayout, comm) -> Block:
    """The block of ``layout`` from its ``nodes`` (given on rank 0, None elsewhere) through gmsh
    and gmshio, distributed in x-slabs (:func:`slab_mesh`)."""
    coordinates, hexahedra = np.empty((0, 3)), np.empty((0, 8), dtype=np.int64)
    if comm.rank == 0:
        with gmsh_model() as gmsh:
            add_block_to_gmsh(gmsh, nodes)
            coordinates, hexahedra = gmsh_hexahedra(gmsh.model)
    mesh = slab_mesh(comm, coordinates, hexahedra)
    grid = comm.bcast(nodes.grid if comm.rank == 0 else None, root=0)
    return Block(mesh, grid[mesh.geometry.input_global_indices], layout)


def write_block_msh(heights: np.ndarray, spacing: float, options: MeshOptions, path: str,
                    comm) -> None:
    """Write the block :func:`build_block` meshes as a gmsh ``.msh`` file (on rank 0; see
    ``geometry.mesh_file.write_msh``), raising its :class:`InputError` on every rank."""
    error = None
    if comm.rank == 0:
        try:
            layout = block_layout(np.shape(heights)[0], spacing, options)
            write_msh(block_nodes(layout, heights), path)
        except InputError as refused:
            error = str(refused)
    error = comm.bcast(error, root=0)
    if error is not None:
        raise InputError(error)


def gmsh_hexahedra(model) -> tuple[np.ndarray, np.ndarray]:
    """Node coordinates [m] (in node-tag order, shape (num_nodes, 3)) and hexahedra (0-based
    node numbers in gmsh order, shape (num_cells, 8)) of a gmsh model, through gmshio."""
    from dolfinx.io import gmshio

    coordinates = gmshio.extract_geometry(model)
    hexahedra = gmshio.extract_topology_and_markers(model)[GMSH_HEXAHEDRON]["topology"]
    return coordinates, hexahedra


def slab_mesh(comm, coordinates: np.ndarray, hexahedra: np.ndarray):
    """The dolfinx mesh of hexahedra given on rank 0 (gmsh order, x-major: contiguous ranges of
    cells are x-slabs of whole columns), distributed by :func:`slab_partitioner`."""
    from dolfinx import cpp
    from dolfinx.io import gmshio
    from dolfinx.mesh import CellType, create_mesh

    cells = np.asarray(hexahedra, dtype=np.int64)[:, gmshio.cell_perm_array(
        CellType.hexahedron, 8)]
    return create_mesh(comm, cells, coordinates, gmshio.ufl_mesh(GMSH_HEXAHEDRON, 3),
                       partitioner=cpp.mesh.create_cell_partitioner(slab_partitioner))


def slab_partitioner(comm, parts: int, graph, ghosting: bool):
    """Destination ranks of the cells of a distributed dual graph: cell g of G goes to rank
    g parts // G, and with ``ghosting`` also to the ranks of its neighbours (a graph
    partitioner for ``dolfinx.cpp.mesh.create_cell_partitioner``)."""
    from dolfinx.cpp.graph import AdjacencyList_int32

    offsets = np.asarray(graph.offsets)
    local = len(offsets) - 1
    first = comm.exscan(local) or 0
    total = comm.allreduce(local)
    owner = ((first + np.arange(local, dtype=np.int64)) * parts // total).astype(np.int32)
    if not ghosting:
        return AdjacencyList_int32(owner)
    # (cell, rank) pairs: its owner first, then the other ranks owning a neighbour
    neighbour_owner = (np.asarray(graph.array, dtype=np.int64) * parts // total).astype(np.int32)
    cell = np.repeat(np.arange(local), np.diff(offsets))
    ghost = np.unique(np.column_stack([cell, neighbour_owner])[neighbour_owner != owner[cell]],
                      axis=0).reshape(-1, 2)
    pairs = np.concatenate([np.column_stack([np.arange(local), owner]), ghost])
    pairs = pairs[np.argsort(pairs[:, 0], kind="stable")]
    counts = np.bincount(pairs[:, 0], minlength=local)
    return AdjacencyList_int32(pairs[:, 1].astype(np.int32),
                               np.concatenate([[0], np.cumsum(counts)]).astype(np.int32))


def check_jacobians(block: Block, heights: np.ndarray, blend_layers: int,
                    spacing: float | None = None) -> None:
    """Refuse inverted or badly distorted cells of the moved block.

    Every owned cell's corner Jacobians are compared with the flat block's (node z on its layer,
    ``layer_z``); a ratio below :data:`MIN_JACOBIAN_RATIO` fails on all ranks with one message
    that names the cells and the number of blend layers that would fix them.

    Parameters
    ----------
    block : Block
        The moved block.
    heights : numpy.ndarray
        Mean-free surface heights [m], (N, N).
    blend_layers : int
        Blend layers used [-].
    spacing : float, optional
        Spacing of ``heights`` [m], whose layers ``blend_layers`` counts; default the block's.
    """
    mesh = block.mesh
    num_cells = mesh.topology.index_map(3).size_local
    cell_nodes = mesh.geometry.dofmap.array.reshape(-1, 8)[:num_cells]
    flat_x = np.column_stack([mesh.geometry.x[:, :2], block.layer_z[block.grid_index[:, 2]]])
    ratio = (corner_jacobians(mesh.geometry.x, cell_nodes)
             / corner_jacobians(flat_x, cell_nodes)).min(axis=1)
    bad = np.flatnonzero(ratio < MIN_JACOBIAN_RATIO)
    comm = mesh.comm
    num_bad = comm.allreduce(len(bad), op=MPI.SUM)
    if num_bad == 0:
        return
    worst = comm.allreduce(float(ratio.min()), op=MPI.MIN)
    examples = comm.allgather([tuple(int(v) for v in block.grid_index[cell_nodes[c, 0]])
                               for c in bad[:3]])
    examples = [e for rank_examples in examples for e in rank_examples][:3]
    needed = blend_layers_needed(heights, spacing or block.spacing)
    state = "inverted" if worst <= 0 else "distorted"
    raise InputError(
        f"{num_bad} mesh cells {state} by the surface heights (worst Jacobian ratio "
        f"{worst:.3g}, cells at (i, j, layer) {examples}); the deepest valley "
        f"{-float(heights.min()):.3g} m needs >= {max(needed, blend_layers + 1)} blend layers "
        f"(now {blend_layers})"
    )
