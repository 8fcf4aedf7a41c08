"""The contact surface's faces: the top faces of the block on the finest surface grid (uniform,
or the top cells of a contact-adaptive block, hanging corners tied to their coarse face), the
faces each rank evaluates, and the Gauss points of a face (:mod:`solver.contact`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from roughfriction.geometry.adaptive import CellSizes, hanging_masters

#: Corner offsets (di, dj) of a face's nodes a = 0..3 from its node (i, j).
CORNERS = np.array([(0, 0), (1, 0), (0, 1), (1, 1)])
def face_quadrature(points_per_side: int) -> tuple[np.ndarray, np.ndarray]:
    """Tensor Gauss-Legendre points of the unit face [0, 1]^2.

    Returns
    -------
    shape : numpy.ndarray
        Bilinear shape functions N_a of the 4 corners (``CORNERS``) at the points, (n^2, 4).
    weight : numpy.ndarray
        Weights (sum 1), (n^2,).
    """
    roots, weights = np.polynomial.legendre.leggauss(points_per_side)
    s, w = (roots + 1.0) / 2.0, weights / 2.0
    xi, eta = (a.ravel() for a in np.meshgrid(s, s, indexing="ij"))
    shape = np.column_stack([(1 - xi) * (1 - eta), xi * (1 - eta), (1 - xi) * eta, xi * eta])
    return shape, np.outer(w, w).ravel()


def nearest_corner(shape: np.ndarray) -> np.ndarray:
    """The corner (0..3, ``CORNERS``) whose tributary quarter of the face holds each point: the
    one with the largest N_a(q) (unique for an even number of points per side), (n^2,)."""
    return np.argmax(shape, axis=1)


@dataclass(frozen=True, eq=False)
class SurfaceFaces:
    """The top faces of the block on the finest surface grid (N x N, spacing h_grid).

    Attributes
    ----------
    first : numpy.ndarray
        (i0, j0) of each face's first corner, shape (F, 2), face-major (i0, then j0).
    width : numpy.ndarray
        Side of each face [grid spacings], shape (F,).
    masters : numpy.ndarray
        Free grid nodes i N + j behind each corner (``CORNERS`` order), shape (F, 4, 4): the
        corner itself, or for a hanging corner the corners of the coarse face it lies on.
    weights : numpy.ndarray
        Their weights, shape (F, 4, 4) (each corner's sum to 1; 0 in unused slots).
    cell_face : numpy.ndarray
        The face covering each finest cell (i, j), shape (N, N): its index among all faces of
        the surface (also in a :meth:`subset`).
    uniform : bool
        All faces of the surface 1 spacing wide (no hanging corners).
    """

    first: np.ndarray
    width: np.ndarray
    masters: np.ndarray
    weights: np.ndarray
    cell_face: np.ndarray
    uniform: bool

    def on_grid(self, face_values: np.ndarray) -> np.ndarray:
        """Values of all faces of the surface as an N x N map of the finest cells, each cell its
        face's value."""
        return np.asarray(face_values)[self.cell_face]

    def subset(self, faces: np.ndarray) -> SurfaceFaces:
        """The faces with these indices (ascending), the same surface's cell map."""
        return SurfaceFaces(self.first[faces], self.width[faces], self.masters[faces],
                            self.weights[faces], self.cell_face, self.uniform)


def local_faces(faces: SurfaceFaces, owner: np.ndarray, rank: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """The faces a rank evaluates for the rows of the surface nodes it owns, and those it counts.

    A node's force involves the points of its faces, whose pressures are those of their
    corners' nodes, whose weighted gaps involve the points of those nodes' faces: the faces
    within two rings of the owned nodes. Each face is counted (integrals, maps) by the rank
    that owns its lowest free node.

    Parameters
    ----------
    faces : SurfaceFaces
        All faces of the surface.
    owner : numpy.ndarray
        Rank owning each free grid node i N + j, shape (N^2,).
    rank : int
        This rank.

    Returns
    -------
    local : numpy.ndarray
        Indices of the faces to evaluate, ascending.
    counted : numpy.ndarray
        Of those, the ones this rank counts (bool).
    """
    used = faces.weights > 0.0
    masters = np.where(used, faces.masters, len(owner))  # N^2: no node

    def touching(nodes: np.ndarray) -> np.ndarray:  # faces with a free node in the mask
        return np.any(np.append(nodes, False)[masters], axis=(1, 2))

    ring = np.zeros(len(owner), dtype=bool)
    near = masters[touching(owner == rank)]
    ring[near[near < len(owner)]] = True
    local = np.flatnonzero(touching(ring))
    lowest = masters[local].min(axis=(1, 2))
    return local, owner[lowest] == rank


def surface_faces(cells: CellSizes) -> SurfaceFaces:
    """The top faces of a block of N x N finest cells: the top cell layer of ``cells``
    (``geometry.adaptive``), hanging corners tied to their coarse face's corners
    (``geometry.adaptive.hanging_masters``)."""
    n, top = cells.grid_size, cells.num_layers - 1
    i0, j0, width = cells.layer_cells(top)
    corner_i = i0[:, None] + width[:, None] * CORNERS[:, 0]
    corner_j = j0[:, None] + width[:, None] * CORNERS[:, 1]
    grid = np.column_stack([corner_i.ravel(), corner_j.ravel(),
                            np.full(corner_i.size, cells.num_layers)])
    masters, weights = hanging_masters(grid, cells)
    nodes = (masters[..., 0] % n) * n + masters[..., 1] % n
    a, b = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    size = cells.size(top, a, b)
    cell_face = np.searchsorted(i0 * n + j0, (a // size * size) * n + b // size * size)
    return SurfaceFaces(np.column_stack([i0, j0]), width, nodes.reshape(-1, 4, 4),
                        weights.reshape(-1, 4, 4), cell_face, bool(np.all(width == 1)))
