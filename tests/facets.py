"""The block's boundary facets tagged by side, for the tests that integrate over a side (the
solver needs no facets, and computing them on 2 ranks takes minutes on a coarsened block)."""

import numpy as np
from roughfriction.geometry.mesh import Block, Boundary


def boundary_facet_tags(block: Block):
    """Tag the block's boundary facets with :class:`Boundary` values, by the grid index of their
    vertices (a facet is on a side when all its vertices are).

    The mesh's facets are computed here, not when the block is built: the solver needs none,
    and dolfinx 0.5 takes minutes computing them on 2 ranks for a coarsened block at N = 64.

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
