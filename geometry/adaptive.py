"""The FEM block's layout: the surface zone refined 2x per level where the contact needs it.

Every block is laid out here (:func:`block_layout`): level 0, without a zone, is the surface's
own grid everywhere over the 2:1 coarsened layers of ``geometry.mesh.layer_layout``.

Everything lives on the finest integer grid of a refinement level L: spacing h / 2^L, N = n 2^L
cells per side of the period n h, node (i, j, k) at x = i h / 2^L, y = j h / 2^L on node layer k
(0 at the bottom). Laterally every cell layer is a quadtree over the own grid's n x n cells: the
surface zone (own cells of the zone mask) is refined to level L, the rest stays at the own grid,
2:1 balanced across edges and corners (periodically); a cell layer's cells are never finer than
its stride (``layer_stride``), so the zone coarsens with depth.

The vertical layering is global (one set of z-layers for the whole block, :func:`adaptive_layers`)
and is the layering of the uniformly refined block (``studies.refinement.refined_case``): the
own grid's ``geometry.mesh.layer_layout`` on the finest grid, with the blend zone, where the
roughness fades linearly, ``blend_layers h`` deep in metres at every level
(:func:`refined_layering`). So ``max(fine_layers, 2^L blend_layers)`` layers h / 2^L thick run
from the surface through the blend zone, then the 2:1 coarsened levels follow; with
``MeshOptions.blend_zone = "coarse"`` the blend zone below the fine layers has the previous
level's cells (:func:`coarse_blend_zone`), so it is still refined 2x per level, one level
behind the surface. The zone refined
everywhere is therefore the uniform ladder's level-L block; a partial zone keeps its cells in
those layers and its own-grid cells elsewhere (aspect ratio 2^L : 1 in the fine layers: flat
trilinear cells stiffen bending there, where the field is smooth on the scale h). Why global
z-layers: they keep every hanging node on a horizontal face (no vertical-face constraints, as an
octree would need) and the blend map exact. Why fine layers through the blend depth: the region
down to a fixed physical depth is refined 2x per level, so that the levels converge to one
continuum problem (a band graded from the surface would keep the cells at a depth h as wide at
every level).

Every level meshes the same continuous surface, the bilinear interpolant of the own-grid heights
(``geometry.surface.bilinear_refine``), and the blend map z -> z + w(z) Z(x, y) is trilinear in
each own-grid column, so every level meshes the same domain exactly and a hanging node lies on
the coarse face it hangs on. Hanging nodes (lateral 2:1 interfaces inside a layer: edge
midpoints; vertical ones between a coarse layer and the finer layer above: edge midpoints and
face centres) are tied to the corners of the coarse face (:func:`hanging_masters`, used by
``solver/periodic.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from roughfriction.case import MeshOptions, ZoneRefinement
from roughfriction.errors import InputError
from roughfriction.geometry.mesh import BlockNodes, layer_layout
from roughfriction.geometry.surface import bilinear_refine


@dataclass(frozen=True, eq=False)
class CellSizes:
    """Lateral size of the cells of every cell layer of a layered hexahedral block.

    Attributes
    ----------
    surface_level : numpy.ndarray
        Refinement level (0 .. ``level``) of the surface-layer cell covering each finest grid
        cell, shape (N, N), int8: the cell is 2^(level - surface_level) finest spacings wide.
    level : int
        L: the finest grid is 2^L times the own grid [-].
    layer_stride : numpy.ndarray
        Smallest lateral cell size of each cell layer [finest spacings], bottom to top.
    """

    surface_level: np.ndarray
    level: int
    layer_stride: np.ndarray

    @property
    def grid_size(self) -> int:
        """N, finest cells per side [-]."""
        return self.surface_level.shape[0]

    @property
    def num_layers(self) -> int:
        """Cell layers [-]."""
        return len(self.layer_stride)

    def size(self, layer, a, b) -> np.ndarray:
        """Width [finest spacings] of the cell of cell layer ``layer`` covering finest cell (a, b)
        (indices taken periodically)."""
        n = self.grid_size
        own = np.left_shift(1, self.level - self.surface_level[a % n, b % n].astype(np.int64))
        return np.maximum(own, np.asarray(self.layer_stride)[layer])

    def layer_cells(self, layer: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cells of one cell layer: first finest indices (i0, j0) and widths, each shape (m),
        i0 first, then j0 (aligned squares no narrower than the layer's stride, so their first
        cells lie on the stride's grid)."""
        index = np.arange(0, self.grid_size, int(self.layer_stride[layer]))
        i, j = np.meshgrid(index, index, indexing="ij")
        width = self.size(layer, i, j)
        first = (i % width == 0) & (j % width == 0)  # the corner cell of each aligned square
        return i[first], j[first], width[first]


#: Offsets of a grid cell's 8 neighbours (edges and corners).
NEIGHBOURS = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1))


def neighbourhood_max(values: np.ndarray) -> np.ndarray:
    """Largest value of each cell and its 8 neighbours, periodically."""
    result = values.copy()
    for shift in NEIGHBOURS:
        np.maximum(result, np.roll(values, shift, axis=(0, 1)), out=result)
    return result


def dilate(mask: np.ndarray, margin: int) -> np.ndarray:
    """Periodic dilation of a cell mask by ``margin`` cells in x, y and diagonally [-]."""
    result = np.asarray(mask, dtype=bool)
    for _ in range(margin):
        result = neighbourhood_max(result)
    return result


def cells_at_nodes(nodes: np.ndarray, margin: int = 0) -> np.ndarray:
    """The cells touching the marked nodes of a periodic grid (node (i, j) is a corner of cells
    (i - 1 .. i, j - 1 .. j)), dilated by ``margin`` cells (:func:`dilate`): a zone mask on the
    same grid, shape of ``nodes``."""
    nodes = np.asarray(nodes, dtype=bool)
    cells = nodes.copy()
    for shift in ((1, 0), (0, 1), (1, 1)):
        cells |= np.roll(nodes, (-shift[0], -shift[1]), axis=(0, 1))
    return dilate(cells, margin)


def quadtree_closure(demand: np.ndarray, level: int) -> np.ndarray:
    """The coarsest quadtree over 2^level-wide roots whose level is at least ``demand`` in every
    finest cell: a root or child square is split when a cell in it asks for a finer level.

    Parameters
    ----------
    demand : numpy.ndarray
        Wanted level (0 .. level) of each finest cell, shape (N, N), N a multiple of 2^level.
    level : int
        L [-].

    Returns
    -------
    numpy.ndarray
        Level of the quadtree cell covering each finest cell, shape (N, N), int8.
    """
    n = demand.shape[0]
    result = np.zeros(demand.shape, dtype=np.int8)
    for depth in range(level):
        width = 1 << (level - depth)  # squares of this depth
        wanted = demand.reshape(n // width, width, n // width, width).max(axis=(1, 3))
        split = np.repeat(np.repeat(wanted > depth, width, axis=0), width, axis=1)
        result[split] = depth + 1
    return result


def balanced_levels(zone: np.ndarray, level: int, zone_level: int = 0) -> np.ndarray:
    """Surface quadtree levels: the zone's cells at ``level``, the rest as coarse as the 2:1
    balance across edges and corners (periodic) allows.

    Parameters
    ----------
    zone : numpy.ndarray
        Cells to refine, bool, on the grid of level ``zone_level``: shape (n 2^m, n 2^m) for
        m = zone_level (0: the own grid; the previous level's contact, say, for m = L - 1).
    level : int
        L [-].
    zone_level : int
        m <= L [-].

    Returns
    -------
    numpy.ndarray
        Level of the surface cell covering each finest cell, shape (N, N) (N = n 2^L), int8.
    """
    factor = 1 << (level - zone_level)
    demand = np.repeat(np.repeat(np.asarray(zone, dtype=np.int8) * level, factor, axis=0),
                       factor, axis=1)
    while True:
        levels = quadtree_closure(demand, level)
        demand = np.maximum(levels, neighbourhood_max(levels) - 1)
        if np.array_equal(demand, levels):
            return levels


@dataclass(frozen=True, eq=False)
class AdaptiveLayout:
    """The contact-adaptive block of one refinement level, in finest grid units.

    Attributes
    ----------
    n : int
        Own-grid cells per side [-].
    spacing : float
        Own grid spacing h [m].
    cells : CellSizes
        Lateral cell sizes of every layer.
    layer_z : numpy.ndarray
        Flat z of the node layers [m], bottom (-H) to top (0).
    blend_depth : float
        Depth under the mean plane over which the roughness fades linearly to 0 [m], a node
        layer's.
    """

    n: int
    spacing: float
    cells: CellSizes
    layer_z: np.ndarray
    blend_depth: float

    @property
    def level(self) -> int:
        """L [-]."""
        return self.cells.level

    @property
    def grid_size(self) -> int:
        """N = n 2^L [-]."""
        return self.cells.grid_size

    @property
    def fine_spacing(self) -> float:
        """h / 2^L [m]."""
        return self.spacing / (1 << self.level)

    @property
    def num_layers(self) -> int:
        """Cell layers [-]."""
        return self.cells.num_layers


def refined_layering(options: MeshOptions, factor: int) -> MeshOptions:
    """The layering of a mesh ``factor`` times finer than the grid whose spacing h the
    ``options`` count their blend layers in: a blend zone of the same depth in metres,
    ``factor`` times the blend layers (each h / factor thick); the fine layers (h / factor
    thick) as given; no zone."""
    return replace(options, blend_layers=factor * options.blend_layers, refinement=None)


def adaptive_layers(n: int, spacing: float, level: int, options: MeshOptions
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Flat z of the node layers and the smallest lateral cell size of each cell layer of the
    level-L block: ``geometry.mesh.layer_layout`` of the finest grid (n 2^L cells of
    h / 2^L) with :func:`refined_layering` (blend zone ``blend_layers h`` deep).

    Parameters n, spacing, level and options as :func:`adaptive_layout`'s.

    Returns
    -------
    layer_z : numpy.ndarray
        Increasing z of the node layers [m], -H first, 0 last.
    layer_stride : numpy.ndarray
        Smallest lateral cell size of each cell layer [finest spacings], bottom to top.
    """
    factor = 1 << level
    layering = refined_layering(options, factor)
    layer_z, layer_stride = layer_layout(n * factor, spacing / factor, layering)
    if options.blend_zone == "coarse" and level > 0:
        return coarse_blend_zone(layer_z, layer_stride, layering)
    return layer_z, layer_stride


def coarse_blend_zone(layer_z: np.ndarray, layer_stride: np.ndarray, options: MeshOptions
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The layering with its blend zone below the top ``fine_layers`` at the previous level's
    resolution: those thin (stride 1) blend layers merged in pairs into layers twice as thick,
    of stride 2 (an odd one left, the one under the fine layers); the layers below unchanged.

    The merged layers' node layers lie on the original ones, so the blend depth stays a node
    layer and the blend map stays trilinear in every cell; the fine layers keep the finest
    grid, the 2:1 interface below them hangs exactly (``hanging_masters``).

    Parameters
    ----------
    layer_z, layer_stride : numpy.ndarray
        A layering of :func:`geometry.mesh.layer_layout` (node z [m] and cell-layer strides
        [finest spacings], bottom to top) whose top ``options.blend_layers`` cell layers are
        the thin stride-1 blend zone.
    options : MeshOptions
        Its layering (``fine_layers``, ``blend_layers`` counted in those thin layers).
    """
    thin = max(options.fine_layers, options.blend_layers)
    pairs = (thin - options.fine_layers) // 2
    if pairs == 0:
        return layer_z, layer_stride
    first = len(layer_stride) - thin  # the lowest thin cell layer (node layer below it)
    merged = np.arange(first + 1, first + 2 * pairs, 2)  # node layers inside the pairs
    strides = np.concatenate([layer_stride[:first], np.full(pairs, 2 * layer_stride[first]),
                              layer_stride[first + 2 * pairs:]])
    return np.delete(layer_z, merged), strides


def adaptive_layout(n: int, spacing: float, level: int, zone: np.ndarray,
                    options: MeshOptions) -> AdaptiveLayout:
    """The block under an n x n surface with the ``zone`` refined ``level`` times.

    Parameters
    ----------
    n : int
        Own-grid cells per side [-].
    spacing : float
        Own grid spacing h [m].
    level : int
        L: the zone is refined to h / 2^L [-], >= 0.
    zone : numpy.ndarray
        Cells to refine, bool: own-grid cells, shape (n, n), or cells of a finer level m <= L,
        shape (n 2^m, n 2^m).
    options : MeshOptions
        Layering (:func:`adaptive_layers`).
    """
    if isinstance(level, bool) or int(level) != level or level < 0:
        raise InputError(f"refinement level must be an integer >= 0, got {level!r}")
    return levels_layout(n, spacing, level, surface_levels(n, level, zone), options)


def levels_layout(n: int, spacing: float, level: int, surface_level: np.ndarray,
                  options: MeshOptions) -> AdaptiveLayout:
    """The level-L block under an n x n surface whose surface cells have the levels
    ``surface_level`` (``CellSizes.surface_level``), layered by :func:`adaptive_layers`."""
    layer_z, layer_stride = adaptive_layers(n, spacing, level, options)
    cells = CellSizes(surface_level, level, layer_stride)
    return AdaptiveLayout(n, spacing, cells, layer_z, options.blend_layers * spacing)


def block_layout(n: int, spacing: float, options: MeshOptions) -> AdaptiveLayout:
    """The layout of the block under an n x n surface of spacing h [m]: the zone and level of
    ``options.refinement`` (:func:`adaptive_layout`), or without one level 0, the surface's own
    grid everywhere (the 2:1 coarsened layers of ``geometry.mesh.layer_layout`` below it; its
    surface levels a read-only view of one 0, so that the memory gate can size any N)."""
    refinement = options.refinement
    if refinement is None:
        return levels_layout(n, spacing, 0, np.broadcast_to(np.int8(0), (n, n)), options)
    return adaptive_layout(n, spacing, refinement.level, refinement.zone, options)


def surface_levels(n: int, level: int, zone: np.ndarray) -> np.ndarray:
    """Level of the surface cell covering each finest cell (:func:`balanced_levels`) of an
    n x n surface with ``zone`` (own cells, or cells of a level m <= L) refined to ``level``,
    shape (n 2^L, n 2^L), int8."""
    zone = np.asarray(zone, dtype=bool)
    zone_levels = {n << m: m for m in range(level + 1)}
    if zone.ndim != 2 or zone.shape[0] != zone.shape[1] or zone.shape[0] not in zone_levels:
        raise InputError(f"refinement zone must be n 2^m x n 2^m cells with n = {n}, "
                         f"0 <= m <= {level}; got {zone.shape}")
    return balanced_levels(zone, level, zone_levels[zone.shape[0]])


def zone_escaped(levels: np.ndarray, level: int, contact: np.ndarray) -> bool:
    """Whether contact reached the edge of the refined zone: a surface cell coarser than
    ``level`` (2:1 transition or own grid) has a node in ``contact`` as a corner
    (:func:`uncovered_nodes`)."""
    return bool(np.any(uncovered_nodes(levels, level, contact)))


def uncovered_nodes(levels: np.ndarray, level: int, contact: np.ndarray) -> np.ndarray:
    """The nodes in ``contact`` that are a corner of a surface cell coarser than ``level``.

    Parameters
    ----------
    levels : numpy.ndarray
        Surface cell levels on the finest grid (:func:`surface_levels`), shape (N, N).
    level : int
        L [-].
    contact : numpy.ndarray
        Nodes in contact on the finest grid, bool, shape (N, N) (a coarse face's interior grid
        points are never in contact: its corners are).

    Returns
    -------
    numpy.ndarray
        bool, shape (N, N).
    """
    coarse = np.asarray(levels) < level
    around = coarse.copy()  # node (i, j) is a corner of cells (i - 1 .. i, j - 1 .. j)
    for shift in ((1, 0), (0, 1), (1, 1)):
        around |= np.roll(coarse, shift, axis=(0, 1))
    return np.asarray(contact, dtype=bool) & around


def interpolated_in_cells(values: np.ndarray, levels: np.ndarray, level: int) -> np.ndarray:
    """A nodal field of the surface given at the free nodes only (NaN at the grid points inside
    a coarse cell or hanging on its edge), completed by the bilinear interpolation of the
    corners of the coarsest surface cell each such point lies on: the field a bilinear (Q1)
    surface carries there.

    Parameters
    ----------
    values : numpy.ndarray
        Nodal values on the finest grid, NaN where there is no free node, shape (N, N).
    levels : numpy.ndarray
        Surface cell levels on the finest grid (:func:`surface_levels`), shape (N, N).
    level : int
        L [-].

    Returns
    -------
    numpy.ndarray
        float, shape (N, N); NaN only where ``values`` has no value at a cell's corners.
    """
    result = np.array(values, dtype=float)
    levels = np.asarray(levels)
    size = result.shape[0]
    for _ in range(level + 1):  # a corner hanging on a coarser cell is filled a pass later
        i, j = np.nonzero(np.isnan(result))
        if i.size == 0:
            break
        # of the 4 cells around node (i, j) (cells i - 1 .. i, j - 1 .. j), the coarsest
        around = [((i - di) % size, (j - dj) % size) for di in (0, 1) for dj in (0, 1)]
        cell_levels = np.stack([levels[ci, cj] for ci, cj in around])
        pick = np.argmin(cell_levels, axis=0)
        ci = np.choose(pick, [ci for ci, _ in around])
        cj = np.choose(pick, [cj for _, cj in around])
        width = 1 << (level - cell_levels.min(axis=0).astype(int))
        i0, j0 = ci - ci % width, cj - cj % width
        s, t = ((i - i0) % size) / width, ((j - j0) % size) / width
        i1, j1 = (i0 + width) % size, (j0 + width) % size
        result[i, j] = ((1 - s) * (1 - t) * result[i0, j0] + s * (1 - t) * result[i1, j0]
                        + (1 - s) * t * result[i0, j1] + s * t * result[i1, j1])
    return result


def overlapped_nodes(heights: np.ndarray, level: int, flat_height: float) -> np.ndarray:
    """Nodes of level L's finest grid where a rigid flat at ``flat_height`` [m] above the mean
    plane overlaps the undeformed surface: the mean-free bilinear surface of the own-grid
    ``heights`` (n, n) [m] at or above it. Under a compressive load the surface only moves
    down (Boussinesq), so a node can touch the flat at that height only if it is one of
    these: bool, shape (n 2^L, n 2^L)."""
    heights = np.asarray(heights, dtype=float)
    return bilinear_refine(heights - heights.mean(), 1 << level) >= flat_height


def refinement_after(refinement: ZoneRefinement | None, contact: np.ndarray, margin: int,
                     near: np.ndarray | None = None) -> ZoneRefinement:
    """The zone refinement one level finer than ``refinement`` (None: no refinement, level 0):
    level L + 1 over the cells of level L's finest grid (h / 2^L) touching a node in
    ``contact`` (bool, that grid's shape), dilated by ``margin`` of those cells
    (:func:`cells_at_nodes`), and the cells touching a node in ``near`` (bool, optional)."""
    level = 0 if refinement is None else refinement.level
    zone = cells_at_nodes(np.asarray(contact, dtype=bool), margin)
    if near is not None:
        zone |= cells_at_nodes(np.asarray(near, dtype=bool))
    return ZoneRefinement(level + 1, zone)


def _corners(i0: np.ndarray, j0: np.ndarray, width: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Finest indices of the 4 corners of squares, counter-clockwise from (i0, j0), (m, 4)."""
    square = np.array([(0, 0), (1, 0), (1, 1), (0, 1)])
    return (i0[:, None] + width[:, None] * square[:, 0],
            j0[:, None] + width[:, None] * square[:, 1])


def corner_keys(cells: CellSizes, layer: int) -> np.ndarray:
    """Keys i (N + 1) + j of the 4 corners of each cell of one cell layer (``layer_cells``
    order, corners counter-clockwise), shape (m, 4)."""
    corner_i, corner_j = _corners(*cells.layer_cells(layer))
    return corner_i * (cells.grid_size + 1) + corner_j


def adaptive_block(cells: CellSizes) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and hexahedra of a block with a quadtree per cell layer, in finest grid units.

    Node layer k holds the corners of the cells of cell layer k (the top one those of the top
    layer), which include those of the coarser layer below; periodic images (i = N or j = N)
    are nodes of their own (tied to their originals by ``solver/periodic.py``). Layers of one
    stride have the same cells, which are laid out once.

    Returns
    -------
    grid : numpy.ndarray
        (i, j, k) of every node, shape (num_nodes, 3), by layer, then i, then j.
    hexahedra : numpy.ndarray
        Node numbers of each cell in gmsh order (bottom face counter-clockwise, then top),
        shape (num_cells, 8).
    """
    side = cells.grid_size + 1
    strides = [int(stride) for stride in cells.layer_stride]
    keys = {}  # the corner keys of the cells of a layer, by stride
    for layer, stride in enumerate(strides):
        if stride not in keys:
            keys[stride] = corner_keys(cells, layer)
    nodes = {stride: np.unique(corners) for stride, corners in keys.items()}
    node_strides = strides + strides[-1:]  # node layer k: the corners of cell layer k
    offsets = np.cumsum([0] + [len(nodes[stride]) for stride in node_strides])
    grid = np.concatenate([np.column_stack([nodes[stride] // side, nodes[stride] % side,
                                            np.full(len(nodes[stride]), k)])
                           for k, stride in enumerate(node_strides)])
    number = {}  # a cell layer's corners numbered in a node layer, by the two strides
    hexahedra = []
    for layer, stride in enumerate(strides):
        faces = []
        for k in (layer, layer + 1):
            pair = (stride, node_strides[k])
            if pair not in number:
                number[pair] = np.searchsorted(nodes[pair[1]], keys[stride])
            faces.append(offsets[k] + number[pair])
        hexahedra.append(np.hstack(faces))
    return grid, np.concatenate(hexahedra)


def hanging_masters(grid: np.ndarray, cells: CellSizes) -> tuple[np.ndarray, np.ndarray]:
    """Where each node's displacement comes from: itself, or for a hanging node the corners of
    the coarse face it lies on, bilinearly (linearly on a coarse edge).

    A node hangs when it lies on the top or bottom face of a cell (of the cell layer below or
    above its node layer, periodically) without being one of its corners; it is tied to the
    widest such face, which is exact for trilinear hexahedra. In the layouts of
    :func:`adaptive_layout` (2:1 balanced across edges and corners) no master hangs itself.

    Parameters
    ----------
    grid : numpy.ndarray
        (i, j, k) of nodes, shape (m, 3) (i, j in 0 .. N).
    cells : CellSizes
        The block's cell sizes.

    Returns
    -------
    masters : numpy.ndarray
        (i, j, k) of up to 4 master nodes per node, shape (m, 4, 3), i and j possibly outside
        0 .. N (a periodic image); unused slots repeat the first master with weight 0.
    weights : numpy.ndarray
        Interpolation weights, shape (m, 4), summing to 1, largest first: (1, 0, 0, 0) for a
        node that does not hang, (1/2, 1/2, 0, 0) at a coarse edge's midpoint, 1/4 each at a
        coarse face's centre.
    """
    i, j, k = np.asarray(grid, dtype=np.int64).T
    width = np.zeros_like(i)  # of the widest face the node hangs on (0: none)
    first_i, first_j = i.copy(), j.copy()
    for layer in (k - 1, k):  # the cell layers below and above node layer k
        inside = (layer >= 0) & (layer < cells.num_layers)
        layer = np.clip(layer, 0, cells.num_layers - 1)
        for a, b in ((i - 1, j - 1), (i - 1, j), (i, j - 1), (i, j)):  # finest cells at the node
            size = cells.size(layer, a, b)
            i0, j0 = a // size * size, b // size * size
            wider = inside & (((i - i0) % size != 0) | ((j - j0) % size != 0)) & (size > width)
            width = np.where(wider, size, width)
            first_i, first_j = np.where(wider, i0, first_i), np.where(wider, j0, first_j)
    hanging = width > 0
    span = np.where(hanging, width, 1)
    t_i, t_j = (i - first_i) / span, (j - first_j) / span
    masters = np.stack([np.column_stack([first_i + a * span, first_j + b * span, k])
                        for a in (0, 1) for b in (0, 1)], axis=1)
    weights = np.column_stack([(t_i if a else 1.0 - t_i) * (t_j if b else 1.0 - t_j)
                               for a in (0, 1) for b in (0, 1)])
    # largest weight first; unused slots repeat it
    order = np.argsort(-weights, axis=1, kind="stable")
    weights = np.take_along_axis(weights, order, axis=1)
    masters = np.take_along_axis(masters, order[:, :, None], axis=1)
    masters = np.where((weights > 0.0)[:, :, None], masters, masters[:, :1])
    return masters, weights


def node_coordinates(layout: AdaptiveLayout, grid: np.ndarray, heights: np.ndarray
                     ) -> np.ndarray:
    """Node coordinates [m] on the surface: the flat block with the mean-free bilinear surface
    of the own-grid ``heights`` (n, n) [m], faded linearly over the blend zone.

    Returns
    -------
    numpy.ndarray
        x, y, z of the nodes [m], shape (m, 3).
    """
    heights = np.asarray(heights, dtype=float)
    if heights.shape != (layout.n, layout.n):
        raise InputError(f"heights must be {layout.n} x {layout.n}, got {heights.shape}")
    n, (i, j, k) = layout.grid_size, np.asarray(grid).T
    surface = bilinear_refine(heights - heights.mean(), 1 << layout.level)
    flat_z = layout.layer_z[k]
    fade = np.clip(1.0 + flat_z / layout.blend_depth, 0.0, 1.0)
    return np.column_stack([i * layout.fine_spacing, j * layout.fine_spacing,
                            flat_z + fade * surface[i % n, j % n]])


def block_nodes(layout: AdaptiveLayout, heights: np.ndarray) -> BlockNodes:
    """The whole block of ``layout`` on one process, its nodes on the bilinear surface of the
    own-grid ``heights`` (n, n) [m] (:func:`node_coordinates`, the paper's moving-node method),
    its cells x-major (contiguous ranges of cells are x-slabs of whole columns)."""
    grid, hexahedra = adaptive_block(layout.cells)
    i, j, k = grid[hexahedra[:, 0]].T  # each cell's first corner: unique, so a sort key
    side = layout.grid_size + 1
    hexahedra = hexahedra[np.argsort((i * side + j) * (layout.num_layers + 1) + k)]
    return BlockNodes(layout, grid, node_coordinates(layout, grid, heights), hexahedra)
