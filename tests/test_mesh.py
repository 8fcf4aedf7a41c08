"""The hexahedral block: layering, surface heights on the nodes, tags, Jacobian checks."""

import numpy as np
import pytest

pytest.importorskip("dolfinx")

from mpi4py import MPI  # noqa: E402

from geometry.errors import InputError  # noqa: E402
from geometry.mesh import (  # noqa: E402
    Boundary,
    MeshOptions,
    build_block,
    corner_jacobians,
    layer_positions,
)

pytestmark = pytest.mark.fem

SPACING = 1e-6


def test_layers_blend_at_grid_spacing_then_grow_to_the_depth():
    options = MeshOptions(blend_layers=3, growth=1.5, depth=1.0)
    z = layer_positions(16, SPACING, options)
    thickness = np.diff(z)[::-1]  # top down
    np.testing.assert_allclose(thickness[:3], SPACING)
    np.testing.assert_allclose(thickness[4:] / thickness[3:-1], 1.5)
    assert z[-1] == 0.0
    assert -z[0] >= 16 * SPACING > -z[1]  # the first layer deep enough, and no deeper


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
    assert cells == n * n * block.num_layers


def test_facet_tags_cover_each_side():
    n = 8
    block = build_block(rough(n, 0.1 * SPACING), SPACING, MeshOptions(), MPI.COMM_WORLD)
    counts = {tag: MPI.COMM_WORLD.allreduce(int(np.count_nonzero(block.facet_tags.values == tag)))
              for tag in Boundary}
    assert counts[Boundary.CONTACT] == counts[Boundary.BOTTOM] == n * n
    for side in (Boundary.X0, Boundary.XL, Boundary.Y0, Boundary.YL):
        assert counts[side] == n * block.num_layers


def test_inverted_cells_are_refused_with_a_layer_count_that_fixes_them():
    heights = rough(8, 2.0 * SPACING, seed=3)  # valleys several grid spacings deep
    with pytest.raises(InputError, match="inverted") as error:
        build_block(heights, SPACING, MeshOptions(blend_layers=2), MPI.COMM_WORLD)
    needed = int(str(error.value).split("needs >= ")[1].split()[0])
    assert needed > 2
    build_block(heights, SPACING, MeshOptions(blend_layers=needed), MPI.COMM_WORLD)


@pytest.mark.parametrize("options", [{"blend_layers": 0}, {"growth": 0.5}, {"depth": -1.0},
                                     {"blend_layers": 2.5}])
def test_bad_mesh_options(options):
    with pytest.raises(InputError):
        MeshOptions(**options)
