"""Node-based penalty contact and friction of the surface nodes against a rigid flat.

The flat is horizontal at height h and slides by U in x. Surface node k (grid height Z_k,
tributary area a_k = h_grid^2 of the projected surface) has

* gap g_k = h - (Z_k + u_z,k); pressure p_k = <lambda_k - eps_N g_k> (augmented Lagrangian,
  like the paper's ANSYS contact): lambda_k = 0 is the pure penalty; after a converged Newton
  solve, Uzawa updates lambda_k <- p_k and re-solve until the penetration of every contact node is
  below a tolerance, which makes the contact area independent of eps_N. The node is in contact
  when p_k > 0;
* friction by a return map under the maximum shear stress criterion (the paper's tau_c): with
  w_k = (U - u_x,k, -u_y,k) the flat's tangential position relative to the node and w_s,k the
  committed stick offset, the trial traction is t* = eps_T (w_k - w_s,k); the node sticks if
  |t*| <= c_k, else slips with t = c_k t*/|t*|, under the cap c_k = tau_c min(1, p_k / p_r).

The stick penalty eps_T is a tenth of eps_N by default (``SolverOptions.tangential_penalty``).
With eps_T = eps_N = 10 E'/h the stick cone |w - w_s| <= tau_c / eps_T is ~1e-9 m at N = 32,
the size of the slide increments near inception at high load: there hundreds of nodes flipped
between stick and slip from one Newton iterate to the next, every step took 11-15 iterations
and the increments could not grow (8L at F* = 0.93: 145 sliding steps of ~2e-9 m, 313 s; G7,
G8, G9, 2L, 8L at F* = 1.86 hit the step limit). With eps_T = eps_N / 10: 8L at F* = 0.93 in
11 sliding steps, 30 s, mu_s 0.4189 against 0.4187; G7 at F* = 1.86 converges in 31 s. mu_s
does not depend on it: eps_T / eps_N = 0.01, 0.1, 1 give 0.4189, 0.4189, 0.4187 (8L, F* = 0.93)
and 0.7565, 0.7564, 0.7566 (G5, F* = 0.155).

The cap is the paper's tau_c wherever the pressure exceeds the ramp pressure p_r (0.01 S_y by
default) and falls linearly to 0 with the pressure below it: ANSYS's form min(mu p, tau_max) of
the maximum shear stress criterion, with mu = tau_c / p_r. With the pure cap tau_c (p_r -> 0) a
node at the edge of a contact patch can have no consistent state: sticking, its shear lifts it
off the flat (p < 0); released, it penetrates (measured on a random 16 x 16 surface at
F* = 0.3: one node with 0.82 tau_c of shear at p = -1 MPa in contact and penetrating out of
contact, so Newton cycled until the step size vanished). The ramp makes the traction continuous
in p, so such a node slips at a small traction. Its cost: nodes below p_r carry less than tau_c
(G5 at F* = 0.155, N = 32: mu_s -0.04 % for p_r = 0.01 S_y, -0.8 % for 0.02 S_y, -2.4 % for
0.05 S_y, against the pure cap, which converges there).

Tangent of a slipping node: eps_T (c_k/|t*|) (I - n n^T) in the plane, which is symmetric, plus,
below p_r, the coupling of its traction to its pressure, dt/dp = (tau_c/p_r) n, which is not
(the node's x-y rows gain a u_z and an h column). That coupling is kept: without it Newton on a
node below p_r is a fixed-point iteration that diverges when mu = tau_c / p_r times the node's
shear-to-lift compliance exceeds 1 (G5, N = 64: residual stuck at 8e-6 F_n, step cut).
``ContactResponse.symmetric`` says whether any node couples (the linear solver then switches
from CG to GMRES).

Tangential predictor: at the first Newton iteration of a tangential step, nodes that stuck at
the last converged step keep the uncapped (linear) stick law. Without it, the trial traction
eps_T dU of a whole slide increment exceeds tau_c everywhere (eps_T is stiffer than the
solid under a node), every node "slips", the slip tangent has no stiffness along the slide
and Newton overshoots back and forth across the small stick cone |w - w_s| <= tau_c / eps_T.

On commit w_s <- w - t/eps_T: a sticking node keeps its offset, a slipping node drags it. A node
that was out of contact at the last converged step has no stick point yet: it carries no shear
in the step in which it touches and sticks where it is at the end of that step (its stick point
is taken at the end of the step rather than at its start). This rule came before the pressure
ramp of the cap: with the pure cap a node touching at a vanishing pressure would at once carry
tau_c, a jump that made such nodes flip in and out of contact from one Newton iterate to the
next (with the ramp its cap is small there; whether the rule is still needed is not measured).
Frictionless steps (``friction=False``, the normal preload) have t = 0 everywhere, so the first
frictional step starts from full stick at every node in contact, as in the paper.

Signs: R = f_int - f_ext. The flat pushes the node with -p a e_z and drags it with t a, so the
node's residual gains (-t_x a, -t_y a, p a), and dR_z/dh = -eps_N a on nodes in contact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from mpi4py import MPI


@dataclass(frozen=True)
class ContactResponse:
    """Tractions, forces and tangent of the surface nodes for one trial state.

    Attributes
    ----------
    gap : numpy.ndarray
        g_k = h - (Z_k + u_z,k) [m], shape (n,).
    in_contact : numpy.ndarray
        p_k > 0, shape (n,), bool.
    slipping : numpy.ndarray
        In contact and at the friction cap, shape (n,), bool.
    pressure : numpy.ndarray
        p_k [Pa], shape (n,).
    traction : numpy.ndarray
        Tangential traction of the flat on the node, t_k [Pa], shape (n, 2).
    stick_offset : numpy.ndarray
        w_s to commit [m], shape (n, 2).
    force : numpy.ndarray
        Contact contribution to the nodal residual R [N], shape (n, 3).
    stiffness : numpy.ndarray
        dR/du blocks [N/m], shape (n, 3, 3).
    height_derivative : numpy.ndarray
        dR/dh [N/m], shape (n, 3).
    symmetric : bool
        No node on this rank couples its traction to its pressure (stiffness blocks symmetric).
    """

    gap: np.ndarray
    in_contact: np.ndarray
    slipping: np.ndarray
    pressure: np.ndarray
    traction: np.ndarray
    stick_offset: np.ndarray
    force: np.ndarray
    stiffness: np.ndarray
    height_derivative: np.ndarray
    symmetric: bool


class RigidFlat:
    """The surface nodes owned by this rank, their contact history and the penalty laws.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator (sums forces over ranks).
    nodes : numpy.ndarray
        Local indices of the surface nodes in the displacement array (blocks of 3), shape (n,).
    grid_index : numpy.ndarray
        (i, j) of each node on the N x N surface grid, shape (n, 2).
    grid_size : int
        N [-].
    heights : numpy.ndarray
        Surface heights Z_k [m], shape (n,).
    area : float
        Tributary (projected) area per node a = h^2 [m^2].
    penalty : float
        Normal penalty eps_N [Pa/m].
    shear_strength : float
        tau_c [Pa].
    ramp_pressure : float
        p_r: the cap is tau_c min(1, p / p_r) [Pa]; 0 for the pure cap tau_c.
    tangential_penalty : float
        Stick penalty eps_T [Pa/m].
    """

    def __init__(self, comm, nodes: np.ndarray, grid_index: np.ndarray, grid_size: int,
                 heights: np.ndarray, area: float, penalty: float, shear_strength: float,
                 ramp_pressure: float, tangential_penalty: float):
        self.comm = comm
        self.nodes = nodes
        self.grid_index = grid_index
        self.grid_size = grid_size
        self.heights = heights
        self.area = area
        self.penalty = penalty
        self.tangential_penalty = tangential_penalty
        self.shear_strength = shear_strength
        self.ramp_pressure = ramp_pressure
        self.stick_offset = np.zeros((len(nodes), 2))
        self.slipped = np.zeros(len(nodes), dtype=bool)  # slipping at the last converged step
        self.anchored = np.zeros(len(nodes), dtype=bool)  # in contact at the last converged step
        self.multiplier = np.zeros(len(nodes))  # lambda_k [Pa]
        self._committed_multiplier = self.multiplier

    def respond(self, displacement: np.ndarray, flat_height: float, flat_slide: float,
                friction: bool, predictor: bool = False, active: np.ndarray | None = None
                ) -> ContactResponse:
        """Contact state of the surface nodes for a trial displacement and flat position.

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
            Stick law without cap for nodes that stuck at the last converged step.
        active : numpy.ndarray, optional
            Frozen contact set, shape (n,), bool: these nodes carry lambda_k - eps_N g_k even
            if it is negative, the others none (a smooth problem for Newton; the caller judges
            a converged iterate under the free law).
        """
        u = displacement[self.nodes]
        a, eps, eps_t = self.area, self.penalty, self.tangential_penalty
        gap = flat_height - (self.heights + u[:, 2])
        trial_pressure = self.multiplier - eps * gap
        in_contact = trial_pressure > 0.0 if active is None else active
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

        direction = trial / np.where(trial_norm > 0.0, trial_norm, 1.0)[:, None]
        tangential = np.eye(2) - np.where(slipping, 1.0, 0.0)[:, None, None] * np.einsum(
            "ni,nj->nij", direction, direction)
        stiffness = np.zeros((len(u), 3, 3))
        stiffness[:, :2, :2] = (np.where(frictional, eps_t * a * scale, 0.0)[:, None, None]
                                * tangential)
        stiffness[:, 2, 2] = np.where(in_contact, eps * a, 0.0)
        # below p_r a slipping node's traction c(p) n follows its pressure p = lambda - eps g:
        # dR_xy/du_z = -a eps dc/dp n, dR_xy/dh = +a eps dc/dp n
        coupling = (eps * a * self.cap_slope(pressure, slipping))[:, None] * direction
        stiffness[:, :2, 2] = -coupling
        height_derivative = np.column_stack([coupling, np.where(in_contact, -eps * a, 0.0)])
        force = np.column_stack([-traction * a, pressure * a])
        return ContactResponse(
            gap=gap,
            in_contact=in_contact,
            slipping=slipping,
            pressure=pressure,
            traction=traction,
            stick_offset=relative - traction / eps_t,
            force=force,
            stiffness=stiffness,
            height_derivative=height_derivative,
            symmetric=not np.any(coupling),
        )

    def shear_cap(self, pressure: np.ndarray) -> np.ndarray:
        """c = tau_c min(1, p / p_r) [Pa] (tau_c if p_r = 0) at the pressures ``pressure``
        [Pa]."""
        if self.ramp_pressure == 0.0:
            return np.full_like(pressure, self.shear_strength)
        return self.shear_strength * np.clip(pressure / self.ramp_pressure, 0.0, 1.0)

    def cap_slope(self, pressure: np.ndarray, slipping: np.ndarray) -> np.ndarray:
        """dc/dp of slipping nodes [-]: tau_c / p_r where 0 < p < p_r, else 0."""
        if self.ramp_pressure == 0.0:
            return np.zeros_like(pressure)
        ramping = slipping & (pressure > 0.0) & (pressure < self.ramp_pressure)
        return np.where(ramping, self.shear_strength / self.ramp_pressure, 0.0)

    def commit(self, response: ContactResponse) -> None:
        """Keep the stick offsets, slip states and multipliers of a converged step."""
        self.stick_offset = response.stick_offset
        self.slipped = response.slipping
        self.anchored = response.in_contact
        self._committed_multiplier = self.multiplier

    def restore(self) -> None:
        """Return the multipliers to the last converged step (after a failed step)."""
        self.multiplier = self._committed_multiplier

    def committed_state(self) -> tuple:
        """The committed stick offsets, slip and contact flags and multipliers (arrays are
        replaced, never changed in place, so references stay valid)."""
        return self.stick_offset, self.slipped, self.anchored, self._committed_multiplier

    def resume(self, state: tuple) -> None:
        """Return to a :meth:`committed_state`."""
        self.stick_offset, self.slipped, self.anchored, self._committed_multiplier = state
        self.multiplier = self._committed_multiplier

    def penetration(self, response: ContactResponse) -> float:
        """Deepest penetration -g_k of a node in contact, over all ranks [m]."""
        local = np.max(-response.gap[response.in_contact], initial=0.0)
        return self.comm.allreduce(float(local), op=MPI.MAX)

    def augment(self, response: ContactResponse) -> None:
        """Uzawa update of the multipliers: lambda_k <- p_k."""
        self.multiplier = response.pressure.copy()

    def normal_force(self, response: ContactResponse) -> float:
        """F_n = sum p_k a_k over all ranks [N]."""
        return self.comm.allreduce(float(response.pressure.sum()) * self.area, op=MPI.SUM)

    def tangential_force(self, response: ContactResponse) -> float:
        """F_t = sum t_x,k a_k over all ranks: the x force needed to hold the flat [N]."""
        return self.comm.allreduce(float(response.traction[:, 0].sum()) * self.area, op=MPI.SUM)

    def count(self, mask: np.ndarray) -> int:
        """Number of surface nodes over all ranks where ``mask`` holds [-]."""
        return self.comm.allreduce(int(np.count_nonzero(mask)), op=MPI.SUM)

    def gather_grid(self, values: np.ndarray) -> np.ndarray:
        """Per-node values (bool or float) as an N x N grid ([i, j] at x = i h, y = j h), on
        every rank."""
        grid = np.zeros((self.grid_size, self.grid_size), dtype=values.dtype)
        for ij, part in self.comm.allgather((self.grid_index, values)):
            grid[ij[:, 0], ij[:, 1]] = part
        return grid

    def touching_height(self, displacement: np.ndarray, force: float,
                        elastic_modulus: float) -> float:
        """A first guess of the flat height h [m] carrying ``force`` [N] from ``displacement``.

        Every node is a spring k, the penalty eps a in series with the solid under one node,
        taken as a uniformly loaded h x h square on a half-space (mean deflection
        0.95 p h / E', Timoshenko & Goodier), and sum k <Z_k + u_z,k - h> = force is solved
        exactly. (The penalty alone would put the whole load on the highest node, from where
        Newton overshoots into deep penetration: the solid is ~10x softer than the penalty.)

        Parameters
        ----------
        displacement : numpy.ndarray
            Local displacement array [m], shape (num_nodes, 3).
        force : float
            Normal force [N].
        elastic_modulus : float
            E' = E / (1 - nu^2) [Pa].
        """
        tops = np.sort(np.concatenate(self.comm.allgather(
            self.heights + displacement[self.nodes, 2])))[::-1]
        solid = elastic_modulus * np.sqrt(self.area) / 0.95
        stiffness = 1.0 / (1.0 / (self.penalty * self.area) + 1.0 / solid)
        count = np.arange(1, len(tops) + 1)
        # with the m highest nodes in contact: h = (sum of their tops - force / stiffness) / m
        heights = (np.cumsum(tops) - force / stiffness) / count
        below_next = np.append(heights[:-1] >= tops[1:], True)
        return float(heights[np.argmax(below_next)])
