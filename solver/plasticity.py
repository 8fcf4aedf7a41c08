"""J2 (von Mises) plasticity with linear isotropic hardening: radial return, NumPy only.

Small strain. The law acts on the strain deviator only: the pressure K tr(eps) is elastic and
J2 does not depend on it, so the solid's volumetric and deviatoric parts can be integrated with
different quadrature rules without changing the constitutive law.

All arrays are stacks over quadrature points: strains and stresses have shape (m, 3, 3).

The solid sees a law through :class:`MaterialLaw` (the return map of a strain deviator from a
committed history, with the consistent tangent's factors); :class:`J2Plasticity` is this
module's, so that another law is another class.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from roughfriction.material import Material

#: Points with von Mises overstress f > -YIELD_TOLERANCE S_y count as on the yield surface [-].
YIELD_TOLERANCE = 1e-9


@dataclass(frozen=True)
class J2State:
    """Committed history at m quadrature points.

    Attributes
    ----------
    plastic_strain : numpy.ndarray
        Plastic strain (deviatoric) [-], shape (m, 3, 3).
    equivalent_plastic_strain : numpy.ndarray
        Accumulated equivalent plastic strain p = int sqrt(2/3 deps_p : deps_p) [-], shape (m,).
    """

    plastic_strain: np.ndarray
    equivalent_plastic_strain: np.ndarray

    @classmethod
    def virgin(cls, num_points: int) -> J2State:
        """Undeformed material at ``num_points`` points."""
        return cls(np.zeros((num_points, 3, 3)), np.zeros(num_points))


@dataclass(frozen=True)
class PlasticHistory:
    """The J2 history of ``num_points`` quadrature points, held only where the material has
    yielded (p > 0): elsewhere the plastic strain and p are zero.

    Attributes
    ----------
    num_points : int
        Points described.
    points : numpy.ndarray
        The points with p > 0, ascending (int64).
    state : J2State
        The history at ``points``.
    """

    num_points: int
    points: np.ndarray
    state: J2State

    @classmethod
    def virgin(cls, num_points: int) -> PlasticHistory:
        """Undeformed material at ``num_points`` points."""
        return cls(num_points, np.empty(0, dtype=np.int64), J2State.virgin(0))

    @classmethod
    def of_block(cls, num_points: int, first: int, state: J2State) -> PlasticHistory:
        """The yielded points of a dense ``state`` of the points from ``first`` on."""
        yielded = np.flatnonzero(state.equivalent_plastic_strain > 0.0)
        return cls(num_points, first + yielded, J2State(
            state.plastic_strain[yielded], state.equivalent_plastic_strain[yielded]))

    @classmethod
    def concatenate(cls, parts: list[PlasticHistory]) -> PlasticHistory:
        """One history of ``parts`` of the same points, each of other points, in order."""
        return cls(parts[0].num_points, np.concatenate([part.points for part in parts]),
                   J2State(np.concatenate([part.state.plastic_strain for part in parts]),
                           np.concatenate([part.state.equivalent_plastic_strain
                                           for part in parts])))

    def dense(self, first: int = 0, last: int | None = None) -> J2State:
        """The history of points ``first`` up to ``last`` (default: all) as dense arrays."""
        last = self.num_points if last is None else last
        state = J2State.virgin(last - first)
        start, end = np.searchsorted(self.points, [first, last])
        where = self.points[start:end] - first
        state.plastic_strain[where] = self.state.plastic_strain[start:end]
        state.equivalent_plastic_strain[where] = self.state.equivalent_plastic_strain[start:end]
        return state


@dataclass(frozen=True)
class J2Response:
    """Stress, trial history and consistent tangent for one strain state.

    The deviatoric consistent tangent is ``2 G beta P_dev - 2 G gamma n (x) n`` with P_dev the
    deviatoric projector and n the unit flow direction; beta = 1, gamma = 0 where elastic.

    Attributes
    ----------
    stress_deviator : numpy.ndarray
        s [Pa], shape (m, 3, 3).
    state : J2State
        History if this strain is accepted.
    beta : numpy.ndarray
        Tangent factor [-], shape (m,).
    gamma : numpy.ndarray
        Tangent factor [-], shape (m,).
    flow_direction : numpy.ndarray
        Unit deviatoric flow direction n [-], shape (m, 3, 3) (zero where elastic).
    yielding : numpy.ndarray
        Points on the yield surface (plastic tangent), shape (m,), bool.
    """

    stress_deviator: np.ndarray
    state: J2State
    beta: np.ndarray
    gamma: np.ndarray
    flow_direction: np.ndarray
    yielding: np.ndarray


def deviator(tensor: np.ndarray) -> np.ndarray:
    """Deviatoric part of a stack of 3 x 3 tensors, shape (m, 3, 3)."""
    trace = np.trace(tensor, axis1=1, axis2=2)
    return tensor - trace[:, None, None] / 3.0 * np.eye(3)


def von_mises(stress_deviator: np.ndarray) -> np.ndarray:
    """Equivalent stress q = sqrt(3/2 s : s) [Pa] of stress deviators s [Pa], shape (m,)."""
    return np.sqrt(1.5 * np.einsum("mij,mij->m", stress_deviator, stress_deviator))


def radial_return(strain_deviator: np.ndarray, committed: J2State, material: Material,
                  elastic: bool = False) -> J2Response:
    """Deviatoric stress and consistent tangent by the radial return map.

    Parameters
    ----------
    strain_deviator : numpy.ndarray
        Total strain deviator dev(eps) [-], shape (m, 3, 3).
    committed : J2State
        History at the last converged step.
    material : Material
        E, nu, S_y [Pa] and the hardening modulus H = E E_t / (E - E_t) [Pa].
    elastic : bool
        Skip the yield check (linear elastic solid).

    Returns
    -------
    J2Response
    """
    shear = material.shear_modulus
    hardening = material.hardening_modulus
    trial = 2.0 * shear * (strain_deviator - committed.plastic_strain)
    q_trial = von_mises(trial)
    overstress = q_trial - (material.Sy + hardening * committed.equivalent_plastic_strain)
    # On the yield surface (|f| within roundoff, e.g. every plastic point at the start of a step)
    # the elastoplastic tangent is used with dp = 0: deciding by the sign of a roundoff-sized f
    # would make the tangent, and the Newton path, differ between runs and rank counts.
    on_surface = overstress > -YIELD_TOLERANCE * material.Sy
    yielding = np.zeros(len(q_trial), bool) if elastic else on_surface
    increment = np.where(yielding, np.maximum(overstress, 0.0), 0.0) / (3.0 * shear + hardening)
    safe_q = np.where(yielding, q_trial, 1.0)
    shrink = 1.0 - 3.0 * shear * increment / safe_q  # s = shrink * s_trial
    trial_norm = np.sqrt(2.0 / 3.0) * safe_q  # |s_trial|
    direction = np.where(yielding[:, None, None], trial / trial_norm[:, None, None], 0.0)
    state = J2State(
        committed.plastic_strain + (1.5 * increment / safe_q)[:, None, None] * trial,
        committed.equivalent_plastic_strain + increment,
    )
    gamma = np.where(yielding, 3.0 * shear / (3.0 * shear + hardening) - (1.0 - shrink), 0.0)
    return J2Response(shrink[:, None, None] * trial, state, shrink, gamma, direction, yielding)


class MaterialLaw(Protocol):
    """A pointwise law of the solid's stress deviator at its quadrature points (the pressure
    K tr(eps) stays elastic, :mod:`solver.solid`).

    Its response to a strain deviator from the committed history is a :class:`J2Response`:
    the stress deviator s, the trial history, and the consistent tangent
    ds/d dev(eps) = 2 G beta P_dev - 2 G gamma n (x) n, with G the material's shear modulus
    (isotropic laws of a scalar internal variable have this form).
    """

    def return_map(self, strain_deviator: np.ndarray, committed: J2State) -> J2Response:
        """Stress deviator, trial history and tangent factors of the strain deviators
        ``strain_deviator`` [-], shape (m, 3, 3), from the ``committed`` history."""
        ...


@dataclass(frozen=True)
class J2Plasticity:
    """J2 plasticity with linear isotropic hardening by the radial return map
    (:func:`radial_return`); ``elastic``: a linear elastic solid (no yield check)."""

    material: Material
    elastic: bool = False

    def return_map(self, strain_deviator: np.ndarray, committed: J2State) -> J2Response:
        """:func:`radial_return` of ``strain_deviator`` from ``committed``."""
        return radial_return(strain_deviator, committed, self.material, self.elastic)
