"""Contact and friction of the block's top faces against a rigid flat: one contact constraint
per surface node, friction at integration points.

The flat is horizontal at height h and slides by U in x. The contact surface is the top of the
hexahedral mesh: periodic faces on an N x N grid of spacing h_grid, each the bilinear
interpolant of its four corner nodes (the surface the FEM resolves), with n x n Gauss points q
per face (weights w_q, sum 1 per face; shape functions N_b of the corners b). The faces are
N x N squares of side h_grid, or on a contact-adaptive block (``geometry.adaptive``) the top
cells, 2^k h_grid wide (area A_f); a corner that hangs on a coarser face's edge has no
constraint of its own: its displacement is the interpolation of that face's corners
(``SurfaceFaces``), to which its forces and tangent go. Below, areas are A_f w_q per point
(h_grid^2 w_q on the uniform grid) and A_a = sum_q W_aq per node.

* **Normal contact, per node** (a mortar-type weighted gap): node a stands for its tributary
  area, the quarter of each of its 4 faces nearest to it (the points of a face where N_a is
  largest; n is even). Its weighted gap is the mean gap over that area,
  g~_a = sum_q W_aq g_q / A_a with g_q = h - sum_b N_b(q) (Z_b + u_z,b) and W_aq = A_f w_q on
  a's tributary points (shared by the weights of a hanging corner's nodes), and its pressure
  p_a follows from g~_a by the augmented Lagrangian law of
  :mod:`solver.contact_law` (after a converged Newton solve, Uzawa sets lambda_a <- p_a and
  re-solves until no node penetrates deeper than a tolerance, so the contact does not depend on
  eps_N). The pressure field is p_a on a's tributary area; the contact area is the tributary
  area of the nodes with p_a > 0. One constraint per node keeps the multipliers unique, and the
  averaged (not collocated) gap is what makes the area converge with the mesh
  (docs/verification.md).
* **Friction, per point**: the return map of :mod:`solver.contact_law` at the slip
  w_q - w_s,q, with w_q = (U - u_x, -u_y) at q, the committed stick point w_s,q and p_q the
  pressure of the node whose tributary area holds q.

Forces and tangent are the derivatives of the contact energy sum_a A_a psi(g~_a) and of
the friction work at the points: f_b = sum_q A_f w_q N_b(q) (-t_q, p_q). On the uniform grid a
node's weighted gap involves its 9 neighbours, so the tangent couples a node to the 25 nodes
within 2 grid steps (``NEIGHBOURS``); on faces of varying width to the nodes of the pattern
``RigidFlat.neighbours``. A slipping point below p_r couples its traction to its node's pressure
(dt/dp = tau_c / p_r along the slip): that part is not symmetric (``ContactResponse.symmetric``),
and a Newton solver may leave it out (``Trial.tangent``).

Stick before slide: at the first Newton iterate of a tangential step, points that stuck at the
last converged step keep the uncapped stick law (tangential predictor). A point out of contact at
the last converged step carries no shear in the step in which it touches and sticks where it is
at its end. Frictionless steps (the preload) have t = 0, so sliding starts from full stick.

Each rank evaluates the faces within two rings of the surface nodes it owns (``local_faces``)
from the gathered surface displacements (sparse NumPy over those faces' points; node arrays
span the N^2 grid points) and adds the rows of its owned nodes, whose state it computes from
the same numbers as a single rank would. Integrals count each face on one rank.

Signs: R = f_int - f_ext. The flat pushes with -p e_z and drags with t, so node b's residual
gains f_b, and dR_z/dh = -eps_N sum (in contact).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from functools import cache, cached_property

import numpy as np
from mpi4py import MPI
from roughfriction.geometry.adaptive import CellSizes, hanging_masters
from roughfriction.solver.contact_law import ContactLaw
from scipy import sparse

#: Corner offsets (di, dj) of a face's nodes a = 0..3 from its node (i, j).
CORNERS = np.array([(0, 0), (1, 0), (0, 1), (1, 1)])
#: Neighbour offsets (di, dj) of a node's 25 couplings (2 grid steps: a node's weighted gap
#: involves its 9 neighbours), in the order of ``node_stiffness``.
NEIGHBOURS = np.array([(di, dj) for di in range(-2, 3) for dj in range(-2, 3)])


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


def surface_faces(n: int, cells: CellSizes | None = None) -> SurfaceFaces:
    """The top faces of a block of N x N finest cells: the uniform grid, or with ``cells`` the
    top cell layer of an adaptive block (``geometry.adaptive``), hanging corners tied to their
    coarse face's corners (``geometry.adaptive.hanging_masters``)."""
    if cells is None:
        cells = CellSizes.uniform(n, np.ones(1, dtype=np.int64))
    top = cells.num_layers - 1
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


class Tangent(Enum):
    """The contact tangent of a trial: ``EXACT``, or ``SYMMETRIC``: the ramp's coupling dt/dp
    left out (an approximate, symmetric Newton tangent; the residual keeps the law exactly)."""

    EXACT = "exact"
    SYMMETRIC = "symmetric"


@dataclass(frozen=True, eq=False)
class Trial:
    """How the contact law is evaluated at a trial state (:meth:`RigidFlat.respond`).

    Attributes
    ----------
    friction : bool
        Frictional (tangential phase) or frictionless (normal preload).
    predictor : bool
        Stick law without cap for points that stuck at the last converged step.
    active : numpy.ndarray or None
        Frozen contact set of the nodes, bool (N^2,): these carry lambda_a - eps_N g~_a even
        if it is negative; the others join when they penetrate (the set only grows: no
        cycling; the caller judges a converged iterate under the free law). None: the law
        decides.
    tangent : Tangent
        Exact or symmetric tangent.
    """

    friction: bool = False
    predictor: bool = False
    active: np.ndarray | None = None
    tangent: Tangent = Tangent.EXACT


#: Frictionless, the law's contact set: the trial of the preload's path predictor.
FRICTIONLESS = Trial()


@dataclass(frozen=True)
class ContactResponse:
    """Contact state at the nodes and integration points a rank evaluates, and its nodal forces
    and tangent.

    Point arrays hold the points of the rank's faces (P, face-major: ``RigidFlat.face_ids``);
    node arrays are indexed by the surface grid node i N + j, exact for the nodes it owns.

    Attributes
    ----------
    gap : numpy.ndarray
        g_q [m].
    node_gap : numpy.ndarray
        Weighted gap g~_a [m], shape (N^2,).
    node_active : numpy.ndarray
        Constraint active: lambda_a - eps_N g~_a > 0, or in the frozen set (bool, (N^2,)).
    node_pressure : numpy.ndarray
        p_a [Pa] (negative only for a frozen node pulled off the flat), shape (N^2,).
    in_contact : numpy.ndarray
        p_q > 0, bool.
    slipping : numpy.ndarray
        In contact and at the friction cap, bool.
    pressure : numpy.ndarray
        p_q [Pa], the pressure of the point's node (negative only under a frozen node).
    traction : numpy.ndarray
        Tangential traction of the flat, t_q [Pa], shape (P, 2).
    stick_offset : numpy.ndarray
        w_s to commit [m], shape (P, 2).
    node_force : numpy.ndarray
        Contact contribution to the nodal residual R [N], shape (N^2, 3).
    stiffness : callable
        Computes :attr:`node_blocks`, or with ``coupling_only`` :attr:`coupling_blocks` (once,
        when a linear solve needs it).
    node_height_derivative : numpy.ndarray
        dR_a/dh [N/m], shape (N^2, 3).
    coupled : bool
        Some slipping point couples its traction to its pressure (below p_r).
    symmetric : bool
        The tangent is symmetric: no coupling, or its coupling left out
        (``Tangent.SYMMETRIC``).
    """

    gap: np.ndarray
    node_gap: np.ndarray
    node_active: np.ndarray
    node_pressure: np.ndarray
    in_contact: np.ndarray
    slipping: np.ndarray
    pressure: np.ndarray
    traction: np.ndarray
    stick_offset: np.ndarray
    node_force: np.ndarray
    stiffness: Callable[..., tuple[np.ndarray, np.ndarray]]
    node_height_derivative: np.ndarray
    coupled: bool
    symmetric: bool

    @cached_property
    def node_blocks(self) -> tuple[np.ndarray, np.ndarray]:
        """The owned nodes a with any contact stiffness (grid node i N + j, ascending) and their
        dR_a/du_b [N/m] for their neighbours b (``RigidFlat.neighbours_of``: on the uniform grid
        the 25 of ``NEIGHBOURS``, a neighbour met twice on a grid smaller than 5 holding its
        block once), shape (m, width, 3, 3)."""
        return self.stiffness()

    @cached_property
    def coupling_blocks(self) -> tuple[np.ndarray, np.ndarray]:
        """The part of :attr:`node_blocks` that is the ramp's coupling dt/dp (the non-symmetric
        part of the tangent), as nodes and blocks [N/m] in the same layout."""
        return self.stiffness(coupling_only=True)

    @property
    def node_stiffness(self) -> np.ndarray:
        """:attr:`node_blocks` of every grid node (zero where there is none), (N^2, width, 3,
        3)."""
        nodes, blocks = self.node_blocks
        stiffness = np.zeros((len(self.node_gap),) + blocks.shape[1:])
        stiffness[nodes] = blocks
        return stiffness


@dataclass(frozen=True)
class ContactHistory:
    """What a converged step leaves at the contact points and nodes (arrays are replaced, never
    changed in place, by the solver: a history stays valid to return to).

    Attributes
    ----------
    stick_offset : numpy.ndarray
        Stick points w_s [m], shape (P, 2).
    slipped : numpy.ndarray
        Slipping (bool, (P,)).
    anchored : numpy.ndarray
        In contact (bool, (P,)): only these carry shear in the next step.
    multiplier : numpy.ndarray
        Uzawa multipliers lambda_a [Pa], shape (N^2,).
    """

    stick_offset: np.ndarray
    slipped: np.ndarray
    anchored: np.ndarray
    multiplier: np.ndarray


class RigidFlat:
    """The contact surface (faces on the N x N grid): its quadrature, the gathers of the surface
    nodes over the ranks, the contact law at its points and their history.

    Each rank evaluates the faces near the surface nodes it owns (:func:`local_faces`): point
    arrays hold those faces' points, node arrays span the N^2 grid nodes and are exact for the
    owned nodes (and their neighbours), zero where no local face is. Integrals, counts and maps
    are over all ranks (collective calls).

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator (gathers the surface displacements).
    nodes : numpy.ndarray
        Local indices of the free surface nodes this rank owns (one per grid position i, j < N
        where a face corner does not hang), shape (m,).
    grid_index : numpy.ndarray
        (i, j) of those nodes, shape (m, 2).
    grid_size : int
        N [-].
    heights : numpy.ndarray
        Surface heights Z [m] of the owned nodes, shape (m,).
    spacing : float
        Grid spacing h_grid [m].
    law : ContactLaw
        Pressure and friction at the points.
    points_per_side : int
        Gauss points per face side n [-].
    cells : CellSizes, optional
        Cell sizes of an adaptive block (``geometry.adaptive``): the faces are its top cells,
        ``nodes`` its free (not hanging) surface nodes; default the uniform N x N faces.

    Attributes
    ----------
    committed : ContactHistory
        The history of the last converged step.
    multiplier : numpy.ndarray
        The current multipliers lambda_a [Pa] (Uzawa updates them within a step).
    """

    def __init__(self, comm, nodes: np.ndarray, grid_index: np.ndarray, grid_size: int,
                 heights: np.ndarray, spacing: float, law: ContactLaw, points_per_side: int = 2,
                 cells: CellSizes | None = None):
        self.comm = comm
        self.nodes = nodes
        self.grid_size = n = grid_size
        self.spacing = spacing
        self.law = law
        self.owned_grid = grid_index[:, 0] * n + grid_index[:, 1]  # grid node of each owned node
        self._gathered_grid = np.concatenate(comm.allgather(self.owned_grid))
        faces = surface_faces(n, cells)
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
        self._counted_area = self.point_area * np.repeat(counted, len(self.weight))  # [m^2]
        self.face_counted = counted
        self.stencil_nodes = np.sort(self.owned_grid)  # rows of ``neighbours``
        self.neighbours = (neighbour_stencil(n, self.stencil_nodes) if faces.uniform
                           else coupling_pattern(self.stencil_nodes, self._to_nodes,
                                                 self._point_pressure, self._gap_gradient,
                                                 self._interpolation))
        self._first_neighbour = first_occurrences(self.neighbours)
        num_points = len(self.point_weight)
        self.committed = ContactHistory(np.zeros((num_points, 2)),
                                        np.zeros(num_points, dtype=bool),
                                        np.zeros(num_points, dtype=bool), np.zeros(n * n))
        self.multiplier = self.committed.multiplier

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
        self._interpolation = sparse.csr_matrix(
            (corner_weight.ravel(), (np.broadcast_to(point, corner_nodes.shape).ravel(),
                                     corner_nodes.ravel())), shape=(num_points, n * n))
        self._to_nodes = (self._interpolation.T @ sparse.diags(self.point_area)).tocsr()
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
        self._tributary = (sparse.diags(np.where(self.node_free, 1.0 / np.where(
            self.node_free, self.node_area, 1.0), 0.0)) @ area).tocsr()
        self._point_pressure = (sparse.diags(1.0 / self.point_area) @ area.T).tocsr()
        self._gap_gradient = (self._tributary @ self._interpolation).tocsr()

    # --- the surface grid ---------------------------------------------------------------------

    def gather_nodes(self, values: np.ndarray) -> np.ndarray:
        """Owned-node values of every rank as one array over the grid nodes i N + j (zero where
        the surface has no free node)."""
        values = np.asarray(values)
        gathered = np.zeros((self.grid_size**2,) + values.shape[1:], dtype=values.dtype)
        gathered[self._gathered_grid] = np.concatenate(self.comm.allgather(values))
        return gathered

    def interpolate(self, node_values: np.ndarray) -> np.ndarray:
        """Grid-node values at the integration points (bilinear in each face), shape (P, ...)."""
        return self._interpolation @ node_values

    def to_nodes(self, point_values: np.ndarray) -> np.ndarray:
        """sum_q A_f w_q N_a(q) v_q for every grid node a: point densities [x/m^2] as
        consistent nodal values [x]."""
        return self._to_nodes @ point_values

    # --- the contact law ------------------------------------------------------------------------

    def respond(self, displacement: np.ndarray, flat_height: float, flat_slide: float,
                trial: Trial = FRICTIONLESS) -> ContactResponse:
        """Contact state of all nodes and integration points for a trial displacement and flat
        position.

        Parameters
        ----------
        displacement : numpy.ndarray
            Local displacement array of the solid [m], shape (num_nodes, 3).
        flat_height : float
            h [m].
        flat_slide : float
            U, the flat's x displacement [m].
        trial : Trial
            Friction, predictor, frozen set and tangent (default: frictionless, the law's
            contact set, the exact tangent).
        """
        law, history = self.law, self.committed
        u = self.interpolate(self.gather_nodes(displacement[self.nodes]))
        gap = flat_height - (self.heights + u[:, 2])
        node_gap = self._tributary @ gap
        node_pressure, node_active = law.pressure(self.multiplier, node_gap, trial.active)
        pressure = self._point_pressure @ node_pressure  # < 0 only under a frozen node
        in_contact = pressure > 0.0
        relative = np.column_stack([flat_slide - u[:, 0], -u[:, 1]])  # w [m]
        frictional = in_contact & trial.friction & history.anchored
        capped = history.slipped if trial.predictor else frictional
        shear = law.friction(relative - history.stick_offset, pressure, frictional, capped)

        stiffness = law.pressure_stiffness(node_active)
        pressure_height = -(self._point_pressure @ stiffness)  # dp_q/dh
        # below p_r a slipping point's traction c(p) n follows its pressure
        coupling = law.pressure_coupling(shear, pressure)  # dc/dp n [-]
        coupled = bool(np.any(coupling))
        if trial.tangent is Tangent.SYMMETRIC:
            coupling = np.zeros_like(coupling)
        height_derivative = np.column_stack([-coupling * pressure_height[:, None],
                                             pressure_height])
        point_force = np.column_stack([-shear.traction, pressure])
        return ContactResponse(
            gap=gap,
            node_gap=node_gap,
            node_active=node_active,
            node_pressure=node_pressure,
            in_contact=in_contact,
            slipping=shear.slipping,
            pressure=pressure,
            traction=shear.traction,
            stick_offset=relative - shear.traction / law.tangential_penalty,
            node_force=self.to_nodes(point_force),
            stiffness=self._stiffness(stiffness, coupling,
                                      lambda: law.slip_tangent(shear, frictional)),
            node_height_derivative=self.to_nodes(height_derivative),
            coupled=coupled,
            symmetric=not np.any(coupling),
        )

    def _stiffness(self, pressure_stiffness: np.ndarray, coupling: np.ndarray,
                   slip_tangent: Callable[[], np.ndarray]) -> Callable:
        """The contact tangent's node blocks (:attr:`ContactResponse.stiffness`) from the law's
        -dp/dg~ of the nodes [Pa/m], dt/dp of the points [-] and dt/ds of the points [Pa/m]
        (computed on the first call)."""
        @cache
        def pressure_columns() -> tuple:
            # dp_q/du_z,b = eps (W^T/w) (W N), and the shear rows' ramp coupling dt/dp through
            # it (both parts of the tangent need them: computed once)
            pressure_gradient = (self._point_pressure @ sparse.diags(pressure_stiffness)
                                 @ self._gap_gradient)
            return pressure_gradient, [-(self._to_nodes @ sparse.diags(coupling[:, i])
                                         @ pressure_gradient) for i in range(2)]

        def node_stiffness(coupling_only: bool = False) -> tuple[np.ndarray, np.ndarray]:
            # tangent per unit area [Pa/m] as 3 x 3 component matrices over the grid nodes:
            # shear by the point tangent, pressure and the ramp's coupling by pressure_columns
            # (the coupling alone if ``coupling_only``)
            pressure_gradient, shear_coupling = pressure_columns()
            blocks = np.full((3, 3), None, dtype=object)
            blocks[0, 2], blocks[1, 2] = shear_coupling
            if coupling_only:
                return self._node_tangent(blocks)
            shear = slip_tangent()
            for i in range(2):
                for j in range(2):
                    blocks[i, j] = (self._to_nodes @ sparse.diags(shear[:, i, j])
                                    @ self._interpolation)
            blocks[2, 2] = self._to_nodes @ pressure_gradient
            return self._node_tangent(blocks)

        return node_stiffness

    def _node_tangent(self, blocks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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

    # --- history --------------------------------------------------------------------------------

    def commit(self, response: ContactResponse) -> None:
        """Keep the stick points, slip states and multipliers of a converged step."""
        self.committed = ContactHistory(response.stick_offset, response.slipping,
                                        response.in_contact, self.multiplier)

    def restore(self) -> None:
        """Return the multipliers to the last converged step (after a failed step)."""
        self.multiplier = self.committed.multiplier

    def resume(self, history: ContactHistory) -> None:
        """Return to an earlier :attr:`committed` history."""
        self.committed = history
        self.restore()

    def augment(self, response: ContactResponse) -> None:
        """Uzawa update of the multipliers: lambda_a <- p_a."""
        self.multiplier = response.node_pressure.copy()

    # --- measures -------------------------------------------------------------------------------

    def penetration(self, response: ContactResponse) -> float:
        """Deepest penetration -g~_a of a node in contact [m], over all ranks."""
        owned = self.owned_grid
        deepest = np.max(-response.node_gap[owned][response.node_active[owned]], initial=0.0)
        return float(self.comm.allreduce(deepest, op=MPI.MAX))

    def integrate(self, point_values: np.ndarray) -> float:
        """sum_q A_f w_q v_q over all faces of all ranks: the integral of a point density
        [x m^2]."""
        return float(self.comm.allreduce(float(self._counted_area @ point_values)))

    def normal_force(self, response: ContactResponse) -> float:
        """F_n = integral of p over the surface [N]."""
        return self.integrate(response.pressure)

    def tangential_force(self, response: ContactResponse) -> float:
        """F_t = integral of t_x: the x force needed to hold the flat [N]."""
        return self.integrate(response.traction[:, 0])

    def stuck_shear_reserve(self, response: ContactResponse) -> float:
        """The x force the sticking contact points could still add before they slip: the
        integral of c(p) - t_x over the points in contact below the cap [N] (a collective
        call)."""
        sticking = response.in_contact & ~response.slipping
        reserve = self.law.shear_cap(response.pressure) - response.traction[:, 0]
        return self.integrate(np.where(sticking, reserve, 0.0))

    def area_ratio(self, mask: np.ndarray) -> float:
        """Fraction of the nominal area whose points satisfy ``mask`` (e.g. p > 0) [-]."""
        return self.integrate(mask) / (self.grid_size * self.spacing) ** 2

    def count(self, mask: np.ndarray) -> int:
        """Number of surface nodes (over all ranks) where the node ``mask`` holds [-]."""
        return int(self.comm.allreduce(np.count_nonzero(mask[self.owned_grid])))

    def node_maps(self, response: ContactResponse) -> dict:
        """N x N nodal maps ([i, j] at x = i h, y = j h on the finest grid) of a contact state,
        the same on every rank (a collective call).

        "contact": p_a > 0 (bool); "slip": in contact and every point of its tributary area
        slipping (bool); "pressure" and "shear_x": the consistent nodal forces over the node's
        tributary area A_a [Pa]; "contact_fraction": per finest cell (i, j), the fraction of the
        area of the face holding it in contact [-]; "gap": the weighted gap g~_a between the
        flat and the deformed surface [m] (negative: penetration). Grid points without a free
        surface node (inside a coarse face, or where it hangs) are out of contact with zero
        forces and no gap (NaN).
        """
        n, owned = self.grid_size, self.owned_grid
        touching_area = self._tributary @ response.in_contact.astype(float)
        sticking_area = self._tributary @ (response.in_contact & ~response.slipping).astype(float)
        area = self.node_area[owned]
        nodal = self.gather_nodes(np.column_stack([
            touching_area[owned], sticking_area[owned], response.node_force[owned, 2] / area,
            -response.node_force[owned, 0] / area, response.node_gap[owned]]))
        fraction = (self.point_weight * response.in_contact).reshape(len(self.face_area), -1).sum(
            axis=1)
        face_fraction = np.zeros(self.num_faces)
        face_fraction[self.face_ids[self.face_counted]] = fraction[self.face_counted]
        touching, sticking = nodal[:, 0] > 0.0, nodal[:, 1] > 0.0
        return {
            "contact": touching.reshape(n, n),
            "slip": (touching & ~sticking).reshape(n, n),
            "pressure": nodal[:, 2].reshape(n, n),
            "shear_x": nodal[:, 3].reshape(n, n),
            "contact_fraction": self.faces.on_grid(self.comm.allreduce(face_fraction)),
            "gap": np.where(self.surface_node, nodal[:, 4], np.nan).reshape(n, n),
        }

    def touching_height(self, displacement: np.ndarray, force: float,
                        elastic_modulus: float) -> float:
        """A first guess of the flat height h [m] carrying ``force`` [N] from ``displacement``,
        over all ranks' nodes (a collective call).

        Every node is a spring k, the penalty eps a in series with the solid under it, taken as
        a uniformly loaded square of its tributary area a = A_a on a half-space (mean
        deflection 0.95 p sqrt(a) / E', Timoshenko & Goodier), and sum k <-g~_a(h)> = force is
        solved exactly (the penalty alone would put the whole load on the highest
        point, from where Newton overshoots into deep penetration).

        Parameters
        ----------
        displacement : numpy.ndarray
            Local displacement array [m], shape (num_nodes, 3).
        force : float
            Normal force [N].
        elastic_modulus : float
            E' = E / (1 - nu^2) [Pa].
        """
        owned = self.owned_grid
        tops = (self._tributary @ (self.heights + self.interpolate(
            self.gather_nodes(displacement[self.nodes, 2]))))[owned]  # h - g~_a [m]
        tops, area = self.gather_nodes(np.column_stack([tops, self.node_area[owned]]))[
            self.surface_node].T
        stiffness = 1.0 / (1.0 / (self.law.penalty * area)
                           + 0.95 / (elastic_modulus * np.sqrt(area)))
        order = np.argsort(tops)[::-1]
        tops, stiffness = tops[order], stiffness[order]
        # with the m highest nodes in contact: h = (sum k z - force) / sum k
        heights = (np.cumsum(stiffness * tops) - force) / np.cumsum(stiffness)
        below_next = np.append(heights[:-1] >= tops[1:], True)
        return float(heights[np.argmax(below_next)])
