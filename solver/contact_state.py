"""The state of the contact (:mod:`solver.contact`): how a trial is evaluated (:class:`Trial`),
the response of the surface to it (:class:`ContactResponse`: gaps, pressures, tractions, nodal
forces and tangent) and what a converged step leaves behind (:class:`ContactHistory`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from functools import cached_property

import numpy as np


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

    Point arrays hold the points of the rank's faces (P, face-major:
    ``SurfaceQuadrature.face_ids``); node arrays are indexed by the surface grid node i N + j,
    exact for the nodes it owns.

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
        dR_a/du_b [N/m] for their neighbours b (``SurfaceQuadrature.neighbours_of``: on the
        uniform grid the 25 of ``NEIGHBOURS``, a neighbour met twice on a grid smaller than 5
        holding its block once), shape (m, width, 3, 3)."""
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
