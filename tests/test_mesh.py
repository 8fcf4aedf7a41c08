"""The hexahedral block: layering, surface heights on the nodes, the gmsh model and its .msh
file, Jacobians."""

from pathlib import Path

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from roughfriction.errors import InputError  # noqa: E402
from roughfriction.geometry.adaptive import block_layout, block_nodes
from roughfriction.geometry.mesh import (  # noqa: E402
    GMSH_HEXAHEDRON,
    GMSH_QUADRANGLE,
    Boundary,
    MeshOptions,
    boundary_quadrangles,
    corner_jacobians,
    gmsh_model,
    layer_layout,
)
from roughfriction.geometry.mesh_file import write_msh

pytestmark = pytest.mark.fem

SPACING = 1e-6


def nodes_of(heights, spacing=SPACING):
    """The block of an unrefined surface (default mesh options) on one process
    (``geometry.adaptive.block_nodes``)."""
    return block_nodes(block_layout(len(heights), spacing, MeshOptions()), heights)


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


FEM_STACK = {"dolfinx", "ufl", "basix", "ffcx", "petsc4py", "mpi4py"}


def imported_packages(source: str) -> set[str]:
    """Top-level packages a Python source imports (anywhere in it, functions included)."""
    import ast

    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names.add(node.module)
    return {name.split(".")[0] for name in names}


def test_geometry_uses_neither_the_fem_library_nor_mpi():
    """geometry/ sits below the solver: the dolfinx mesh is made in solver/block.py."""

    import roughfriction.geometry

    for source in Path(roughfriction.geometry.__file__).parent.glob("*.py"):
        assert not imported_packages(source.read_text()) & FEM_STACK, source.name


def test_block_nodes_sit_on_the_periodic_height_map():
    n = 8
    heights = rough(n, 0.2 * SPACING)
    nodes = nodes_of(heights)
    x, (i, j, k) = nodes.coordinates, nodes.grid.T
    num_layers = len(nodes.layer_z) - 1
    top = k == num_layers
    expected = heights - heights.mean()
    np.testing.assert_allclose(x[top, 2], expected[i[top] % n, j[top] % n], rtol=0, atol=1e-18)
    np.testing.assert_allclose(x[:, 0], i * SPACING, atol=1e-18)
    np.testing.assert_allclose(x[k == 0, 2], nodes.layer_z[0])
    below_blend = k <= num_layers - MeshOptions().blend_layers
    np.testing.assert_allclose(x[below_blend, 2], nodes.layer_z[k[below_blend]], atol=1e-18)
    assert len(nodes.hexahedra) == sum((n // stride) ** 2 for stride in nodes.layer_stride)
    low_i = nodes.grid[nodes.hexahedra[:, 0], 0]
    assert np.all(np.diff(low_i) >= 0)  # x-major: contiguous cells form x-slabs


def test_boundary_quadrangles_cover_each_side_and_face_out():
    n = 8
    nodes = nodes_of(np.zeros((n, n)))
    assert set(nodes.layer_stride) == {1, 2}  # coarsened once
    sides = boundary_quadrangles(nodes)
    assert len(sides[Boundary.CONTACT]) == n * n
    assert len(sides[Boundary.BOTTOM]) == (n // nodes.layer_stride[0]) ** 2
    outward = {Boundary.CONTACT: (0, 0, 1), Boundary.BOTTOM: (0, 0, -1), Boundary.X0: (-1, 0, 0),
               Boundary.XL: (1, 0, 0), Boundary.Y0: (0, -1, 0), Boundary.YL: (0, 1, 0)}
    for side, quadrangles in sides.items():
        if side not in (Boundary.CONTACT, Boundary.BOTTOM):
            assert len(quadrangles) == sum(n // stride for stride in nodes.layer_stride)
        corner = nodes.coordinates[quadrangles]  # (faces, 4, 3)
        normal = np.cross(corner[:, 2] - corner[:, 0], corner[:, 3] - corner[:, 1])
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        np.testing.assert_allclose(normal, np.broadcast_to(outward[side], normal.shape), atol=1e-12)


def read_msh(path):
    """Node coordinates [m] in tag order, hexahedra (0-based), and the quadrangles of each named
    physical group, of a .msh file read by a fresh gmsh session."""
    with gmsh_model() as gmsh:
        gmsh.open(str(path))
        tags, coordinates, _ = gmsh.model.mesh.getNodes()
        coordinates = coordinates.reshape(-1, 3)[np.argsort(tags)]
        _, hexahedra = gmsh.model.mesh.getElementsByType(GMSH_HEXAHEDRON)
        groups = {}
        for dim, tag in gmsh.model.getPhysicalGroups():
            name = gmsh.model.getPhysicalName(dim, tag)
            entity, = gmsh.model.getEntitiesForPhysicalGroup(dim, tag)
            if dim == 2:
                _, quadrangles = gmsh.model.mesh.getElementsByType(GMSH_QUADRANGLE, entity)
                groups[name] = quadrangles.reshape(-1, 4).astype(np.int64) - 1
            else:
                groups[name] = None
    return coordinates, hexahedra.reshape(-1, 8).astype(np.int64) - 1, groups


def test_the_msh_file_holds_the_moved_block_and_its_named_sides(tmp_path):
    nodes = nodes_of(rough(8, 0.2 * SPACING))
    path = write_msh(nodes, tmp_path / "block.msh")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["block.msh"]  # no partial file left
    coordinates, hexahedra, groups = read_msh(path)
    np.testing.assert_array_equal(coordinates, nodes.coordinates)
    np.testing.assert_array_equal(hexahedra, nodes.hexahedra)
    assert groups.keys() == {side.name.lower() for side in Boundary} | {"block"}
    for side, quadrangles in boundary_quadrangles(nodes).items():
        np.testing.assert_array_equal(groups[side.name.lower()], quadrangles)


def test_an_msh_path_that_cannot_be_written_is_refused(tmp_path):
    nodes = nodes_of(np.zeros((4, 4)))
    with pytest.raises(InputError, match="ends in .msh"):
        write_msh(nodes, tmp_path / "block.vtk")
    with pytest.raises(InputError, match="cannot write the mesh"):
        write_msh(nodes, tmp_path / "missing" / "block.msh")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("options", [{"blend_layers": 0}, {"growth": 0.5}, {"depth": -1.0},
                                     {"blend_layers": 2.5}, {"fine_layers": 0},
                                     {"coarsen": "yes"}])
def test_bad_mesh_options(options):
    with pytest.raises(InputError):
        MeshOptions(**options)
