"""The hexahedral block: layering, surface heights on the nodes, tags, Jacobian checks."""

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from mpi4py import MPI  # noqa: E402
from roughfriction.errors import InputError  # noqa: E402
from roughfriction.geometry.mesh import (  # noqa: E402
    Boundary,
    MeshOptions,
    boundary_facet_tags,
    build_block,
    corner_jacobians,
    estimated_memory_gb,
    interpolation_masters,
    layer_layout,
    slab_partitioner,
    structured_block,
)
from roughfriction.solver.run import check_memory  # noqa: E402

pytestmark = pytest.mark.fem

SPACING = 1e-6


def test_uncoarsened_layers_are_fine_then_grow_to_the_depth():
    options = MeshOptions(blend_layers=3, fine_layers=3, coarsen=False, growth=1.5, depth=1.0)
    z, stride = layer_layout(16, SPACING, options)
    thickness = np.diff(z)[::-1]  # top down
    np.testing.assert_allclose(thickness[:3], SPACING)
    np.testing.assert_allclose(thickness[4:] / thickness[3:-1], 1.5)
    assert z[-1] == 0.0
    assert -z[0] >= 16 * SPACING > -z[1]  # the first layer deep enough, and no deeper
    assert np.all(stride == 1)


def test_coarsened_levels_halve_the_lateral_resolution_in_cubic_layers():
    z, stride = layer_layout(32, SPACING, MeshOptions(blend_layers=4, fine_layers=6))
    thickness, stride = np.diff(z)[::-1] / SPACING, stride[::-1]  # top down
    np.testing.assert_array_equal(stride, [1] * 6 + [2, 2, 4, 4, 8, 8])
    np.testing.assert_allclose(thickness[:-1], stride[:-1])  # cubes ...
    assert thickness[-1] == pytest.approx(6.0)  # ... but the deepest, cut to one period
    assert -z[0] == pytest.approx(32 * SPACING, rel=1e-12)
    # N = 12 halves twice (12 / 8 is not whole); the 4h level's second layer would pass the depth
    _, stride = layer_layout(12, SPACING, MeshOptions(fine_layers=4))
    assert set(stride) == {1, 2, 4} and stride[0] == 4


def test_hanging_nodes_interpolate_the_corners_of_the_coarse_face():
    stride = np.array([2, 1])  # cell layer 0 coarse, 1 fine: node layer 1 is the interface
    grid = np.array([[2, 4, 1], [1, 4, 1], [2, 3, 1], [1, 3, 1], [1, 3, 2], [2, 2, 0]])
    masters, weights = interpolation_masters(grid, stride)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0)
    expected = [{(2, 4, 1): 1.0}, {(0, 4, 1): 0.5, (2, 4, 1): 0.5},
                {(2, 2, 1): 0.5, (2, 4, 1): 0.5},
                {(0, 2, 1): 0.25, (0, 4, 1): 0.25, (2, 2, 1): 0.25, (2, 4, 1): 0.25},
                {(1, 3, 2): 1.0}, {(2, 2, 0): 1.0}]
    for node, weights_of in enumerate(expected):
        found = {tuple(m): w for m, w in zip(masters[node], weights[node], strict=True) if w}
        assert found == weights_of


def test_structured_block_cells_use_only_existing_nodes_and_cover_the_block():
    n, stride = 8, np.array([4, 2, 2, 1])
    grid, hexahedra = structured_block(n, stride)
    assert len(hexahedra) == sum((n // s) ** 2 for s in stride)
    assert len(np.unique(grid, axis=0)) == len(grid)
    corners = grid[hexahedra]  # (cells, 8, 3), gmsh order: bottom face then top face
    assert np.all(corners[:, :4, 2] + 1 == corners[:, 4:, 2])
    width = corners[:, 2, 0] - corners[:, 0, 0]
    assert np.array_equal(width, stride[corners[:, 0, 2]])


def test_corner_jacobians_of_unit_and_sheared_cubes():
    corners = np.array([[a, b, c] for c in (0, 1) for b in (0, 1) for a in (0, 1)], float)
    cell = np.arange(8)[None, :]
    np.testing.assert_allclose(corner_jacobians(corners, cell), 1.0)
    sheared = corners.copy()
    sheared[:, 2] += 0.3 * sheared[:, 0] + 2.0 * sheared[:, 2]  # z' = 3 z + 0.3 x
    np.testing.assert_allclose(corner_jacobians(sheared, cell), 3.0)
    inverted = corners.copy()
    inverted[4:, 2] = -1.0
    assert np.all(corner_jacobians(inverted, cell) < 0)


def rough(n, rms, seed=0):
    return np.random.default_rng(seed).normal(0.0, rms, (n, n))


def test_block_nodes_sit_on_the_periodic_height_map():
    n = 8
    heights = rough(n, 0.2 * SPACING)
    block = build_block(heights, SPACING, MeshOptions(), MPI.COMM_WORLD)
    x, (i, j, k) = block.mesh.geometry.x, block.grid_index.T
    top = k == block.num_layers
    expected = heights - heights.mean()
    np.testing.assert_allclose(x[top, 2], expected[i[top] % n, j[top] % n], rtol=0, atol=1e-18)
    np.testing.assert_allclose(x[:, 0], i * SPACING, atol=1e-18)
    np.testing.assert_allclose(x[k == 0, 2], -block.depth)
    below_blend = k <= block.num_layers - MeshOptions().blend_layers
    np.testing.assert_allclose(x[below_blend, 2], block.layer_z[k[below_blend]], atol=1e-18)
    cells = block.mesh.topology.index_map(3).size_global
    assert cells == sum((n // stride) ** 2 for stride in block.layer_stride)


def test_facet_tags_cover_each_side():
    n = 8
    block = build_block(rough(n, 0.1 * SPACING), SPACING, MeshOptions(), MPI.COMM_WORLD)
    assert set(block.layer_stride) == {1, 2}  # coarsened once
    tags = boundary_facet_tags(block)
    counts = {tag: MPI.COMM_WORLD.allreduce(int(np.count_nonzero(tags.values == tag)))
              for tag in Boundary}
    assert counts[Boundary.CONTACT] == n * n
    assert counts[Boundary.BOTTOM] == (n // block.layer_stride[0]) ** 2
    for side in (Boundary.X0, Boundary.XL, Boundary.Y0, Boundary.YL):
        assert counts[side] == sum(n // stride for stride in block.layer_stride)


def test_inverted_cells_are_refused_with_a_layer_count_that_fixes_them():
    heights = rough(8, 2.0 * SPACING, seed=3)  # valleys several grid spacings deep
    with pytest.raises(InputError, match="inverted") as error:
        build_block(heights, SPACING, MeshOptions(blend_layers=2), MPI.COMM_WORLD)
    needed = int(str(error.value).split("needs >= ")[1].split()[0])
    assert needed > 2
    build_block(heights, SPACING, MeshOptions(blend_layers=needed), MPI.COMM_WORLD)


@pytest.mark.parametrize("options", [{"blend_layers": 0}, {"growth": 0.5}, {"depth": -1.0},
                                     {"blend_layers": 2.5}, {"fine_layers": 0},
                                     {"coarsen": "yes"}])
def test_bad_mesh_options(options):
    with pytest.raises(InputError):
        MeshOptions(**options)


def test_slab_partitioner_sends_contiguous_cells_to_one_rank_and_ghosts_to_neighbours():
    from dolfinx.cpp.graph import AdjacencyList_int64

    # 4 cells in a row, each a neighbour of the next: 2 parts split them 2 + 2
    graph = AdjacencyList_int64(np.array([1, 0, 2, 1, 3, 2], dtype=np.int64),
                                np.array([0, 1, 3, 5, 6], dtype=np.int32))
    plain = slab_partitioner(MPI.COMM_SELF, 2, graph, False)
    assert list(plain.array) == [0, 0, 1, 1]
    ghosted = slab_partitioner(MPI.COMM_SELF, 2, graph, True)
    assert [list(ghosted.links(cell)) for cell in range(4)] == [[0], [0, 1], [1, 0], [1]]


@pytest.mark.mpi
def test_the_block_is_partitioned_the_same_way_at_every_build():
    """dolfinx 0.5's graph partitioner is not repeatable; a different partition changes the
    round-off of every solve and can flip a step cut (docs/benchmarks.md, version 0.4.2)."""
    heights = np.random.default_rng(1).normal(0.0, 0.1e-6, (8, 8))
    owned = []
    for _ in range(3):
        block = build_block(heights, 1e-6, MeshOptions(), MPI.COMM_WORLD)
        cells = block.mesh.topology.index_map(3).size_local
        nodes = block.mesh.geometry.dofmap.array.reshape(-1, 8)[:cells]
        owned.append(np.sort(block.mesh.geometry.x[nodes].reshape(-1, 24), axis=0))
    for other in owned[1:]:
        np.testing.assert_array_equal(other, owned[0])


def test_the_memory_estimate_bounds_the_benchmarked_runs():
    """The estimate lies above the peak memory of every committed `make bench-fem` row
    (docs/bench/fem.csv), but within 1.5x of it (else it refuses runs that would fit)."""
    import csv
    from pathlib import Path

    rows = list(csv.DictReader((Path(__file__).parents[1] / "docs" / "bench" / "fem.csv")
                               .read_text().splitlines()))
    assert rows
    for row in rows:
        estimate = estimated_memory_gb(int(row["n"]), MeshOptions(), int(row["ranks"]))
        assert 1.0 < estimate / float(row["peak_memory_gb"]) < 1.5, row


def test_a_run_too_large_for_the_available_memory_is_refused(monkeypatch):
    from roughfriction.solver import run as run_module

    monkeypatch.setattr(run_module, "available_memory_gb", lambda comm: 8.0)
    check_memory(256, MeshOptions(), MPI.COMM_SELF)  # ~7 GB
    with pytest.raises(InputError, match=r"N = 512: the FEM run needs about 2\d\.\d GB"):
        check_memory(512, MeshOptions(), MPI.COMM_SELF)
