"""The contact surface's quadrature, built once: the Gauss points of the faces a rank evaluates
(:mod:`solver.contact_faces`), the sparse operators between points and surface grid nodes
(interpolation N_b(q), consistent nodal forces A_f w_q N_a(q), tributary weights W_aq), the
gathers of the owned surface nodes over the ranks, and the pattern of the contact tangent's
node blocks (:mod:`solver.contact`)."""

from __future__ import annotations

import numpy as np
from roughfriction.geometry.adaptive import CellSizes
from roughfriction.solver.contact_faces import (
    SurfaceFaces,
    face_quadrature,
    local_faces,
    nearest_corner,
    surface_faces,
)
from scipy import sparse

#: Neighbour offsets (di, dj) of a node's 25 couplings (2 grid steps: a node's weighted gap
#: involves its 9 neighbours), in the order of ``node_stiffness``.
NEIGHBOURS = np.array([(di, dj) for di in range(-2, 3) for dj in range(-2, 3)])


def neighbour_stencil(n: int, nodes: np.ndarray) -> np.ndarray:
    """Grid nodes of the 25 couplings (``NEIGHBOURS``) of the grid ``nodes`` i N + j of the
    uniform periodic N x N grid, shape (len(nodes), 25)."""
    i, j = np.divmod(np.asarray(nodes), n)
    return ((i[:, None] + NEIGHBOURS[:, 0]) % n) * n + (j[:, None] + NEIGHBOURS[:, 1]) % n


def coupling_pattern(nodes, to_nodes, point_pressure, gap_gradient, interpolation
                     ) -> np.ndarray:
    """Grid nodes b that the contact tangent couples each of the grid ``nodes`` a to (through a
    shared point, its pressure or its gap), padded with -1, shape (len(nodes), widest row)."""
    absolute = [abs(sparse.csr_matrix(m)) for m in (to_nodes[nodes], point_pressure,
                                                  gap_gradient, interpolation)]
    pattern = (absolute[0] @ (absolute[1] @ absolute[2] + absolute[3])).tocsr()
    pattern.eliminate_zeros()
    counts = np.diff(pattern.indptr)
    columns = np.full((pattern.shape[0], max(int(counts.max(initial=0)), 1)), -1, dtype=np.int64)
    slot = np.arange(pattern.nnz) - np.repeat(pattern.indptr[:-1], counts)
    columns[np.repeat(np.arange(pattern.shape[0]), counts), slot] = pattern.indices
    return columns


def first_occurrences(neighbours: np.ndarray) -> np.ndarray:
    """1.0 where a row's entry is a node not met earlier in the row (and not the -1 padding),
    else 0.0 (a neighbour met twice on a grid smaller than 5 holds its block once), shape of
    ``neighbours`` plus two unit axes (for 3 x 3 blocks)."""
    first = np.zeros(neighbours.shape)
    for column in range(neighbours.shape[1]):
        earlier = (neighbours[:, :column] == neighbours[:, column:column + 1]).any(axis=1)
        first[:, column] = (neighbours[:, column] >= 0) & ~earlier
    return first


class SurfaceQuadrature:
    """The points, operators and node gathers of the contact surface (faces on the N x N grid)
    on one rank: the faces near the surface nodes it owns (:func:`local_faces`); point arrays
    hold those faces' points, node arrays span the N^2 grid nodes.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator (gathers the surface displacements).
    nodes : numpy.ndarray
        Local indices of the free surface nodes this rank owns (one per grid position i, j < N
        where a face corner does not hang), shape (m,).
    grid_index : numpy.ndarray
        (i, j) of those nodes, shape (m, 2).
    cells : CellSizes
        Cell sizes of the block (``geometry.adaptive``): the faces are its top cells on the
        N x N finest grid, ``nodes`` its free (not hanging) surface nodes.
    heights : numpy.ndarray
        Surface heights Z [m] of the owned nodes, shape (m,).
    spacing : float
        Grid spacing h_grid [m].
    points_per_side : int
        Gauss points per face side n [-].

    Attributes
    ----------
    interpolation : scipy.sparse.csr_matrix
        N_b(q): grid-node values at the points, (P, N^2).
    to_nodes_matrix : scipy.sparse.csr_matrix
        A_f w_q N_a(q): point densities to consistent nodal values, (N^2, P).
    tributary : scipy.sparse.csr_matrix
        W_aq / A_a: the weighted gap g~_a = tributary g, (N^2, P).
    point_pressure : scipy.sparse.csr_matrix
        W_aq / (A_f w_q): p_q = point_pressure p_a, (P, N^2).
    gap_gradient : scipy.sparse.csr_matrix
        dg~_a/du_z,b, (N^2, N^2).
    counted_area : numpy.ndarray
        A_f w_q of the points of the faces this rank counts, 0 elsewhere [m^2].
    neighbours : numpy.ndarray
        The grid nodes of the tangent's columns of each owned node (rows: ``stencil_nodes``),
        padded with -1.
    """

    def __init__(self, comm, nodes: np.ndarray, grid_index: np.ndarray, cells: CellSizes,
                 heights: np.ndarray, spacing: float, points_per_side: int = 2):
        self.comm = comm
        self.nodes = nodes
        self.grid_size = n = cells.grid_size
        self.spacing = spacing
        self.owned_grid = grid_index[:, 0] * n + grid_index[:, 1]  # grid node of each owned node
        self._gathered_grid = np.concatenate(comm.allgather(self.owned_grid))
        faces = surface_faces(cells)
        needed = np.unique(faces.masters[faces.weights > 0.0])
        if not np.array_equal(np.sort(self._gathered_grid), needed):
            raise RuntimeError(f"surface nodes are not the {len(needed)} free nodes of the "
                               f"{n} x {n} surface grid, once each")
        self.node_heights = self.gather_nodes(heights)
        self.surface_node = np.zeros(n * n, dtype=bool)  # a free node there, (N^2,)
        self.surface_node[self._gathered_grid] = True
        self.num_faces = len(faces.width)
        local, counted = local_faces(faces, self.gather_nodes(np.full(len(nodes), comm.rank)),
                                     comm.rank)
        self.face_ids = local  # this rank's faces among all of the surface's
        self._build_quadrature(faces.subset(local), points_per_side)
        self.counted_area = self.point_area * np.repeat(counted, len(self.weight))  # [m^2]
        self.face_counted = counted
        self.stencil_nodes = np.sort(self.owned_grid)  # rows of ``neighbours``
        self.neighbours = (neighbour_stencil(n, self.stencil_nodes) if faces.uniform
                           else coupling_pattern(self.stencil_nodes, self.to_nodes_matrix,
                                                 self.point_pressure, self.gap_gradient,
                                                 self.interpolation))
        self._first_neighbour = first_occurrences(self.neighbours)

    def _build_quadrature(self, faces: SurfaceFaces, points_per_side: int) -> None:
        """The points of the ``faces`` and the sparse maps between points and grid nodes."""
        n = self.grid_size
        self.shape, self.weight = face_quadrature(points_per_side)
        q, num_faces = len(self.weight), len(faces.width)
        num_points = num_faces * q
        self.point_weight = np.tile(self.weight, num_faces)  # w_q per point (face area units)
        self.face_area = (faces.width * self.spacing) ** 2  # A_f [m^2]
        self.point_area = self.point_weight * np.repeat(self.face_area, q)  # A_f w_q [m^2]
        self.faces = faces
        # the free nodes behind each point's face corners: N_c(q) times the corner's weights
        point = np.arange(num_points)[:, None, None]
        corner_weight = (np.tile(self.shape, (num_faces, 1))[:, :, None]
                         * np.repeat(faces.weights, q, axis=0))  # (P, 4 corners, 4 masters)
        corner_nodes = np.repeat(faces.masters, q, axis=0)
        self.interpolation = sparse.csr_matrix(
            (corner_weight.ravel(), (np.broadcast_to(point, corner_nodes.shape).ravel(),
                                     corner_nodes.ravel())), shape=(num_points, n * n))
        self.to_nodes_matrix = (self.interpolation.T @ sparse.diags(self.point_area)).tocsr()
        self.heights = self.interpolate(self.node_heights)  # Z at the points [m]
        # W_aq [m^2]: a point's area goes to its face's nearest corner (to that corner's free
        # nodes, by their weights, where it hangs)
        nearest = nearest_corner(self.shape)
        points = np.arange(num_points)
        point_corner = np.tile(nearest, num_faces)
        tributary_nodes = corner_nodes[points, point_corner]  # (P, 4)
        tributary_weights = (np.repeat(faces.weights, q, axis=0)[points, point_corner]
                             * self.point_area[:, None])
        area = sparse.csr_matrix((tributary_weights.ravel(), (tributary_nodes.ravel(),
                                                              np.repeat(points, 4))),
                                 shape=(n * n, num_points))
        self.node_area = np.asarray(area.sum(axis=1)).ravel()  # A_a [m^2] (0: no node there)
        self.node_free = self.node_area > 0.0
        # g~_a = sum_q W_aq g_q / A_a, p_q = sum_a W_aq p_a / (A_f w_q), dg~_a/du_z,b
        self.tributary = (sparse.diags(np.where(self.node_free, 1.0 / np.where(
            self.node_free, self.node_area, 1.0), 0.0)) @ area).tocsr()
        self.point_pressure = (sparse.diags(1.0 / self.point_area) @ area.T).tocsr()
        self.gap_gradient = (self.tributary @ self.interpolation).tocsr()

    def gather_nodes(self, values: np.ndarray) -> np.ndarray:
        """Owned-node values of every rank as one array over the grid nodes i N + j (zero where
        the surface has no free node)."""
        values = np.asarray(values)
        gathered = np.zeros((self.grid_size**2,) + values.shape[1:], dtype=values.dtype)
        gathered[self._gathered_grid] = np.concatenate(self.comm.allgather(values))
        return gathered

    def interpolate(self, node_values: np.ndarray) -> np.ndarray:
        """Grid-node values at the integration points (bilinear in each face), shape (P, ...)."""
        return self.interpolation @ node_values

    def to_nodes(self, point_values: np.ndarray) -> np.ndarray:
        """sum_q A_f w_q N_a(q) v_q for every grid node a: point densities [x/m^2] as
        consistent nodal values [x]."""
        return self.to_nodes_matrix @ point_values

    def node_tangent(self, blocks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The owned nodes a with a nonzero row in any of the 3 x 3 component matrices
        ``blocks`` (N^2 x N^2 sparse, per unit area [Pa/m]; None for zero) and their K_ab [N/m]
        with their neighbours b (:attr:`neighbours`), shape (m, width, 3, 3)."""
        matrices = {}
        stiff = np.zeros(len(self.stencil_nodes), dtype=bool)
        for (i, j), matrix in np.ndenumerate(blocks):
            if matrix is not None:
                matrix = sparse.csr_matrix(matrix)[self.stencil_nodes]
                matrix.eliminate_zeros()
                stiff |= np.diff(matrix.indptr) > 0
                matrices[i, j] = matrix
        rows = np.flatnonzero(stiff)
        width = self.neighbours.shape[1]
        columns = np.maximum(self.neighbours[rows], 0).ravel()
        tangent = np.zeros((3, 3, len(rows), width))  # component-major: contiguous
        for (i, j), matrix in matrices.items():
            if len(rows):  # (scipy gives a 1 x 0 matrix for no index)
                tangent[i, j] = np.asarray(matrix[np.repeat(rows, width), columns]).reshape(
                    len(rows), width)
        tangent *= self._first_neighbour[rows]
        return self.stencil_nodes[rows], tangent.transpose(2, 3, 0, 1)

    def neighbours_of(self, nodes: np.ndarray) -> np.ndarray:
        """:attr:`neighbours` of owned grid nodes (the columns of their tangent rows)."""
        return self.neighbours[np.searchsorted(self.stencil_nodes, nodes)]
