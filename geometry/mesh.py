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

gmsh holds the mesh: the structured layers and the 2:1 levels are numbered here in NumPy
(:func:`structured_block`), moved onto the height map (:func:`block_nodes`, the paper's
moving-node method) and put into a gmsh model as discrete entities (:func:`add_block_to_gmsh`:
the nodes and hexahedra, and a physical group per side), which is written to a ``.msh`` file on
request (:func:`geometry.mesh_file.write_msh`) and read by dolfinx through ``dolfinx.io.gmshio``
(``solver/block.py``). gmsh's own meshers cannot make this block: its structured meshes
(transfinite volumes, extrusion in layers) are conforming, one lateral resolution per volume,
and joining two resolutions conformingly takes transition cells (recombination leaves prisms
and pyramids, which dolfinx 0.5 refuses), while the 2:1 levels here are non-conforming on
purpose (their hanging nodes are tied by the reduction, above). This module is NumPy and gmsh
only; the dolfinx side is in the solver.
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from roughfriction.case import MeshOptions

# gmsh is imported where the model is built, so that this module imports without it.

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


def blend_weight(layer: np.ndarray, num_layers: int, blend_layers: int) -> np.ndarray:
    """Fraction of the surface height applied to node layer ``layer`` [-]: 1 at the top, 0 at
    and below ``blend_layers`` layers under it, linear in between."""
    return np.clip(1.0 - (num_layers - layer) / blend_layers, 0.0, 1.0)


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


# --- the block as a gmsh model ----------------------------------------------------------------

#: gmsh element types: 4-node quadrangle and 8-node hexahedron.
GMSH_QUADRANGLE, GMSH_HEXAHEDRON = 3, 5
#: Tag of the block's volume entity and of its physical group in the gmsh model.
BLOCK_VOLUME = 1
#: The outward face of a hexahedron (gmsh node order: bottom face counter-clockwise seen from
#: above, then the top face) on each side of the block.
SIDE_FACES = {Boundary.CONTACT: (4, 5, 6, 7), Boundary.BOTTOM: (0, 3, 2, 1),
              Boundary.X0: (0, 4, 7, 3), Boundary.XL: (1, 2, 6, 5),
              Boundary.Y0: (0, 1, 5, 4), Boundary.YL: (2, 3, 7, 6)}


@dataclass(frozen=True, eq=False)
class BlockNodes:
    """The whole block on one process, its nodes on the height map (before distribution).

    Attributes
    ----------
    grid : numpy.ndarray
        (i, j, k) of every node, shape (num_nodes, 3) (:func:`structured_block`'s numbering).
    coordinates : numpy.ndarray
        Node coordinates [m], shape (num_nodes, 3): x = i h, y = j h, z = layer_z[k] plus the
        blended surface height (:func:`blend_weight`).
    hexahedra : numpy.ndarray
        Node numbers of each cell in gmsh order, shape (num_cells, 8), x-major: contiguous
        ranges of cells are x-slabs of whole columns.
    layer_z, layer_stride : numpy.ndarray
        As in :class:`Block`.
    n : int
        Surface cells per side [-].
    spacing : float
        Grid spacing h [m].
    """

    grid: np.ndarray
    coordinates: np.ndarray
    hexahedra: np.ndarray
    layer_z: np.ndarray
    layer_stride: np.ndarray
    n: int
    spacing: float


def block_nodes(heights: np.ndarray, spacing: float, options: MeshOptions) -> BlockNodes:
    """The layered block under a height map, moved onto it (the paper's moving-node method).

    Parameters
    ----------
    heights : numpy.ndarray
        Surface heights [m], shape (N, N), ``heights[i, j]`` at x = i h, y = j h; node N
        repeats node 0 (periodic closure). The mean is removed.
    spacing : float
        Grid spacing h [m].
    options : MeshOptions
        Layering.
    """
    heights = np.asarray(heights, dtype=float)
    n = heights.shape[0]
    layer_z, layer_stride = layer_layout(n, spacing, options)
    grid, hexahedra = structured_block(n, layer_stride)
    corner = grid[hexahedra[:, 0]]
    hexahedra = hexahedra[np.lexsort((corner[:, 2], corner[:, 1], corner[:, 0]))]
    coordinates = np.column_stack([grid[:, :2] * spacing, layer_z[grid[:, 2]]])
    i, j, k = grid.T
    surface_height = (heights - heights.mean())[i % n, j % n]
    coordinates[:, 2] += blend_weight(k, len(layer_z) - 1, options.blend_layers) * surface_height
    return BlockNodes(grid, coordinates, hexahedra, layer_z, layer_stride, n, spacing)


def boundary_quadrangles(nodes: BlockNodes) -> dict[Boundary, np.ndarray]:
    """The outward cell faces on each side of the block: node numbers, shape (faces, 4)."""
    low = nodes.grid[nodes.hexahedra[:, 0]]  # (i, j, k) of each cell's lowest corner ...
    high = nodes.grid[nodes.hexahedra[:, 6]]  # ... and of the opposite one
    on_side = {Boundary.CONTACT: high[:, 2] == len(nodes.layer_z) - 1,
               Boundary.BOTTOM: low[:, 2] == 0,
               Boundary.X0: low[:, 0] == 0, Boundary.XL: high[:, 0] == nodes.n,
               Boundary.Y0: low[:, 1] == 0, Boundary.YL: high[:, 1] == nodes.n}
    return {side: nodes.hexahedra[cells][:, SIDE_FACES[side]] for side, cells in on_side.items()}


@contextmanager
def gmsh_model(name: str = "block"):
    """A fresh gmsh session holding one empty model, finalised on exit (yields gmsh)."""
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(name)
        yield gmsh
    finally:
        gmsh.finalize()


def add_block_to_gmsh(gmsh, nodes: BlockNodes) -> None:
    """Put the block in gmsh's current model as discrete entities: one volume holding every
    node (tag = node number + 1) and hexahedron (tag = cell number + 1, in the order of
    ``nodes.hexahedra``), one surface per side holding its quadrangles, and a physical group for
    each (the volume "block", tag :data:`BLOCK_VOLUME`; the sides named and tagged as
    :class:`Boundary`)."""
    model = gmsh.model
    sides = boundary_quadrangles(nodes)
    for side in sides:
        model.addDiscreteEntity(2, int(side))
    model.addDiscreteEntity(3, BLOCK_VOLUME, [int(side) for side in sides])
    model.mesh.addNodes(3, BLOCK_VOLUME, np.arange(1, len(nodes.grid) + 1),
                        nodes.coordinates.ravel())
    model.mesh.addElementsByType(BLOCK_VOLUME, GMSH_HEXAHEDRON,
                                 np.arange(1, len(nodes.hexahedra) + 1),
                                 nodes.hexahedra.ravel() + 1)
    next_tag = len(nodes.hexahedra) + 1
    for side, quadrangles in sides.items():
        model.mesh.addElementsByType(int(side), GMSH_QUADRANGLE,
                                     np.arange(next_tag, next_tag + len(quadrangles)),
                                     quadrangles.ravel() + 1)
        next_tag += len(quadrangles)
        model.setPhysicalName(2, model.addPhysicalGroup(2, [int(side)], int(side)),
                              side.name.lower())
    model.setPhysicalName(3, model.addPhysicalGroup(3, [BLOCK_VOLUME], BLOCK_VOLUME), "block")
