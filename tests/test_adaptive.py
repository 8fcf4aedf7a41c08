"""The block layout (geometry.adaptive): level 0 and the contact-adaptive levels, quadtree
layers, 2:1 balance, hanging-node masters, blend depth."""

from dataclasses import replace

import numpy as np
import pytest
from roughfriction.case import MeshOptions, ZoneRefinement
from roughfriction.errors import InputError
from roughfriction.geometry.adaptive import (
    CellSizes,
    adaptive_block,
    adaptive_layers,
    adaptive_layout,
    balanced_levels,
    block_layout,
    cells_at_nodes,
    dilate,
    hanging_masters,
    interpolated_in_cells,
    node_coordinates,
    overlapped_nodes,
    surface_levels,
    uncovered_nodes,
    zone_escaped,
)
from roughfriction.geometry.mesh import (
    MIN_JACOBIAN_RATIO,
    blend_layers_needed,
    corner_jacobians,
    layer_layout,
)
from roughfriction.geometry.surface import bilinear_refine

SPACING = 1e-6
#: gmsh hexahedron corners in dolfinx's tensor-product order (a + 2 b + 4 c).
TENSOR_ORDER = [0, 1, 3, 2, 4, 5, 7, 6]


def patches(n, seed=0, fraction=0.08, margin=1):
    """A zone mask: random own cells dilated by ``margin``."""
    return dilate(np.random.default_rng(seed).random((n, n)) < fraction, margin)


def as_sets(grid, hexahedra):
    """Nodes as a set of (i, j, k), cells as a set of sorted corner tuples."""
    nodes = {tuple(node) for node in grid}
    cells = {tuple(sorted(map(tuple, grid[cell]))) for cell in hexahedra}
    return nodes, cells


LAYERINGS = [MeshOptions(), MeshOptions(blend_layers=3, fine_layers=1), MeshOptions(blend_layers=5),
             MeshOptions(coarsen=False, growth=2.0)]


def reduced_dofs(grid, cells):
    """Reduced dofs of a built block: 3 per node above the bottom that is neither a periodic
    image (i = N or j = N) nor hanging (``hanging_masters``) [-]."""
    n = cells.grid_size
    _, weights = hanging_masters(grid, cells)
    own = (grid[:, 0] < n) & (grid[:, 1] < n) & (grid[:, 2] > 0) & (weights[:, 0] == 1.0)
    return 3 * int(np.count_nonzero(own))


def level_0(n, layer_stride):
    """The cell sizes of an unrefined n x n surface, cell layers ``layer_stride`` wide."""
    return CellSizes(np.zeros((n, n), dtype=np.int8), 0, np.asarray(layer_stride))


@pytest.mark.parametrize("options", LAYERINGS)
def test_without_refinement_the_block_is_level_0_of_the_own_grid(options):
    """``block_layout``: no zone is level 0, the own grid over ``layer_layout``'s layers; a
    ``ZoneRefinement`` is its adaptive layout."""
    n = 8
    layout = block_layout(n, SPACING, options)
    layer_z, layer_stride = layer_layout(n, SPACING, options)
    assert layout.level == 0 and layout.grid_size == n and layout.fine_spacing == SPACING
    assert not layout.cells.surface_level.any()
    np.testing.assert_allclose(layout.layer_z, layer_z, rtol=0, atol=1e-18)
    np.testing.assert_array_equal(layout.cells.layer_stride, layer_stride)
    grid, hexahedra = adaptive_block(layout.cells)
    # node layer k >= 1 holds its own dofs at the stride of the cell layer under it
    assert len(hexahedra) == sum((n // s) ** 2 for s in layer_stride)
    assert reduced_dofs(grid, layout.cells) == 3 * sum((n // s) ** 2 for s in layer_stride)
    zone = patches(n)
    refined = block_layout(n, SPACING, replace(options, refinement=ZoneRefinement(2, zone)))
    expected = adaptive_layout(n, SPACING, 2, zone, options)
    np.testing.assert_array_equal(refined.cells.surface_level, expected.cells.surface_level)
    np.testing.assert_array_equal(refined.layer_z, expected.layer_z)


def test_level_0_cells_use_only_existing_nodes_and_cover_the_block():
    n, stride = 8, np.array([4, 2, 2, 1])
    grid, hexahedra = adaptive_block(level_0(n, stride))
    assert len(hexahedra) == sum((n // s) ** 2 for s in stride)
    assert len(np.unique(grid, axis=0)) == len(grid)
    corners = grid[hexahedra]  # (cells, 8, 3), gmsh order: bottom face then top face
    assert np.all(corners[:, :4, 2] + 1 == corners[:, 4:, 2])
    width = corners[:, 2, 0] - corners[:, 0, 0]
    assert np.array_equal(width, stride[corners[:, 0, 2]])


def test_hanging_nodes_interpolate_the_corners_of_the_coarse_face():
    # cell layer 0 coarse, 1 fine: node layer 1 is the interface
    cells = level_0(4, [2, 1])
    grid = np.array([[2, 4, 1], [1, 4, 1], [2, 3, 1], [1, 3, 1], [1, 3, 2], [2, 2, 0]])
    masters, weights = hanging_masters(grid, cells)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0)
    expected = [{(2, 4, 1): 1.0}, {(0, 4, 1): 0.5, (2, 4, 1): 0.5},
                {(2, 2, 1): 0.5, (2, 4, 1): 0.5},
                {(0, 2, 1): 0.25, (0, 4, 1): 0.25, (2, 2, 1): 0.25, (2, 4, 1): 0.25},
                {(1, 3, 2): 1.0}, {(2, 2, 0): 1.0}]
    for node, weights_of in enumerate(expected):
        found = {tuple(m): w for m, w in zip(masters[node], weights[node], strict=True) if w}
        assert found == weights_of


@pytest.mark.parametrize("level", [1, 2, 3])
@pytest.mark.parametrize("options", LAYERINGS)
def test_an_all_zone_mask_gives_the_level_0_block_of_its_layers(level, options):
    n = 4
    layout = adaptive_layout(n, SPACING, level, np.ones((n, n), bool), options)
    big_n = n * 2**level
    grid, hexahedra = adaptive_block(layout.cells)
    assert as_sets(grid, hexahedra) == as_sets(*adaptive_block(
        level_0(big_n, layout.cells.layer_stride)))
    # node layer k >= 1 holds its own dofs at the stride of the cell layer under it
    assert reduced_dofs(grid, layout.cells) == 3 * sum((big_n // s) ** 2
                                                       for s in layout.cells.layer_stride)
    # --refine's meshes: max(fine_layers, 2^L blend_layers) layers h / 2^L thick on top
    thickness = np.diff(layout.layer_z)[::-1]
    fine = max(options.fine_layers, 2**level * options.blend_layers)
    np.testing.assert_allclose(thickness[:fine], SPACING / 2**level)
    assert np.all(thickness >= SPACING / 2**level * (1 - 1e-12))


@pytest.mark.parametrize("level", [1, 2])
@pytest.mark.parametrize("options", LAYERINGS)
def test_an_all_zone_mask_gives_the_level_0_block_of_the_re_gridded_surface(level, options):
    """The adaptive block refined everywhere is the level-0 block of the 2^L re-gridded
    bilinear surface with a blend zone as deep in metres (2^L times the layers): the adaptive
    and the uniform ladder mesh the same block."""
    n, factor = 4, 2**level
    heights = rough(n, 0.2 * SPACING, seed=8)
    layout = adaptive_layout(n, SPACING, level, np.ones((n, n), bool), options)
    blend = factor * options.blend_layers
    uniform = MeshOptions(fine_layers=options.fine_layers, blend_layers=blend,
                          coarsen=options.coarsen, growth=options.growth, depth=options.depth)
    layer_z, layer_stride = layer_layout(factor * n, SPACING / factor, uniform)
    np.testing.assert_allclose(layout.layer_z, layer_z, rtol=0, atol=1e-18)
    np.testing.assert_array_equal(layout.cells.layer_stride, layer_stride)
    grid, hexahedra = adaptive_block(layout.cells)
    fine_layout = block_layout(factor * n, SPACING / factor, uniform)
    assert as_sets(grid, hexahedra) == as_sets(*adaptive_block(fine_layout.cells))
    fine = bilinear_refine(heights, factor)
    fine -= fine.mean()
    i, j, k = grid.T
    blend_weight = np.clip(1.0 - (len(layer_stride) - k) / blend, 0.0, 1.0)
    expected_z = layer_z[k] + blend_weight * fine[i % (factor * n), j % (factor * n)]
    np.testing.assert_allclose(node_coordinates(layout, grid, heights)[:, 2], expected_z,
                               rtol=0, atol=1e-18)
    np.testing.assert_allclose(node_coordinates(fine_layout, grid, fine)[:, 2], expected_z,
                               rtol=0, atol=1e-18)


def test_the_surface_quadtree_is_refined_in_the_zone_and_2_to_1_balanced():
    n, level = 8, 3
    zone = patches(n, seed=2, margin=0)
    assert 0 < zone.sum() < n * n // 4
    levels = balanced_levels(zone, level)
    factor = 2**level
    own = levels.reshape(n, factor, n, factor).transpose(0, 2, 1, 3)  # (I, J, a, b)
    assert np.all(own[zone] == level)  # the zone at the finest level
    assert np.any(own[~zone] == 0)  # the rest as coarse as the balance allows
    for shift in ((1, 0), (0, 1), (1, 1), (1, -1)):  # across edges and corners, periodically
        assert np.abs(levels - np.roll(levels, shift, axis=(0, 1))).max() <= 1
    # aligned squares: the cell of level l covering a finest cell is one constant square
    width = 2 ** (level - levels.astype(int))
    i, j = np.meshgrid(np.arange(n * factor), np.arange(n * factor), indexing="ij")
    first_i, first_j = i // width * width, j // width * width
    np.testing.assert_array_equal(levels, levels[first_i, first_j])


def test_a_zone_on_a_finer_grid_refines_only_its_cells():
    """The contact of level 1 marks half cells: level 2 refines them, not their whole own cell."""
    n = 4
    zone = np.zeros((2 * n, 2 * n), bool)
    zone[2, 3] = True  # one h / 2 cell, in own cell (1, 1)
    levels = adaptive_layout(n, SPACING, 2, zone, MeshOptions()).cells.surface_level
    assert np.all(levels[4:6, 6:8] == 2) and np.sum(levels == 2) == 4
    assert levels[4, 4] == 1 and np.all(levels[:, 12:] == 0)  # balanced around it, coarse away


def test_each_layer_is_balanced_and_no_finer_than_the_layer_above():
    layout = adaptive_layout(8, SPACING, 2, patches(8, seed=1), MeshOptions())
    cells = layout.cells
    i, j = np.meshgrid(np.arange(cells.grid_size), np.arange(cells.grid_size), indexing="ij")
    sizes = np.array([cells.size(layer, i, j) for layer in range(cells.num_layers)])
    assert np.all((sizes[:-1] == sizes[1:]) | (sizes[:-1] == 2 * sizes[1:]))
    for shift in ((1, 0), (0, 1), (1, 1), (1, -1)):
        ratio = sizes / np.roll(sizes, shift, axis=(1, 2))
        assert set(np.unique(ratio)) <= {0.5, 1.0, 2.0}
    # the cells tile every layer once
    for layer in range(cells.num_layers):
        _, _, width = cells.layer_cells(layer)
        assert np.sum(width.astype(float) ** 2) == cells.grid_size**2


def trilinear(points, coefficients):
    """c . (1, i, j, k, ij, ik, jk, ijk) at (i, j, k) points, any leading shape."""
    i, j, k = (points[..., axis].astype(float) for axis in range(3))
    terms = np.stack([np.ones_like(i), i, j, k, i * j, i * k, j * k, i * j * k], axis=-1)
    return terms @ coefficients


@pytest.mark.parametrize("blend_zone", ["fine", "coarse"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_masters_of_every_node_reproduce_trilinear_fields(seed, blend_zone):
    layout = adaptive_layout(6, SPACING, 2, patches(6, seed=seed),
                             MeshOptions(blend_layers=3, blend_zone=blend_zone))
    grid, _ = adaptive_block(layout.cells)
    masters, weights = hanging_masters(grid, layout.cells)
    hanging = weights[:, 0] < 1.0
    assert hanging.sum() > 0.1 * len(grid)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0)
    assert set(np.unique(weights[hanging][:, :2].round(12))) <= {0.25, 0.5}
    for coefficients in np.random.default_rng(seed).normal(size=(3, 8)):
        expected = trilinear(grid, coefficients)
        interpolated = (weights * trilinear(masters, coefficients)).sum(axis=1)
        np.testing.assert_allclose(interpolated, expected, rtol=1e-12, atol=1e-9)
    # the masters (periodically) are nodes that do not hang themselves
    n = layout.grid_size
    key = (grid[:, 2] * n + grid[:, 0] % n) * n + grid[:, 1] % n
    free_keys = set(key[~hanging])
    used = masters[weights > 0.0]
    assert set((used[:, 2] * n + used[:, 0] % n) * n + used[:, 1] % n) <= free_keys


def expand_random_field(grid, cells, seed=0):
    """A random value per reduced node (periodic, bottom included), carried to every node."""
    n = cells.grid_size
    masters, weights = hanging_masters(grid, cells)
    key = lambda p: (p[..., 2] * n + p[..., 0] % n) * n + p[..., 1] % n  # noqa: E731
    values = np.random.default_rng(seed).normal(size=(cells.num_layers + 1) * n * n)
    return (weights * values[key(masters)]).sum(axis=1)


@pytest.mark.parametrize("level", [1, 2])
def test_the_field_is_continuous_across_every_2_to_1_interface(level):
    """Every node on a cell's top or bottom face (edges included) carries the bilinear
    interpolation of that face's corners: no gap between coarse and fine cells."""
    cells = adaptive_layout(4, SPACING, level, patches(4, seed=3, fraction=0.15),
                            MeshOptions(fine_layers=2)).cells
    grid, hexahedra = adaptive_block(cells)
    u = expand_random_field(grid, cells)
    checked = 0
    for cell in hexahedra:
        for face in (cell[:4], cell[4:]):
            corners = grid[face]
            (i0, j0, k), width = corners[0], corners[1, 0] - corners[0, 0]
            on_face = np.flatnonzero((grid[:, 2] == k) & (grid[:, 0] >= i0)
                                     & (grid[:, 0] <= i0 + width) & (grid[:, 1] >= j0)
                                     & (grid[:, 1] <= j0 + width))
            t_i = (grid[on_face, 0] - i0) / width
            t_j = (grid[on_face, 1] - j0) / width
            bilinear = ((1 - t_i) * (1 - t_j) * u[face[0]] + t_i * (1 - t_j) * u[face[1]]
                        + t_i * t_j * u[face[2]] + (1 - t_i) * t_j * u[face[3]])
            np.testing.assert_allclose(u[on_face], bilinear, rtol=1e-12, atol=1e-12)
            checked += len(on_face) - 4
    assert checked > 0  # some faces carry hanging nodes


def rough(n, rms, seed=0):
    return np.random.default_rng(seed).normal(0.0, rms, (n, n))


def jacobian_ratio(layout, heights):
    """Smallest corner Jacobian of each moved cell over the flat cell's [-]."""
    grid, hexahedra = adaptive_block(layout.cells)
    cell_nodes = hexahedra[:, TENSOR_ORDER]
    moved = node_coordinates(layout, grid, heights)
    flat = node_coordinates(layout, grid, np.zeros_like(heights))
    return (corner_jacobians(moved, cell_nodes) / corner_jacobians(flat, cell_nodes)).min(axis=1)


@pytest.mark.parametrize("blend_zone", ["fine", "coarse"])
@pytest.mark.parametrize("level", [0, 1, 2])
def test_cell_jacobians_stay_positive_on_a_rough_surface(level, blend_zone):
    n = 8
    heights = rough(n, 1.0 * SPACING, seed=4)  # valleys a few grid spacings deep
    needed = blend_layers_needed(heights, SPACING)
    assert needed > 2
    zone = patches(n, seed=4)
    options = MeshOptions(blend_layers=needed, blend_zone=blend_zone)
    layout = adaptive_layout(n, SPACING, level, zone, options)
    assert jacobian_ratio(layout, heights).min() >= MIN_JACOBIAN_RATIO
    # the check can fail: half the blend depth inverts cells
    thin = adaptive_layout(n, SPACING, level, zone, replace(options, blend_layers=needed // 3))
    assert jacobian_ratio(thin, heights).min() <= 0.0


@pytest.mark.parametrize("blend_zone", ["fine", "coarse"])
def test_the_blend_zone_has_the_same_depth_in_metres_at_every_level(blend_zone):
    n, options = 8, MeshOptions(blend_layers=3, fine_layers=2, blend_zone=blend_zone)
    heights = rough(n, 0.3 * SPACING, seed=5)
    zone = patches(n, seed=5)
    for level in range(4):
        layout = adaptive_layout(n, SPACING, level, zone, options)
        assert layout.blend_depth == pytest.approx(3 * SPACING, rel=1e-12)
        assert np.min(np.abs(layout.layer_z + layout.blend_depth)) < 1e-9 * SPACING  # a node layer
        grid, _ = adaptive_block(layout.cells)
        z = node_coordinates(layout, grid, heights)[:, 2]
        flat = layout.layer_z[grid[:, 2]]
        deep = flat <= -layout.blend_depth * (1 + 1e-9)
        np.testing.assert_array_equal(z[deep], flat[deep])  # no roughness below it ...
        # ... and a linear fade above it, the same at every level (at the own grid's points)
        own = (grid[~deep, 0] % 2**level == 0) & (grid[~deep, 1] % 2**level == 0)
        i, j = grid[~deep][own, 0] // 2**level % n, grid[~deep][own, 1] // 2**level % n
        expected = (1 + flat[~deep][own] / layout.blend_depth) * (heights - heights.mean())[i, j]
        np.testing.assert_allclose((z - flat)[~deep][own], expected, rtol=1e-12, atol=1e-20)


@pytest.mark.parametrize("level", [1, 2, 3])
@pytest.mark.parametrize("options", [MeshOptions(), MeshOptions(blend_layers=3),
                                     MeshOptions(blend_layers=3, fine_layers=1),
                                     MeshOptions(fine_layers=5)])
def test_the_coarse_blend_zone_has_the_previous_level_s_cells_below_the_fine_layers(level,
                                                                                  options):
    """The coarse blend zone keeps the fine layers (an odd thin layer under them where the
    blend zone's thin layers do not pair up), merges the other thin blend layers in pairs
    into layers of stride 2 on the fine zone's own node layers, and leaves the layers below
    the blend depth as they are; level 0 is unchanged."""
    fine_z, fine_stride = adaptive_layers(8, SPACING, level, options)
    z, stride = adaptive_layers(8, SPACING, level, replace(options, blend_zone="coarse"))
    thin = max(options.fine_layers, 2**level * options.blend_layers)
    pairs = (thin - options.fine_layers) // 2
    assert len(stride) == len(fine_stride) - pairs and len(z) == len(stride) + 1
    assert set(np.round(z / SPACING, 9)) <= set(np.round(fine_z / SPACING, 9))
    blend = len(fine_stride) - thin  # cell layers below the blend zone, bottom up
    np.testing.assert_array_equal(stride[:blend], fine_stride[:blend])
    np.testing.assert_array_equal(z[:blend + 1], fine_z[:blend + 1])
    kept_thin = thin - 2 * pairs
    np.testing.assert_array_equal(stride[blend:], [2] * pairs + [1] * kept_thin)
    np.testing.assert_allclose(np.diff(z[blend:]), [2**(1 - level) * SPACING] * pairs
                               + [2**-level * SPACING] * kept_thin, rtol=1e-9)
    unrefined = adaptive_layers(8, SPACING, 0, replace(options, blend_zone="coarse"))
    for coarse, plain in zip(unrefined, adaptive_layers(8, SPACING, 0, options), strict=True):
        np.testing.assert_array_equal(coarse, plain)


def test_a_blend_zone_other_than_fine_or_coarse_is_refused():
    with pytest.raises(InputError, match="blend_zone must be one of fine, coarse"):
        MeshOptions(blend_zone="medium")


def test_every_level_meshes_the_same_bilinear_surface():
    n = 4
    heights = rough(n, 0.3 * SPACING, seed=6)
    coarse = adaptive_layout(n, SPACING, 0, np.zeros((n, n), bool), MeshOptions())
    fine = adaptive_layout(n, SPACING, 2, patches(n, seed=6, fraction=0.2), MeshOptions())
    grid, _ = adaptive_block(fine.cells)
    top = grid[grid[:, 2] == fine.num_layers]
    z = node_coordinates(fine, top, heights)[:, 2]
    # the own-grid mesh's surface at the same points: bilinear in each own cell
    x = top[:, :2] / 4.0
    i0 = np.floor(x).astype(int)
    t = x - i0
    z_mean_free = heights - heights.mean()
    corner = lambda a, b: z_mean_free[(i0[:, 0] + a) % n, (i0[:, 1] + b) % n]  # noqa: E731
    expected = ((1 - t[:, 0]) * (1 - t[:, 1]) * corner(0, 0) + t[:, 0] * (1 - t[:, 1])
                * corner(1, 0) + t[:, 0] * t[:, 1] * corner(1, 1)
                + (1 - t[:, 0]) * t[:, 1] * corner(0, 1))
    np.testing.assert_allclose(z, expected, rtol=0, atol=1e-18)
    assert coarse.num_layers < fine.num_layers


@pytest.mark.parametrize("arguments", [
    {"zone": np.ones((3, 3), bool)}, {"zone": np.ones((16, 16), bool)},
    {"zone": np.ones((4, 8), bool)}, {"level": -1}, {"level": 1.5}, {"level": True}])
def test_bad_adaptive_layouts_are_refused(arguments):
    values = {"n": 4, "spacing": SPACING, "level": 1, "zone": np.ones((4, 4), bool),
              "options": MeshOptions()} | arguments
    with pytest.raises(InputError):
        adaptive_layout(**values)


def test_a_small_zone_costs_a_fraction_of_the_uniform_dofs():
    n, level = 16, 2
    zone = patches(n, seed=7, fraction=0.03, margin=1)
    dofs = {}
    for name, mask in {"adaptive": zone, "uniform": np.ones((n, n), bool)}.items():
        layout = adaptive_layout(n, SPACING, level, mask, MeshOptions())
        dofs[name] = reduced_dofs(adaptive_block(layout.cells)[0], layout.cells)
    unrefined = block_layout(n, SPACING, MeshOptions()).cells
    assert reduced_dofs(adaptive_block(unrefined)[0], unrefined) < dofs["adaptive"]
    assert dofs["adaptive"] < 0.6 * dofs["uniform"]


def uniaxial_strain_error():
    """Periodic sides, fixed bottom, pressure p on top of a flat adaptive block: u_z = -p (z + H)
    / M, u_x = u_y = 0 (M = lambda + 2 mu), which trilinear hexahedra and the hanging-node ties
    hold exactly. Returns the largest nodal error over the largest displacement [-]."""
    import ufl
    from dolfinx import fem
    from dolfinx.fem import petsc as fem_petsc
    from facets import boundary_facet_tags
    from mpi4py import MPI
    from petsc4py import PETSc
    from roughfriction.geometry.mesh import Boundary
    from roughfriction.solver.block import build_block
    from roughfriction.solver.memory import block_size
    from roughfriction.solver.periodic import PeriodicReduction

    n = 4
    zone = patches(n, seed=3, fraction=0.15)
    options = MeshOptions(fine_layers=2, refinement=ZoneRefinement(2, zone))
    layout = adaptive_layout(n, SPACING, 2, zone, options)
    block = build_block(np.zeros((n, n)), SPACING, options, MPI.COMM_WORLD)
    V = fem.VectorFunctionSpace(block.mesh, ("Lagrange", 1))
    reduction = PeriodicReduction(V, block)
    assert 3 * reduction.num_reduced_global == reduced_dofs(adaptive_block(layout.cells)[0],
                                                            layout.cells)
    assert block_size(layout) == (block.mesh.topology.index_map(3).size_global,
                                  3 * reduction.num_reduced_global)
    young, poisson, pressure = 200e9, 0.3, 1e8  # [Pa], [-], [Pa]
    mu, lame = young / (2 * (1 + poisson)), young * poisson / ((1 + poisson) * (1 - 2 * poisson))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    strain = lambda w: ufl.sym(ufl.grad(w))  # noqa: E731
    stress = 2 * mu * strain(u) + lame * ufl.tr(strain(u)) * ufl.Identity(3)
    ds = ufl.Measure("ds", domain=block.mesh, subdomain_data=boundary_facet_tags(block))
    stiffness = fem_petsc.assemble_matrix(fem.form(ufl.inner(stress, strain(v)) * ufl.dx))
    stiffness.assemble()
    load = fem_petsc.assemble_vector(fem.form(-pressure * v[2] * ds(int(Boundary.CONTACT))))
    load.ghostUpdate(PETSc.InsertMode.ADD_VALUES, PETSc.ScatterMode.REVERSE)
    reduced_load = reduction.create_reduced_vector()
    reduction.restrict(load, reduced_load)
    solver = PETSc.KSP().create(block.mesh.comm)
    solver.setOperators(reduction.reduce_matrix(stiffness))
    solver.setType("preonly")
    solver.getPC().setType("lu")
    solver.getPC().setFactorSolverType("mumps")
    solution = reduction.create_reduced_vector()
    solver.solve(reduced_load, solution)
    displacement = fem.Function(V)
    reduction.expand(solution, displacement)

    z = V.tabulate_dof_coordinates()[:, 2]
    expected = np.zeros((len(z), 3))
    expected[:, 2] = -pressure * (z + block.depth) / (lame + 2 * mu)
    error = np.abs(displacement.x.array.reshape(-1, 3) - expected).max()
    comm = block.mesh.comm
    return comm.allreduce(error, op=MPI.MAX) / comm.allreduce(np.abs(expected).max(), op=MPI.MAX)


@pytest.mark.fem
def test_a_flat_adaptive_block_under_uniform_pressure_is_in_uniaxial_strain():
    assert uniaxial_strain_error() < 1e-9


@pytest.mark.mpi
@pytest.mark.fem
def test_the_adaptive_ties_hold_across_ranks():
    """The same on 2 ranks: copies of interface nodes and masters on the other rank."""
    assert uniaxial_strain_error() < 1e-9


def test_the_cells_at_a_contact_node_are_its_four_cells_dilated_periodically():
    nodes = np.zeros((6, 6), bool)
    nodes[0, 3] = True
    cells = cells_at_nodes(nodes)
    assert set(zip(*np.nonzero(cells), strict=True)) == {(5, 2), (5, 3), (0, 2), (0, 3)}
    wider = cells_at_nodes(nodes, margin=1)
    assert wider.sum() == 16 and wider[4, 1] and wider[1, 4] and not wider[2, 2]


@pytest.mark.parametrize(("node", "escaped"), [
    ((6, 6), False), ((9, 6), False),  # inside the zone, the second on its last fine cells
    ((10, 6), True), ((4, 4), True),  # a corner of a cell outside; the zone's corner
])
def test_contact_at_a_cell_outside_the_refined_zone_has_escaped(node, escaped):
    """Own cells 2..4 refined once: fine cells 4..9 are at level 1, the rest coarser."""
    zone = np.zeros((8, 8), bool)
    zone[2:5, 2:5] = True
    levels = surface_levels(8, 1, zone)
    assert (levels == 1).sum() == 36
    contact = np.zeros((16, 16), bool)
    contact[node] = True
    assert zone_escaped(levels, 1, contact) is escaped
    assert not zone_escaped(levels, 1, np.zeros((16, 16), bool))
    assert not zone_escaped(surface_levels(8, 1, np.ones((8, 8), bool)), 1, contact)


def test_the_flat_overlaps_the_bilinear_surface_at_and_above_its_height():
    heights = rough(4, 0.2 * SPACING, seed=5)
    fine = bilinear_refine(heights - heights.mean(), 4)  # level 2
    top = fine.max()
    np.testing.assert_array_equal(overlapped_nodes(heights, 2, top), fine == top)
    assert overlapped_nodes(heights, 2, fine.min()).all()
    assert not overlapped_nodes(heights, 0, top + 1e-12).any()
    assert overlapped_nodes(heights, 0, 0.0).sum() == (heights > heights.mean()).sum()


@pytest.mark.parametrize("level", [1, 2, 3])
def test_a_field_at_the_free_surface_nodes_is_completed_bilinearly_in_each_cell(level):
    """A field bilinear in each own-grid cell (as a Q1 surface's) given at the free surface
    nodes of an adaptive block is reproduced at every other grid point, hanging nodes whose
    master hangs on a coarser cell included (level 3)."""
    n = 6
    layout = adaptive_layout(n, SPACING, level, patches(n, seed=level, fraction=0.1, margin=0),
                             MeshOptions())
    grid, _ = adaptive_block(layout.cells)
    _, weights = hanging_masters(grid, layout.cells)
    size = layout.grid_size
    free = grid[(grid[:, 2] == layout.num_layers) & (weights[:, 0] == 1.0)]
    field = bilinear_refine(rough(n, SPACING, seed=level), 1 << level)
    given = np.full((size, size), np.nan)
    given[free[:, 0] % size, free[:, 1] % size] = field[free[:, 0] % size, free[:, 1] % size]
    assert np.isnan(given).sum() > size  # coarse cells' interiors and hanging nodes
    levels = layout.cells.surface_level
    np.testing.assert_allclose(interpolated_in_cells(given, levels, level), field,
                               rtol=0, atol=1e-12 * SPACING)


def test_uncovered_nodes_are_the_contact_nodes_at_a_cell_outside_the_zone():
    """The four nodes of the parametrised case above at once: the two outside are counted."""
    zone = np.zeros((8, 8), bool)
    zone[2:5, 2:5] = True
    contact = np.zeros((16, 16), bool)
    for node in ((6, 6), (9, 6), (10, 6), (4, 4)):
        contact[node] = True
    uncovered = uncovered_nodes(surface_levels(8, 1, zone), 1, contact)
    assert set(zip(*np.nonzero(uncovered), strict=True)) == {(10, 6), (4, 4)}
