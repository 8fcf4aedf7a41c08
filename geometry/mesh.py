"""The FEM block under a rough surface: a pure-hexahedral gmsh mesh moved onto the height map.

Layout (z up, the mean plane of the surface at z = 0)::

    z = Z(x, y)      contact surface: N x N cells, (N + 1)^2 nodes, periodic closure
    ...              ``blend_layers`` layers of thickness h; the roughness fades linearly to 0
    z = -n_b h       flat from here down
    ...              base layers, thickness growing geometrically (ratio ``growth``)
    z = -H           bottom (fixed), H >= ``depth`` x period

Why hexahedra only: linear tetrahedra lock under isochoric plastic flow, and a hexahedral
surface zone over a tetrahedral base makes gmsh insert pyramids, which dolfinx 0.5 refuses (one
cell type per mesh). Trilinear hexahedra with selective reduced integration do not lock.

The block is first meshed flat (gmsh: a transfinite, recombined square extruded in graded
layers), then the surface heights are applied by moving node z-coordinates in place
(the paper's moving-node method), and every cell's Jacobian is checked.

Lateral coarsening of the base is not implemented. Note for later: 2:1 coarsened hexahedral
layers, tied by hanging-node constraints placed in the same 0/1-type reduction matrix as the
periodicity, would be exact for trilinear hexahedra.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from geometry.errors import InputError

# gmsh, dolfinx and mpi4py are imported where the block is built, so that MeshOptions (and the
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


@dataclass(frozen=True)
class MeshOptions:
    """How the block under the surface is layered.

    Parameters
    ----------
    blend_layers : int
        Layers of thickness h (the grid spacing) over which the roughness fades to flat [-].
    growth : float
        Thickness ratio of successive base layers going down [-], >= 1.
    depth : float
        Minimum block depth below the mean surface plane, in periods (N h) [-]. A surface
        wavelength lambda decays like exp(-2 pi z / lambda): at one period the longest one is down
        to exp(-2 pi) ~ 0.2 %.
    """

    blend_layers: int = 4
    growth: float = 1.4
    depth: float = 1.0

    def __post_init__(self):
        if isinstance(self.blend_layers, bool) or int(self.blend_layers) != self.blend_layers:
            raise InputError(f"blend_layers must be an integer, got {self.blend_layers!r}")
        if self.blend_layers < 1:
            raise InputError(f"blend_layers must be >= 1, got {self.blend_layers}")
        if not (math.isfinite(self.growth) and 1.0 <= self.growth <= 3.0):
            raise InputError(f"layer growth ratio must lie in [1, 3], got {self.growth}")
        if not (math.isfinite(self.depth) and self.depth > 0):
            raise InputError(f"block depth must be > 0 periods, got {self.depth}")


@dataclass(frozen=True, eq=False)
class Block:
    """The meshed block and its structured indexing.

    Attributes
    ----------
    mesh : dolfinx.mesh.Mesh
        Hexahedral mesh [m], surface nodes already on the height map.
    facet_tags : dolfinx.mesh.MeshTags
        Facets tagged with :class:`Boundary` values.
    grid_index : numpy.ndarray
        (i, j, k) of every local geometry node, shape (num_nodes, 3): x = i h, y = j h
        (0 <= i, j <= n) and node layer k (0 at the bottom, ``num_layers`` at the surface).
    layer_z : numpy.ndarray
        Flat z of the node layers [m], bottom (-H) to top (0), shape (num_layers + 1,).
    n : int
        Surface cells per side [-].
    spacing : float
        Grid spacing h [m].
    """

    mesh: object
    facet_tags: object
    grid_index: np.ndarray
    layer_z: np.ndarray
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


def layer_positions(n: int, spacing: float, options: MeshOptions) -> np.ndarray:
    """Flat z of the node layers [m], bottom to top, the top at z = 0.

    Parameters
    ----------
    n : int
        Surface cells per side [-].
    spacing : float
        Grid spacing h [m]; the blend layers are h thick.
    options : MeshOptions
        Layering.

    Returns
    -------
    numpy.ndarray
        Increasing z [m]; the first entry is -H with H >= options.depth * n * spacing.
    """
    thicknesses = [spacing] * options.blend_layers
    target = options.depth * n * spacing
    while sum(thicknesses) < target * (1.0 - 1e-12):
        thicknesses.append(thicknesses[-1] * options.growth)
    return -np.concatenate([np.cumsum(thicknesses)[::-1], [0.0]])


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
    layer_z = layer_positions(n, spacing, options)
    mesh, facet_tags = _flat_hex_block(n, spacing, layer_z, comm)
    grid_index = _grid_index(mesh.geometry.x, spacing, layer_z)
    flat_x = mesh.geometry.x.copy()
    _move_to_surface(mesh.geometry.x, grid_index, heights - heights.mean(), len(layer_z) - 1,
                     options.blend_layers)
    block = Block(mesh, facet_tags, grid_index, layer_z, n, spacing)
    check_jacobians(block, flat_x, heights - heights.mean(), options.blend_layers)
    return block


def _flat_hex_block(n: int, spacing: float, layer_z: np.ndarray, comm):
    """Flat structured hexahedral block [0, N h]^2 x [-H, 0] from gmsh, distributed over comm.

    A transfinite, recombined square at z = -H is extruded upwards in one-cell layers whose
    relative heights follow ``layer_z``. Returns (mesh, facet_tags).
    """
    import gmsh
    from dolfinx.io import gmshio

    period = n * spacing
    depth = -layer_z[0]
    if comm.rank == 0:
        gmsh.initialize()
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("block")
        geo = gmsh.model.geo
        corners = [(0.0, 0.0), (period, 0.0), (period, period), (0.0, period)]
        points = [geo.addPoint(x, y, -depth) for x, y in corners]
        lines = [geo.addLine(points[i], points[(i + 1) % 4]) for i in range(4)]
        base = geo.addPlaneSurface([geo.addCurveLoop(lines)])
        for line in lines:
            geo.mesh.setTransfiniteCurve(line, n + 1)
        geo.mesh.setTransfiniteSurface(base)
        geo.mesh.setRecombine(2, base)
        cumulative = (layer_z[1:] - layer_z[0]) / depth
        extruded = geo.extrude(
            [(2, base)], 0.0, 0.0, depth,
            numElements=[1] * len(cumulative), heights=list(cumulative), recombine=True,
        )
        geo.synchronize()
        volume = [tag for dim, tag in extruded if dim == 3]
        gmsh.model.addPhysicalGroup(3, volume, 1)
        for tag in [base] + [tag for dim, tag in extruded if dim == 2]:
            side = _boundary_of(gmsh.model.getBoundingBox(2, tag), period, depth)
            gmsh.model.addPhysicalGroup(2, [tag], side)
        gmsh.model.mesh.generate(3)
    mesh, _, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=3)
    if comm.rank == 0:
        gmsh.finalize()
    return mesh, facet_tags


def _boundary_of(box, period: float, depth: float) -> Boundary:
    """Which side of the block a flat gmsh surface with bounding box ``box`` is."""
    xmin, ymin, zmin, xmax, ymax, zmax = box
    tol = 1e-6 * period
    sides = {
        Boundary.CONTACT: zmin > -tol,
        Boundary.BOTTOM: zmax < -depth + tol,
        Boundary.X0: xmax < tol,
        Boundary.XL: xmin > period - tol,
        Boundary.Y0: ymax < tol,
        Boundary.YL: ymin > period - tol,
    }
    (side,) = [tag for tag, matches in sides.items() if matches]
    return side


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
    deepest_valley = -float(heights.min())
    needed = math.ceil(deepest_valley / ((1.0 - MIN_JACOBIAN_RATIO) * block.spacing))
    state = "inverted" if worst <= 0 else "distorted"
    raise InputError(
        f"{num_bad} mesh cells {state} by the surface heights (worst Jacobian ratio "
        f"{worst:.3g}, cells at (i, j, layer) {examples}); the deepest valley "
        f"{deepest_valley:.3g} m needs >= {max(needed, blend_layers + 1)} blend layers "
        f"(now {blend_layers})"
    )
