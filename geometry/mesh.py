"""The FEM block under a rough surface: its layering, and the pure-hexahedral mesh as a gmsh
model.

Layering (z up, the mean plane of the surface at z = 0; :func:`layer_layout`)::

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

The nodes and hexahedra of a block are numbered in NumPy by ``geometry.adaptive`` (its layout,
of which the surface's own grid is level 0, moved onto the height map: the paper's moving-node
method) and put here into a gmsh model as discrete entities (:func:`add_block_to_gmsh`: the
nodes and hexahedra, and a physical group per side), which is written to a ``.msh`` file on
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


class LaidOut:
    """The grid and layering a block reads from its ``layout``
    (``geometry.adaptive.AdaptiveLayout``): shared by :class:`Block` and :class:`BlockNodes`."""

    layout: object

    @property
    def cells(self):
        """Lateral cell sizes of every cell layer (``geometry.adaptive.CellSizes``)."""
        return self.layout.cells

    @property
    def n(self) -> int:
        """Surface cells per side of the finest grid [-]."""
        return self.layout.grid_size

    @property
    def spacing(self) -> float:
        """Finest grid spacing h [m]."""
        return self.layout.fine_spacing

    @property
    def layer_z(self) -> np.ndarray:
        """Flat z of the node layers [m], bottom (-H) to top (0), shape (num_layers + 1,)."""
        return self.layout.layer_z

    @property
    def layer_stride(self) -> np.ndarray:
        """Smallest lateral size of the cells of each cell layer [finest spacings] (1 at full
        resolution, 2, 4, ... in coarsened levels), bottom to top, shape (num_layers,)."""
        return self.layout.cells.layer_stride


@dataclass(frozen=True, eq=False)
class Block(LaidOut):
    """The meshed block and its grid indexing.

    Attributes
    ----------
    mesh : dolfinx.mesh.Mesh
        Hexahedral mesh [m], surface nodes already on the height map.
    grid_index : numpy.ndarray
        (i, j, k) of every local geometry node, shape (num_nodes, 3): x = i h, y = j h
        (0 <= i, j <= n, h the finest spacing) and node layer k (0 at the bottom,
        ``num_layers`` at the surface).
    layout : geometry.adaptive.AdaptiveLayout
        The block's layout: cell sizes of every layer and flat z of the node layers (built on
        this module's layering, so held here untyped, as the dolfinx mesh is).
    """

    mesh: object
    grid_index: np.ndarray
    layout: object

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
class BlockNodes(LaidOut):
    """The whole block on one process, its nodes on the height map (before distribution).

    Attributes
    ----------
    layout : geometry.adaptive.AdaptiveLayout
        The block's layout (untyped here, as in :class:`Block`).
    grid : numpy.ndarray
        (i, j, k) of every node, shape (num_nodes, 3) (``geometry.adaptive.adaptive_block``'s
        numbering, finest grid units).
    coordinates : numpy.ndarray
        Node coordinates [m], shape (num_nodes, 3): x = i h, y = j h, z = layer_z[k] plus the
        blended surface height (``geometry.adaptive.node_coordinates``).
    hexahedra : numpy.ndarray
        Node numbers of each cell in gmsh order, shape (num_cells, 8), x-major: contiguous
        ranges of cells are x-slabs of whole columns.
    """

    layout: object
    grid: np.ndarray
    coordinates: np.ndarray
    hexahedra: np.ndarray


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
