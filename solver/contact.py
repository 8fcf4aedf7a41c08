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
``SurfaceQuadrature.neighbours``. A slipping point below p_r couples its traction to its node's
pressure (dt/dp = tau_c / p_r along the slip): that part is not symmetric
(``ContactResponse.symmetric``), and a Newton solver may leave it out (``Trial.tangent``).

The faces and their points are :mod:`solver.contact_faces`, the quadrature and operators built
once :mod:`solver.contact_quadrature`, the contact state :mod:`solver.contact_state` and the
measures of a response (forces, areas, maps) :mod:`solver.contact_measures`.

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
from functools import cache

import numpy as np
from roughfriction.geometry.adaptive import CellSizes
from roughfriction.solver.contact_law import ContactLaw
from roughfriction.solver.contact_measures import ContactMeasures
from roughfriction.solver.contact_quadrature import SurfaceQuadrature
from roughfriction.solver.contact_state import (
    FRICTIONLESS,
    ContactHistory,
    ContactResponse,
    Tangent,
    Trial,
)
from roughfriction.solver.stages import CONTACT_LAW, stage
from scipy import sparse

__all__ = ["FRICTIONLESS", "ContactHistory", "ContactResponse", "RigidFlat", "Tangent", "Trial"]


class RigidFlat(ContactMeasures):
    """The contact surface against the flat: the contact law at the points of its quadrature
    (:class:`solver.contact_quadrature.SurfaceQuadrature`, built once), its history and the
    Uzawa multipliers; forces, areas and maps of its responses are the methods of
    :class:`solver.contact_measures.ContactMeasures`.

    Each rank evaluates the faces near the surface nodes it owns (``local_faces``): point
    arrays hold those faces' points, node arrays span the N^2 grid nodes and are exact for the
    owned nodes (and their neighbours), zero where no local face is. Integrals, counts and maps
    are over all ranks (collective calls).

    Parameters
    ----------
    comm, nodes, grid_index, cells, heights, spacing, points_per_side
        The surface (:class:`solver.contact_quadrature.SurfaceQuadrature`).
    law : ContactLaw
        Pressure and friction at the points.

    Attributes
    ----------
    surface : SurfaceQuadrature
        Points, operators and gathers of the surface.
    committed : ContactHistory
        The history of the last converged step.
    multiplier : numpy.ndarray
        The current multipliers lambda_a [Pa] (Uzawa updates them within a step).
    """

    def __init__(self, comm, nodes: np.ndarray, grid_index: np.ndarray, cells: CellSizes,
                 heights: np.ndarray, spacing: float, law: ContactLaw, points_per_side: int = 2):
        self.surface = SurfaceQuadrature(comm, nodes, grid_index, cells, heights, spacing,
                                         points_per_side)
        self.law = law
        num_points = len(self.surface.point_weight)
        self.committed = ContactHistory(np.zeros((num_points, 2)),
                                        np.zeros(num_points, dtype=bool),
                                        np.zeros(num_points, dtype=bool),
                                        np.zeros(cells.grid_size**2))
        self.multiplier = self.committed.multiplier

    @property
    def nodes(self) -> np.ndarray:
        """Local indices of the free surface nodes this rank owns, shape (m,)."""
        return self.surface.nodes

    @property
    def owned_grid(self) -> np.ndarray:
        """The grid node i N + j of each owned node, shape (m,)."""
        return self.surface.owned_grid

    @property
    def grid_size(self) -> int:
        """N [-]."""
        return self.surface.grid_size

    # --- the contact law ------------------------------------------------------------------------

    @stage(CONTACT_LAW)
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
        law, history, surface = self.law, self.committed, self.surface
        u = surface.interpolate(surface.gather_nodes(displacement[surface.nodes]))
        gap = flat_height - (surface.heights + u[:, 2])
        node_gap = surface.tributary @ gap
        node_pressure, node_active = law.pressure(self.multiplier, node_gap, trial.active)
        pressure = surface.point_pressure @ node_pressure  # < 0 only under a frozen node
        in_contact = pressure > 0.0
        relative = np.column_stack([flat_slide - u[:, 0], -u[:, 1]])  # w [m]
        frictional = in_contact & trial.friction & history.anchored
        capped = history.slipped if trial.predictor else frictional
        shear = law.friction(relative - history.stick_offset, pressure, frictional, capped)

        stiffness = law.pressure_stiffness(node_active)
        pressure_height = -(surface.point_pressure @ stiffness)  # dp_q/dh
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
            node_force=surface.to_nodes(point_force),
            stiffness=self._stiffness(stiffness, coupling,
                                      lambda: law.slip_tangent(shear, frictional)),
            node_height_derivative=surface.to_nodes(height_derivative),
            coupled=coupled,
            symmetric=not np.any(coupling),
        )

    def _stiffness(self, pressure_stiffness: np.ndarray, coupling: np.ndarray,
                   slip_tangent: Callable[[], np.ndarray]) -> Callable:
        """The contact tangent's node blocks (:attr:`ContactResponse.stiffness`) from the law's
        -dp/dg~ of the nodes [Pa/m], dt/dp of the points [-] and dt/ds of the points [Pa/m]
        (computed on the first call)."""
        surface = self.surface

        @cache
        def pressure_columns() -> tuple:
            # dp_q/du_z,b = eps (W^T/w) (W N), and the shear rows' ramp coupling dt/dp through
            # it (both parts of the tangent need them: computed once)
            pressure_gradient = (surface.point_pressure @ sparse.diags(pressure_stiffness)
                                 @ surface.gap_gradient)
            return pressure_gradient, [-(surface.to_nodes_matrix @ sparse.diags(coupling[:, i])
                                         @ pressure_gradient) for i in range(2)]

        def node_stiffness(coupling_only: bool = False) -> tuple[np.ndarray, np.ndarray]:
            # tangent per unit area [Pa/m] as 3 x 3 component matrices over the grid nodes:
            # shear by the point tangent, pressure and the ramp's coupling by pressure_columns
            # (the coupling alone if ``coupling_only``)
            pressure_gradient, shear_coupling = pressure_columns()
            blocks = np.full((3, 3), None, dtype=object)
            blocks[0, 2], blocks[1, 2] = shear_coupling
            if coupling_only:
                return surface.node_tangent(blocks)
            shear = slip_tangent()
            for i in range(2):
                for j in range(2):
                    blocks[i, j] = (surface.to_nodes_matrix @ sparse.diags(shear[:, i, j])
                                    @ surface.interpolation)
            blocks[2, 2] = surface.to_nodes_matrix @ pressure_gradient
            return surface.node_tangent(blocks)

        return node_stiffness

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
