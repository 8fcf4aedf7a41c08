"""Contact and friction of the block's top faces against a rigid flat, at integration points.

The flat is horizontal at height h and slides by U in x. The contact surface is the top of the
hexahedral mesh: N x N periodic faces of side h_grid, each the bilinear interpolant of its four
corner nodes (the surface the FEM resolves). Inside every face, n x n Gauss points q (weights
w_q, sum 1; shape functions N_a of the corners a) carry

* gap g_q = h - sum_a N_a (Z_a + u_z,a) and pressure p_q = <lambda_q - eps_N g_q>
  (augmented Lagrangian: lambda_q = 0 is the pure penalty; after a converged Newton solve, Uzawa
  sets lambda_q <- p_q and re-solves until no point penetrates deeper than a tolerance, so the
  contact area does not depend on eps_N);
* friction by a return map under the maximum shear stress criterion (the paper's tau_c): with
  w_q = (U - u_x, -u_y) at q and the committed stick point w_s,q, the trial traction is
  t* = eps_T (w_q - w_s,q); the point sticks if |t*| <= c_q, else slips with t = c_q t*/|t*|,
  under the cap c_q = tau_c min(1, p_q / p_r) (ANSYS's min(mu p, tau_max) with mu = tau_c / p_r:
  continuous in p, so a point at a patch edge has a consistent state).

Forces and tangent go to the corner nodes through the shape functions:
f_a = h_grid^2 sum_q w_q N_a(q) (-t_q, p_q) and K_ab = h_grid^2 sum_q w_q N_a N_b D_q, with D_q the
point's 3 x 3 tangent. The contact area is the measure of the faces' points with p_q > 0.
A slipping point below p_r couples its traction to its pressure (dt/dp = tau_c / p_r along the
slip): that part of D_q is not symmetric (``ContactResponse.symmetric``).

Stick before slide: at the first Newton iterate of a tangential step, points that stuck at the
last converged step keep the uncapped stick law (tangential predictor). A point out of contact at
the last converged step carries no shear in the step in which it touches and sticks where it is
at its end. Frictionless steps (the preload) have t = 0, so sliding starts from full stick.

Every rank evaluates all N^2 faces from the gathered surface displacements (cheap NumPy over
N^2 n^2 points, identical on every rank) and adds the rows of the surface nodes it owns: the
contact state is the same on any number of ranks.

Signs: R = f_int - f_ext. The flat pushes with -p e_z and drags with t, so node a's residual
gains f_a = sum (-t_x, -t_y, p) w N_a h_grid^2, and dR_z/dh = -eps_N (in contact).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse

#: Corner offsets (di, dj) of a face's nodes a = 0..3 from its node (i, j).
CORNERS = np.array([(0, 0), (1, 0), (0, 1), (1, 1)])
#: Neighbour offsets (di, dj) of a node's 9 couplings, in the order of ``node_stiffness``.
NEIGHBOURS = np.array([(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1)])


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


@dataclass(frozen=True)
class ContactResponse:
    """Contact state at every integration point, and its nodal forces and tangent.

    Point arrays have shape (N^2 n^2,) (face-major); node arrays are indexed by the surface grid
    node i N + j.

    Attributes
    ----------
    gap : numpy.ndarray
        g_q [m].
    in_contact : numpy.ndarray
        p_q > 0 (or the frozen set), bool.
    slipping : numpy.ndarray
        In contact and at the friction cap, bool.
    pressure : numpy.ndarray
        p_q [Pa].
    traction : numpy.ndarray
        Tangential traction of the flat, t_q [Pa], shape (P, 2).
    stick_offset : numpy.ndarray
        w_s to commit [m], shape (P, 2).
    node_force : numpy.ndarray
        Contact contribution to the nodal residual R [N], shape (N^2, 3).
    node_stiffness : numpy.ndarray
        dR_a/du_b [N/m] for the 9 neighbours b of node a (``NEIGHBOURS``), shape (N^2, 9, 3, 3).
    node_height_derivative : numpy.ndarray
        dR_a/dh [N/m], shape (N^2, 3).
    symmetric : bool
        No slipping point couples its traction to its pressure.
    """

    gap: np.ndarray
    in_contact: np.ndarray
    slipping: np.ndarray
    pressure: np.ndarray
    traction: np.ndarray
    stick_offset: np.ndarray
    node_force: np.ndarray
    node_stiffness: np.ndarray
    node_height_derivative: np.ndarray
    symmetric: bool


class RigidFlat:
    """The contact surface (N x N faces), its history at the integration points, the laws.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator (gathers the surface displacements).
    nodes : numpy.ndarray
        Local indices of the surface nodes this rank owns (one per grid position i, j < N),
        shape (m,).
    grid_index : numpy.ndarray
        (i, j) of those nodes, shape (m, 2).
    grid_size : int
        N [-].
    heights : numpy.ndarray
        Surface heights Z [m] of the owned nodes, shape (m,).
    spacing : float
        Grid spacing h_grid [m].
    penalty : float
        Normal penalty eps_N [Pa/m].
    shear_strength : float
        tau_c [Pa].
    ramp_pressure : float
        p_r: the cap is tau_c min(1, p / p_r) [Pa]; 0 for the pure cap tau_c.
    tangential_penalty : float
        Stick penalty eps_T [Pa/m].
    points_per_side : int
        Gauss points per face side n [-].
    """

    def __init__(self, comm, nodes: np.ndarray, grid_index: np.ndarray, grid_size: int,
                 heights: np.ndarray, spacing: float, penalty: float, shear_strength: float,
                 ramp_pressure: float, tangential_penalty: float, points_per_side: int = 2):
        self.comm = comm
        self.nodes = nodes
        self.grid_size = n = grid_size
        self.spacing = spacing
        self.penalty = penalty
        self.tangential_penalty = tangential_penalty
        self.shear_strength = shear_strength
        self.ramp_pressure = ramp_pressure
        self.owned_grid = grid_index[:, 0] * n + grid_index[:, 1]  # grid node of each owned node
        self._gather_order = np.argsort(np.concatenate(comm.allgather(self.owned_grid)))
        if len(self._gather_order) != n * n or np.any(
                np.sort(self._gather_order) != np.arange(n * n)):
            raise RuntimeError(f"surface nodes do not cover the {n} x {n} grid once")
        self.node_heights = self.gather_nodes(heights)

        self.shape, self.weight = face_quadrature(points_per_side)
        q = len(self.weight)
        i, j = np.divmod(np.arange(n * n), n)
        # corners[f, a]: grid node of corner a of face f = i N + j
        self.corners = (((i[:, None] + CORNERS[:, 0]) % n) * n + (j[:, None] + CORNERS[:, 1]) % n)
        self.point_weight = np.tile(self.weight, n * n)  # w_q per point (face area units)
        self.heights = self.interpolate(self.node_heights)  # Z at the points [m]
        # sparse sums: point -> node (weights w_q N_a) and (face, a, b) -> (node a, neighbour)
        rows = np.repeat(self.corners, q, axis=0).reshape(n * n, q, 4)
        self._to_nodes = sparse.csr_matrix(
            ((self.weight[:, None] * self.shape)[None].repeat(n * n, 0).ravel(),
             (rows.ravel(), np.repeat(np.arange(n * n * q), 4))), shape=(n * n, n * n * q))
        offset = (CORNERS[None, :, :] - CORNERS[:, None, :] + 1) @ np.array([3, 1])  # (a, b)
        pair_rows = self.corners[:, :, None] * 9 + offset[None]
        self._pairs_to_nodes = sparse.csr_matrix(
            (np.ones(pair_rows.size), (pair_rows.ravel(), np.arange(pair_rows.size))),
            shape=(9 * n * n, pair_rows.size))
        self._pair_shape = np.einsum("q,qa,qb->qab", self.weight, self.shape, self.shape)

        num_points = n * n * q
        self.stick_offset = np.zeros((num_points, 2))
        self.slipped = np.zeros(num_points, dtype=bool)  # slipping at the last converged step
        self.anchored = np.zeros(num_points, dtype=bool)  # in contact at the last converged step
        self.multiplier = np.zeros(num_points)  # lambda_q [Pa]
        self._committed_multiplier = self.multiplier

    # --- the surface grid ---------------------------------------------------------------------

    def gather_nodes(self, values: np.ndarray) -> np.ndarray:
        """Owned-node values of every rank as one array over the grid nodes i N + j."""
        return np.concatenate(self.comm.allgather(np.asarray(values)))[self._gather_order]

    def interpolate(self, node_values: np.ndarray) -> np.ndarray:
        """Grid-node values at the integration points (bilinear in each face), shape (P, ...)."""
        corner_values = node_values[self.corners]  # (F, 4, ...)
        return np.einsum("qa,fa...->fq...", self.shape, corner_values).reshape(
            (-1,) + node_values.shape[1:])

    def to_nodes(self, point_values: np.ndarray) -> np.ndarray:
        """sum_q w_q N_a(q) v_q h_grid^2 for every grid node a: point densities [x/m^2] as
        consistent nodal values [x]."""
        return self._to_nodes @ point_values * self.spacing**2

    # --- the contact law ------------------------------------------------------------------------

    def respond(self, displacement: np.ndarray, flat_height: float, flat_slide: float,
                friction: bool, predictor: bool = False, active: np.ndarray | None = None
                ) -> ContactResponse:
        """Contact state of all integration points for a trial displacement and flat position.

        Parameters
        ----------
        displacement : numpy.ndarray
            Local displacement array of the solid [m], shape (num_nodes, 3).
        flat_height : float
            h [m].
        flat_slide : float
            U, the flat's x displacement [m].
        friction : bool
            Frictional (tangential phase) or frictionless (normal preload).
        predictor : bool
            Stick law without cap for points that stuck at the last converged step.
        active : numpy.ndarray, optional
            Frozen contact set of the points, bool: these carry lambda_q - eps_N g_q even if it
            is negative; the others join when they penetrate (the set only grows: no cycling;
            the caller judges a converged iterate under the free law).
        """
        eps, eps_t = self.penalty, self.tangential_penalty
        u = self.interpolate(self.gather_nodes(displacement[self.nodes]))
        gap = flat_height - (self.heights + u[:, 2])
        trial_pressure = self.multiplier - eps * gap
        in_contact = trial_pressure > 0.0
        if active is not None:
            in_contact |= active
        pressure = np.where(in_contact, trial_pressure, 0.0)
        relative = np.column_stack([flat_slide - u[:, 0], -u[:, 1]])  # w [m]
        trial = eps_t * (relative - self.stick_offset)
        trial_norm = np.linalg.norm(trial, axis=1)
        frictional = in_contact & friction & self.anchored
        capped = self.slipped if predictor else frictional
        cap = self.shear_cap(pressure)
        slipping = frictional & capped & (trial_norm > cap)
        scale = np.where(slipping, cap / np.where(slipping, trial_norm, 1.0), 1.0)
        traction = np.where(frictional[:, None], scale[:, None] * trial, 0.0)

        # point tangent D_q [Pa/m] and dR/dh per unit area
        direction = trial / np.where(trial_norm > 0.0, trial_norm, 1.0)[:, None]
        tangential = np.eye(2) - np.where(slipping, 1.0, 0.0)[:, None, None] * np.einsum(
            "ni,nj->nij", direction, direction)
        tangent = np.zeros((len(gap), 3, 3))
        tangent[:, :2, :2] = np.where(frictional, eps_t * scale, 0.0)[:, None, None] * tangential
        tangent[:, 2, 2] = np.where(in_contact, eps, 0.0)
        # below p_r a slipping point's traction c(p) n follows p = lambda - eps g:
        # dR_xy/du_z = -eps dc/dp n, dR_xy/dh = +eps dc/dp n
        coupling = (eps * self.cap_slope(pressure, slipping))[:, None] * direction
        tangent[:, :2, 2] = -coupling
        height_derivative = np.column_stack([coupling, np.where(in_contact, -eps, 0.0)])
        point_force = np.column_stack([-traction, pressure])
        return ContactResponse(
            gap=gap,
            in_contact=in_contact,
            slipping=slipping,
            pressure=pressure,
            traction=traction,
            stick_offset=relative - traction / eps_t,
            node_force=self.to_nodes(point_force),
            node_stiffness=self._node_tangent(tangent),
            node_height_derivative=self.to_nodes(height_derivative),
            symmetric=not np.any(coupling),
        )

    def _node_tangent(self, tangent: np.ndarray) -> np.ndarray:
        """K_ab = h_grid^2 sum_q w_q N_a N_b D_q summed into (node a, neighbour b) blocks,
        shape (N^2, 9, 3, 3), from the point tangents D_q (P, 3, 3) [Pa/m]."""
        n2, q = self.grid_size**2, len(self.weight)
        pairs = np.einsum("qab,fqij->fabij", self._pair_shape, tangent.reshape(n2, q, 3, 3))
        return (self._pairs_to_nodes @ pairs.reshape(-1, 9)).reshape(n2, 9, 3, 3) \
            * self.spacing**2

    def shear_cap(self, pressure: np.ndarray) -> np.ndarray:
        """c = tau_c min(1, p / p_r) [Pa] (tau_c if p_r = 0) at the pressures ``pressure``
        [Pa]."""
        if self.ramp_pressure == 0.0:
            return np.full_like(pressure, self.shear_strength)
        return self.shear_strength * np.clip(pressure / self.ramp_pressure, 0.0, 1.0)

    def cap_slope(self, pressure: np.ndarray, slipping: np.ndarray) -> np.ndarray:
        """dc/dp of slipping points [-]: tau_c / p_r where 0 < p < p_r, else 0."""
        if self.ramp_pressure == 0.0:
            return np.zeros_like(pressure)
        ramping = slipping & (pressure > 0.0) & (pressure < self.ramp_pressure)
        return np.where(ramping, self.shear_strength / self.ramp_pressure, 0.0)

    # --- history --------------------------------------------------------------------------------

    def commit(self, response: ContactResponse) -> None:
        """Keep the stick points, slip states and multipliers of a converged step."""
        self.stick_offset = response.stick_offset
        self.slipped = response.slipping
        self.anchored = response.in_contact
        self._committed_multiplier = self.multiplier

    def restore(self) -> None:
        """Return the multipliers to the last converged step (after a failed step)."""
        self.multiplier = self._committed_multiplier

    def committed_state(self) -> tuple:
        """The committed stick points, slip and contact flags and multipliers (arrays are
        replaced, never changed in place, so references stay valid)."""
        return self.stick_offset, self.slipped, self.anchored, self._committed_multiplier

    def resume(self, state: tuple) -> None:
        """Return to a :meth:`committed_state`."""
        self.stick_offset, self.slipped, self.anchored, self._committed_multiplier = state
        self.multiplier = self._committed_multiplier

    def augment(self, response: ContactResponse) -> None:
        """Uzawa update of the multipliers: lambda_q <- p_q."""
        self.multiplier = response.pressure.copy()

    # --- measures -------------------------------------------------------------------------------

    def penetration(self, response: ContactResponse) -> float:
        """Deepest penetration -g_q of a point in contact [m]."""
        return float(np.max(-response.gap[response.in_contact], initial=0.0))

    def integrate(self, point_values: np.ndarray) -> float:
        """sum_q w_q v_q h_grid^2 over all faces: the integral of a point density [x m^2]."""
        return float(self.point_weight @ point_values) * self.spacing**2

    def normal_force(self, response: ContactResponse) -> float:
        """F_n = integral of p over the surface [N]."""
        return self.integrate(response.pressure)

    def tangential_force(self, response: ContactResponse) -> float:
        """F_t = integral of t_x: the x force needed to hold the flat [N]."""
        return self.integrate(response.traction[:, 0])

    def area_ratio(self, mask: np.ndarray) -> float:
        """Fraction of the nominal area whose points satisfy ``mask`` (e.g. p > 0) [-]."""
        return float(self.point_weight @ mask) / self.grid_size**2

    def count(self, mask: np.ndarray) -> int:
        """Number of integration points where ``mask`` holds [-]."""
        return int(np.count_nonzero(mask))

    def node_maps(self, response: ContactResponse) -> dict:
        """N x N nodal maps ([i, j] at x = i h, y = j h) of a contact state.

        "contact": a point in contact in the node's faces (bool); "slip": in contact and every
        contact point of its faces slipping (bool); "pressure" and "shear_x": the consistent
        nodal forces over h_grid^2 [Pa]; "contact_fraction": per face (i, j), the fraction of
        its area in contact [-].
        """
        n = self.grid_size
        weight = self.point_weight
        touching = self._to_nodes @ response.in_contact.astype(float)
        sticking = self._to_nodes @ (response.in_contact & ~response.slipping).astype(float)
        area = self.spacing**2
        fraction = (weight * response.in_contact).reshape(n * n, -1).sum(axis=1)
        return {
            "contact": (touching > 0.0).reshape(n, n),
            "slip": ((touching > 0.0) & (sticking == 0.0)).reshape(n, n),
            "pressure": (response.node_force[:, 2] / area).reshape(n, n),
            "shear_x": (-response.node_force[:, 0] / area).reshape(n, n),
            "contact_fraction": fraction.reshape(n, n),
        }

    def touching_height(self, displacement: np.ndarray, force: float,
                        elastic_modulus: float) -> float:
        """A first guess of the flat height h [m] carrying ``force`` [N] from ``displacement``.

        Every integration point is a spring k, the penalty eps a_q in series with the solid
        under it, taken as a uniformly loaded square of area a_q on a half-space (mean
        deflection 0.95 p sqrt(a_q) / E', Timoshenko & Goodier), and sum k <Z_q + u_z,q - h> =
        force is solved exactly (the penalty alone would put the whole load on the highest
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
        tops = self.heights + self.interpolate(
            self.gather_nodes(displacement[self.nodes, 2]))
        area = self.point_weight * self.spacing**2
        stiffness = 1.0 / (1.0 / (self.penalty * area)
                           + 0.95 / (elastic_modulus * np.sqrt(area)))
        order = np.argsort(tops)[::-1]
        tops, stiffness = tops[order], stiffness[order]
        # with the m highest points in contact: h = (sum k z - force) / sum k
        heights = (np.cumsum(stiffness * tops) - force) / np.cumsum(stiffness)
        below_next = np.append(heights[:-1] >= tops[1:], True)
        return float(heights[np.argmax(below_next)])
