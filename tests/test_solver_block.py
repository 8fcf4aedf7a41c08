"""The block as a dolfinx mesh: read from the gmsh model unchanged, fixed slab partition, facet
tags, Jacobian checks, and the ``fem --msh`` file."""

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from facets import boundary_facet_tags  # noqa: E402
from mpi4py import MPI  # noqa: E402
from roughfriction.errors import InputError  # noqa: E402
from roughfriction.geometry.mesh import (  # noqa: E402
    Boundary,
    MeshOptions,
    boundary_quadrangles,
)
from roughfriction.solver.block import (  # noqa: E402
    build_block,
    slab_mesh,
    slab_partitioner,
)
from test_mesh import nodes_of  # noqa: E402

pytestmark = pytest.mark.fem

SPACING = 1e-6


def rough(n, rms, seed=0):
    return np.random.default_rng(seed).normal(0.0, rms, (n, n))


def test_the_mesh_read_through_gmsh_is_the_mesh_of_its_nodes_and_cells():
    """gmsh and gmshio neither move, renumber nor reorder anything: the mesh equals the one made
    from the NumPy nodes and cells directly, node for node, and the grid index is each node's."""
    heights = rough(8, 0.2 * SPACING)
    nodes = nodes_of(heights)
    block = build_block(heights, SPACING, MeshOptions(), MPI.COMM_WORLD)
    on_root = MPI.COMM_WORLD.rank == 0
    direct = slab_mesh(MPI.COMM_WORLD, nodes.coordinates if on_root else np.empty((0, 3)),
                       nodes.hexahedra if on_root else np.empty((0, 8), dtype=np.int64))
    mesh = block.mesh
    np.testing.assert_array_equal(mesh.geometry.x, direct.geometry.x)
    np.testing.assert_array_equal(mesh.geometry.dofmap.array, direct.geometry.dofmap.array)
    inputs = mesh.geometry.input_global_indices
    np.testing.assert_array_equal(inputs, direct.geometry.input_global_indices)
    np.testing.assert_array_equal(mesh.geometry.x, nodes.coordinates[inputs])
    np.testing.assert_array_equal(block.grid_index, nodes.grid[inputs])
    cells = block.mesh.topology.index_map(3).size_global
    assert cells == sum((8 // stride) ** 2 for stride in block.layer_stride)


def test_facet_tags_are_the_sides_of_the_gmsh_model():
    n = 8
    heights = rough(n, 0.1 * SPACING)
    block = build_block(heights, SPACING, MeshOptions(), MPI.COMM_WORLD)
    assert set(block.layer_stride) == {1, 2}  # coarsened once
    tags = boundary_facet_tags(block)
    from dolfinx.cpp.mesh import entities_to_geometry

    facet_nodes = entities_to_geometry(block.mesh._mesh, 2, tags.indices, False)
    inputs = np.asarray(block.mesh.geometry.input_global_indices)[facet_nodes]
    for side, quadrangles in boundary_quadrangles(nodes_of(heights)).items():
        mine = {tuple(sorted(f)) for f in inputs[tags.values == side]}
        tagged = set().union(*MPI.COMM_WORLD.allgather(mine))
        assert tagged == {tuple(sorted(q)) for q in quadrangles}, side


def test_inverted_cells_are_refused_with_a_layer_count_that_fixes_them():
    heights = rough(8, 2.0 * SPACING, seed=3)  # valleys several grid spacings deep
    with pytest.raises(InputError, match="inverted") as error:
        build_block(heights, SPACING, MeshOptions(blend_layers=2), MPI.COMM_WORLD)
    needed = int(str(error.value).split("needs >= ")[1].split()[0])
    assert needed > 2
    build_block(heights, SPACING, MeshOptions(blend_layers=needed), MPI.COMM_WORLD)


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
    round-off of every solve and can flip a step cut."""
    heights = np.random.default_rng(1).normal(0.0, 0.1e-6, (8, 8))
    owned = []
    for _ in range(3):
        block = build_block(heights, 1e-6, MeshOptions(), MPI.COMM_WORLD)
        cells = block.mesh.topology.index_map(3).size_local
        nodes = block.mesh.geometry.dofmap.array.reshape(-1, 8)[:cells]
        owned.append(np.sort(block.mesh.geometry.x[nodes].reshape(-1, 24), axis=0))
    for other in owned[1:]:
        np.testing.assert_array_equal(other, owned[0])


def test_the_fem_command_writes_the_block_it_meshes_as_msh(tmp_path, capsys):
    from roughfriction.geometry.readers import load_surface
    from roughfriction.scripts.cli import main
    from test_mesh import read_msh

    path, msh = tmp_path / "rough.npy", tmp_path / "block.msh"
    np.save(path, rough(8, 0.1 * SPACING, seed=3))
    code = main(["fem", str(path), "--size", "7um", "--load", "0.3", "--normal-only", "--elastic",
                 "--json", "--output", str(tmp_path / "run.h5"), "--msh", str(msh)])
    assert code == 0
    coordinates, hexahedra, groups = read_msh(msh)
    surface = load_surface(str(path), size="7um")  # as the command reads it (detrended)
    nodes = nodes_of(surface.heights, surface.spacing)
    np.testing.assert_array_equal(coordinates, nodes.coordinates)
    np.testing.assert_array_equal(hexahedra, nodes.hexahedra)
    assert len(groups[Boundary.CONTACT.name.lower()]) == 8 * 8
