"""The FEM block under a rough surface: a pure-hexahedral mesh moved onto the height map.

Layout (z up, the mean plane of the surface at z = 0)::

    z = Z(x, y)      contact surface: N x N cells, (N + 1)^2 nodes, periodic closure
    ...              ``blend_layers`` layers of thickness h; the roughness fades linearly to 0
    ...              flat layers of thickness h, down to ``fine_layers`` layers in all
    ...              coarsened levels: each doubles the lateral cell size (2:1) and holds
                     ``COARSE_LAYERS_PER_LEVEL`` cubic layers (``coarsen``); otherwise, or
                     once a level cannot be halved again, layers of lateral size unchanged
                     whose thickness grows geometrically (ratio ``growth``)
    z = -H           bottom (fixed), H >= ``depth`` x period

Why hexahedra only: linear tetrahedra lock under isochoric plastic flow, and a hexahedral
surface zone over a tetrahedral base makes gmsh insert pyramids, which dolfinx 0.5 refuses (one
cell type per mesh). Trilinear hexahedra with selective reduced integration do not lock.

Lateral coarsening: a 2:1 level below a finer layer leaves "hanging" nodes on the interface
(edge midpoints and face centres of the coarse cells' top faces, corners of the fine cells
above). They keep their own dofs in the mesh and are tied to the coarse face's corners by
bilinear interpolation in the same reduction u = P u_red that imposes periodicity
(``solver/periodic.py``), which is exact for trilinear hexahedra: the fine cells see exactly the
displacement of the coarse face. Below the surface zone the field varies on the scale of the
depth, not of h, so this removes more than half of the dofs at N >= 64 (numbers in the README).

The flat structured block is built on rank 0 and distributed by ``dolfinx.mesh.create_mesh`` in
fixed x-slabs (``slab_partitioner``: the same partition at every run); the surface heights are
then applied by moving node z-coordinates in place (the paper's moving-node method), and every
cell's Jacobian is checked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from roughfriction.case import MeshOptions
from roughfriction.errors import InputError

# dolfinx and mpi4py are imported where the block is built, so that this module (and the
# command line that builds it) import without them.

#: Smallest accepted ratio of a moved cell's corner Jacobian to the flat cell's [-].
MIN_JACOBIAN_RATIO = 0.1


class Boundary(IntEnum):
    """Facet tags of the block."""

    CONTACT = 1
    BOTTOM = 2
    X0 = 3
    XL = 4
    Y0 = 5
    YL = 6


#: Cubic cell layers per 2:1 coarsened level [-].
COARSE_LAYERS_PER_LEVEL = 2


@dataclass(frozen=True, eq=False)
class Block:
    """The meshed block and its structured indexing.

    Attributes
    ----------
    mesh : dolfinx.mesh.Mesh
        Hexahedral mesh [m], surface nodes already on the height map.
    grid_index : numpy.ndarray
        (i, j, k) of every local geometry node, shape (num_nodes, 3): x = i h, y = j h
        (0 <= i, j <= n) and node layer k (0 at the bottom, ``num_layers`` at the surface).
    layer_z : numpy.ndarray
        Flat z of the node layers [m], bottom (-H) to top (0), shape (num_layers + 1,).
    layer_stride : numpy.ndarray
        Lateral size of the cells of each cell layer in grid spacings (1 at full resolution,
        2, 4, ... in coarsened levels), bottom to top, shape (num_layers,).
    n : int
        Surface cells per side [-].
    spacing : float
        Grid spacing h [m].
    """

    mesh: object
    grid_index: np.ndarray
    layer_z: np.ndarray
    layer_stride: np.ndarray
    n: int
    spacing: float

    @property
    def period(self) -> float:
        """Lateral size of the periodic block, N h [m]."""
        return self.n * self.spacing

    @property
    def depth(self) -> float:
        """Block depth H below the mean surface plane [m]."""
        return -float(self.layer_z[0])

    @property
    def num_layers(self) -> int:
        """Number of cell layers [-]."""
        return len(self.layer_z) - 1


def layer_layout(n: int, spacing: float, options: MeshOptions) -> tuple[np.ndarray, np.ndarray]:
    """Flat z of the node layers and the lateral cell size of each cell layer.

    Parameters
    ----------
    n : int
        Surface cells per side [-].
    spacing : float
        Grid spacing h [m]; the fine layers are h thick.
    options : MeshOptions
        Layering.

    Returns
    -------
    layer_z : numpy.ndarray
        Increasing z of the node layers [m]; the first entry is -H, the last 0. With
        ``coarsen``, H = options.depth * n * spacing (the deepest layer is cut to it, so the
        block's bulk compliance does not depend on the layering); else H >= that.
    layer_stride : numpy.ndarray
        Lateral cell size of each cell layer, bottom to top [grid spacings].
    """
    fine = max(options.fine_layers, options.blend_layers)
    thicknesses, strides = [spacing] * fine, [1] * fine
    target = options.depth * n * spacing
    while (remaining := target - sum(thicknesses)) > 1e-12 * target:
        stride = strides[-1]
        if (options.coarsen and n % (2 * stride) == 0 and 2 * stride <= n // 2
                and 2 * stride * spacing <= remaining * (1.0 + 1e-12)):
            thicknesses += [2 * stride * spacing] * COARSE_LAYERS_PER_LEVEL
            strides += [2 * stride] * COARSE_LAYERS_PER_LEVEL
        else:
            thicknesses.append(thicknesses[-1] * options.growth)
            strides.append(stride)
        excess = sum(thicknesses) - target
        if options.coarsen and excess > 0.0:  # end at the depth
            if thicknesses[-1] - excess <= 1e-12 * target:
                thicknesses.pop()
                strides.pop()
            else:
                thicknesses[-1] -= excess
    layer_z = -np.concatenate([np.cumsum(thicknesses)[::-1], [0.0]])
    return layer_z, np.array(strides[::-1])


def mesh_size(n: int, options: MeshOptions) -> tuple[int, int]:
    """Hexahedra and reduced dofs (3 per node above the bottom that is neither a periodic image
    nor hanging) of the block under an n x n surface, without building it."""
    _, layer_stride = layer_layout(n, 1.0, options)
    cells = int(sum((n // stride) ** 2 for stride in layer_stride))
    return cells, int(3 * sum((n // stride) ** 2 for stride in layer_stride))


#: Peak memory of a run, summed over ranks: MEMORY_PER_RANK_GB per rank, plus
#: CONTACT_MEMORY_PER_NODE_GB per surface grid node on every rank (each rank evaluates the whole
#: surface's contact), plus MEMORY_PER_DOF_GB per reduced dof [GB] (an upper fit of
#: ``make bench-fem``, N = 32-128 on 2 ranks, and of the contact arrays alone to N = 512).
MEMORY_PER_RANK_GB = 0.2
CONTACT_MEMORY_PER_NODE_GB = 6.5e-6
MEMORY_PER_DOF_GB = 12e-6


def estimated_memory_gb(n: int, options: MeshOptions, ranks: int) -> float:
    """Peak memory of an FEM run on an n x n surface, summed over ``ranks`` ranks [GB]."""
    return (ranks * (MEMORY_PER_RANK_GB + CONTACT_MEMORY_PER_NODE_GB * n**2)
            + MEMORY_PER_DOF_GB * mesh_size(n, options)[1])


def node_layer_stride(layer_stride: np.ndarray) -> np.ndarray:
    """Lateral node spacing of each node layer [grid spacings], bottom to top: that of the cell
    layer above it (the finer one), the top layer's for the surface."""
    return np.append(layer_stride, layer_stride[-1])


def interpolation_masters(grid: np.ndarray, layer_stride: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Where each node's displacement comes from: itself, or for a hanging node the corners of
    the coarse face it lies on, bilinearly.

    Parameters
    ----------
    grid : numpy.ndarray
        (i, j, k) of nodes, shape (m, 3).
    layer_stride : numpy.ndarray
        Lateral cell size of each cell layer [grid spacings], bottom to top.

    Returns
    -------
    masters : numpy.ndarray
        (i, j, k) of up to 4 master nodes per node, shape (m, 4, 3) (unused slots repeat the
        first master with weight 0).
    weights : numpy.ndarray
        Interpolation weights, shape (m, 4), summing to 1: (1, 0, 0, 0) for a node that is not
        hanging, (1/2, 1/2, 0, 0) on a coarse edge, (1/4, ...) at a coarse face centre.
    """
    i, j, k = grid.T
    below = np.append(1, layer_stride)[k]  # cell layer under node layer k (none under k = 0)
    half = below // 2
    off_i, off_j = (i % below != 0), (j % below != 0)
    corners_i = np.stack([i - half * off_i, i + half * off_i], axis=1)
    corners_j = np.stack([j - half * off_j, j + half * off_j], axis=1)
    masters = np.stack([
        np.column_stack([corners_i[:, a], corners_j[:, b], k]) for a in (0, 1) for b in (0, 1)
    ], axis=1)
    weight = np.where(off_i, 0.5, 1.0) * np.where(off_j, 0.5, 1.0)
    # keep each distinct corner once: a node off in i only uses corners (0, 0) and (1, 0)
    used = np.column_stack([np.ones_like(off_i), off_j, off_i, off_i & off_j])
    return masters, np.where(used, weight[:, None], 0.0)


def build_block(heights: np.ndarray, spacing: float, options: MeshOptions, comm) -> Block:
    """Mesh the periodic block under a height map and move its surface onto the heights.

    Parameters
    ----------
    heights : numpy.ndarray
        Surface heights [m], shape (N, N), ``heights[i, j]`` at x = i h, y = j h; the block's
        period is N h and node N repeats node 0 (periodic closure). The mean is removed.
    spacing : float
        Grid spacing h [m].
    options : MeshOptions
        Layering.
    comm : mpi4py.MPI.Comm
        Communicator the mesh is distributed over.

    Returns
    -------
    Block

    Raises
    ------
    InputError
        If a moved cell is inverted or too distorted (names the cells and a layer count that
        fixes it).
    """
    heights = np.asarray(heights, dtype=float)
    n = heights.shape[0]
    layer_z, layer_stride = layer_layout(n, spacing, options)
    mesh = _flat_hex_block(n, spacing, layer_z, layer_stride, comm)
    grid_index = _grid_index(mesh.geometry.x, spacing, layer_z)
    flat_x = mesh.geometry.x.copy()
    _move_to_surface(mesh.geometry.x, grid_index, heights - heights.mean(), len(layer_z) - 1,
                     options.blend_layers)
    block = Block(mesh, grid_index, layer_z, layer_stride, n, spacing)
    check_jacobians(block, flat_x, heights - heights.mean(), options.blend_layers)
    return block


def structured_block(n: int, layer_stride: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and hexahedra of the layered block, in grid units.

    Parameters
    ----------
    n : int
        Surface cells per side [-].
    layer_stride : numpy.ndarray
        Lateral cell size of each cell layer [grid spacings], bottom to top.

    Returns
    -------
    grid : numpy.ndarray
        (i, j, k) of every node, shape (num_nodes, 3).
    hexahedra : numpy.ndarray
        Node numbers of each cell in gmsh order (bottom face counter-clockwise, then top),
        shape (num_cells, 8).
    """
    node_stride = node_layer_stride(layer_stride)
    layers = []
    for k, stride in enumerate(node_stride):
        i, j = np.meshgrid(np.arange(0, n + 1, stride), np.arange(0, n + 1, stride), indexing="ij")
        layers.append(np.column_stack([i.ravel(), j.ravel(), np.full(i.size, k)]))
    grid = np.concatenate(layers)
    number = np.full((len(node_stride), n + 1, n + 1), -1, dtype=np.int64)
    number[grid[:, 2], grid[:, 0], grid[:, 1]] = np.arange(len(grid))

    square = np.array([(0, 0), (1, 0), (1, 1), (0, 1)])  # counter-clockwise corners
    hexahedra = []
    for layer, stride in enumerate(layer_stride):
        start = np.arange(0, n, stride)
        i0, j0 = (a.ravel() for a in np.meshgrid(start, start, indexing="ij"))
        ci, cj = i0[:, None] + stride * square[:, 0], j0[:, None] + stride * square[:, 1]
        hexahedra.append(np.hstack([number[layer, ci, cj], number[layer + 1, ci, cj]]))
    return grid, np.concatenate(hexahedra)


def _flat_hex_block(n: int, spacing: float, layer_z: np.ndarray, layer_stride: np.ndarray,
                    comm):
    """Flat structured hexahedral block [0, N h]^2 x [-H, 0], distributed over comm.

    The nodes and hexahedra of :func:`structured_block` (on rank 0) are handed to dolfinx with
    :func:`slab_partitioner`, which gives every rank the columns of cells of one x-slab: the
    same partition at every run (dolfinx 0.5's graph partitioner is not repeatable, and a
    different partition changes the round-off of every solve). Returns the mesh.
    """
    import ufl
    from dolfinx import cpp
    from dolfinx.cpp.io import perm_gmsh
    from dolfinx.mesh import create_mesh

    if comm.rank == 0:
        grid, hexahedra = structured_block(n, layer_stride)
        # x-major cell order: contiguous ranges of cells are x-slabs of whole columns
        corner = grid[hexahedra[:, 0]]
        hexahedra = hexahedra[np.lexsort((corner[:, 2], corner[:, 1], corner[:, 0]))]
        coordinates = np.column_stack([grid[:, :2] * spacing, layer_z[grid[:, 2]]])
        cells = hexahedra[:, perm_gmsh(cpp.mesh.CellType.hexahedron, 8)]
    else:
        coordinates, cells = np.empty((0, 3)), np.empty((0, 8), dtype=np.int64)
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", ufl.hexahedron, 1))
    return create_mesh(comm, cells, coordinates, domain,
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


def boundary_facet_tags(block: Block):
    """Tag the block's boundary facets with :class:`Boundary` values, by the grid index of their
    vertices (a facet is on a side when all its vertices are).

    The mesh's facets are computed here, not when the block is built: the solver needs none,
    and dolfinx 0.5 takes minutes computing them on 2 ranks for a coarsened block at N = 64
    (measured: not finished after 40 s; 0.5 s at N = 32).

    Returns
    -------
    dolfinx.mesh.MeshTags
    """
    from dolfinx import mesh as dolfinx_mesh
    from dolfinx.cpp.mesh import entities_to_geometry

    mesh = block.mesh
    mesh.topology.create_entities(2)
    mesh.topology.create_connectivity(2, 3)
    facets = dolfinx_mesh.exterior_facet_indices(mesh.topology)
    facet_nodes = entities_to_geometry(mesh._mesh, 2, facets, False)
    i, j, k = (block.grid_index[facet_nodes][..., axis] for axis in range(3))
    sides = {Boundary.CONTACT: k == block.num_layers, Boundary.BOTTOM: k == 0,
             Boundary.X0: i == 0, Boundary.XL: i == block.n,
             Boundary.Y0: j == 0, Boundary.YL: j == block.n}
    values = np.zeros(len(facets), dtype=np.int32)
    for side, on_side in sides.items():
        values[on_side.all(axis=1)] = int(side)
    tagged = values > 0
    return dolfinx_mesh.meshtags(mesh, 2, facets[tagged].astype(np.int32), values[tagged])


def _grid_index(x: np.ndarray, spacing: float, layer_z: np.ndarray) -> np.ndarray:
    """(i, j, k) of flat node coordinates x [m]: lateral grid indices and node layer."""
    ij = np.rint(x[:, :2] / spacing).astype(np.int64)
    thickness = np.diff(layer_z).min()
    k = np.searchsorted(layer_z, x[:, 2] - 0.25 * thickness)
    if not np.allclose(layer_z[k], x[:, 2], rtol=0, atol=1e-6 * thickness):
        raise RuntimeError("mesh nodes are off the structured layers")
    return np.column_stack([ij, k])


def blend_weight(layer: np.ndarray, num_layers: int, blend_layers: int) -> np.ndarray:
    """Fraction of the surface height applied to node layer ``layer`` [-]: 1 at the top, 0 at
    and below ``blend_layers`` layers under it, linear in between."""
    return np.clip(1.0 - (num_layers - layer) / blend_layers, 0.0, 1.0)


def _move_to_surface(x: np.ndarray, grid_index: np.ndarray, heights: np.ndarray,
                     num_layers: int, blend_layers: int) -> None:
    """Add the blended surface height to the z of every node, in place on x [m]."""
    n = heights.shape[0]
    surface_height = heights[grid_index[:, 0] % n, grid_index[:, 1] % n]
    x[:, 2] += blend_weight(grid_index[:, 2], num_layers, blend_layers) * surface_height


def corner_jacobians(x: np.ndarray, cell_nodes: np.ndarray) -> np.ndarray:
    """Jacobian determinants of trilinear hexahedra at their 8 corners.

    Parameters
    ----------
    x : numpy.ndarray
        Node coordinates [m], shape (num_nodes, 3).
    cell_nodes : numpy.ndarray
        Node indices of each cell in dolfinx (tensor-product) order, shape (num_cells, 8):
        node a + 2 b + 4 c sits at the reference corner (a, b, c).

    Returns
    -------
    numpy.ndarray
        det J [m^3] at the corners, shape (num_cells, 8); at a corner the Jacobian's columns are
        the three cell edges leaving it in the reference directions.
    """
    corners = x[cell_nodes]  # (cells, 8, 3), index a + 2 b + 4 c
    grid = corners.reshape(-1, 2, 2, 2, 3)  # axes (c, b, a)
    d_xi = np.broadcast_to(grid[:, :, :, 1:2] - grid[:, :, :, 0:1], grid.shape)
    d_eta = np.broadcast_to(grid[:, :, 1:2, :] - grid[:, :, 0:1, :], grid.shape)
    d_zeta = np.broadcast_to(grid[:, 1:2] - grid[:, 0:1], grid.shape)
    jacobian = np.stack([d_xi, d_eta, d_zeta], axis=-1)
    return np.linalg.det(jacobian).reshape(-1, 8)


def check_jacobians(block: Block, flat_x: np.ndarray, heights: np.ndarray,
                    blend_layers: int) -> None:
    """Refuse inverted or badly distorted cells after moving the surface nodes.

    Every owned cell's corner Jacobians are compared with the flat block's; a ratio below
    :data:`MIN_JACOBIAN_RATIO` fails on all ranks with one message that names the cells and
    the number of blend layers that would fix them.

    Parameters
    ----------
    block : Block
        The moved block.
    flat_x : numpy.ndarray
        Node coordinates before moving [m].
    heights : numpy.ndarray
        Mean-free surface heights [m], (N, N).
    blend_layers : int
        Blend layers used [-].
    """
    from mpi4py import MPI

    mesh = block.mesh
    num_cells = mesh.topology.index_map(3).size_local
    cell_nodes = mesh.geometry.dofmap.array.reshape(-1, 8)[:num_cells]
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
    needed = blend_layers_needed(heights, block.spacing)
    state = "inverted" if worst <= 0 else "distorted"
    raise InputError(
        f"{num_bad} mesh cells {state} by the surface heights (worst Jacobian ratio "
        f"{worst:.3g}, cells at (i, j, layer) {examples}); the deepest valley "
        f"{-float(heights.min()):.3g} m needs >= {max(needed, blend_layers + 1)} blend layers "
        f"(now {blend_layers})"
    )


def blend_layers_needed(heights: np.ndarray, spacing: float) -> int:
    """Blend layers that keep every cell's Jacobian ratio above :data:`MIN_JACOBIAN_RATIO`
    under the deepest valley (a sufficient count): ceil(depth / ((1 - ratio) h)) [-].

    Parameters
    ----------
    heights : numpy.ndarray
        Surface heights [m], (N, N).
    spacing : float
        Grid spacing h [m].
    """
    deepest_valley = float(np.mean(heights) - np.min(heights))
    return math.ceil(deepest_valley / ((1.0 - MIN_JACOBIAN_RATIO) * spacing))
