"""The contact law of the rigid flat at points: pressure from the gap, shear traction from the
slip, and their derivatives (pure NumPy: no mesh, quadrature, ranks or history).

* **Normal**, augmented Lagrangian: p = <lambda - eps_N g> [Pa] at a gap g [m] with the
  multiplier lambda [Pa]; dp/dg = -eps_N where the constraint is active.
* **Friction**, a return map under the maximum shear stress criterion (the paper's tau_c): the
  trial traction t* = eps_T s for the slip s = w - w_s from the stick point [m] sticks if
  |t*| <= c, else slips with t = c t*/|t*|, under the cap c = tau_c min(1, p / p_r) (continuous
  in p: a point at a patch edge has a consistent state). Tangents: dt/ds = eps_T I (stick),
  eps_T c/|t*| (I - n n^T) (slip, n = t*/|t*|), and dt/dp = (dc/dp) n = tau_c / p_r n for a
  slipping point below p_r (the non-symmetric part of the contact tangent).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Friction:
    """The friction law's state at points (shape (P,) or (P, 2)).

    Attributes
    ----------
    traction : numpy.ndarray
        t [Pa], (P, 2); zero where the point carries no shear.
    slipping : numpy.ndarray
        At the cap (bool).
    direction : numpy.ndarray
        n = t*/|t*| (the trial's direction; t* where |t*| = 0) [-], (P, 2).
    scale : numpy.ndarray
        t = scale t*: c/|t*| slipping, else 1 [-].
    """

    traction: np.ndarray
    slipping: np.ndarray
    direction: np.ndarray
    scale: np.ndarray


@dataclass(frozen=True)
class ContactLaw:
    """Pressure and shear traction of the flat at points, with their tangents.

    Attributes
    ----------
    penalty : float
        eps_N [Pa/m].
    tangential_penalty : float
        Stick penalty eps_T [Pa/m].
    shear_strength : float
        tau_c [Pa].
    ramp_pressure : float
        p_r: the cap is tau_c min(1, p / p_r) [Pa]; 0 for the pure cap tau_c.
    """

    penalty: float
    tangential_penalty: float
    shear_strength: float
    ramp_pressure: float

    def pressure(self, multiplier: np.ndarray, gap: np.ndarray,
                 frozen: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """p = <lambda - eps_N g> [Pa] and the active set (bool) at the multipliers lambda
        [Pa] and gaps g [m]; ``frozen`` points stay active, carrying lambda - eps_N g even if
        it is negative."""
        trial = multiplier - self.penalty * gap
        active = trial > 0.0
        if frozen is not None:
            active |= frozen
        return np.where(active, trial, 0.0), active

    def pressure_stiffness(self, active: np.ndarray) -> np.ndarray:
        """-dp/dg [Pa/m]: eps_N where active, else 0."""
        return self.penalty * active

    def shear_cap(self, pressure: np.ndarray) -> np.ndarray:
        """c = tau_c min(1, p / p_r) [Pa] (tau_c if p_r = 0) at the pressures p [Pa]."""
        if self.ramp_pressure == 0.0:
            return np.full_like(pressure, self.shear_strength)
        return self.shear_strength * np.clip(pressure / self.ramp_pressure, 0.0, 1.0)

    def cap_slope(self, pressure: np.ndarray, slipping: np.ndarray) -> np.ndarray:
        """dc/dp of slipping points [-]: tau_c / p_r where 0 < p < p_r, else 0."""
        if self.ramp_pressure == 0.0:
            return np.zeros_like(pressure)
        ramping = slipping & (pressure > 0.0) & (pressure < self.ramp_pressure)
        return np.where(ramping, self.shear_strength / self.ramp_pressure, 0.0)

    def friction(self, slip: np.ndarray, pressure: np.ndarray, frictional: np.ndarray,
                 capped: np.ndarray) -> Friction:
        """The return map at the slips s = w - w_s [m], (P, 2), and pressures p [Pa]: points
        where ``frictional`` (bool) carry shear, and those also ``capped`` (bool) are held to the
        cap (the others stick whatever their trial, e.g. under a predictor)."""
        trial = self.tangential_penalty * slip
        trial_norm = np.linalg.norm(trial, axis=1)
        cap = self.shear_cap(pressure)
        slipping = frictional & capped & (trial_norm > cap)
        scale = np.where(slipping, cap / np.where(slipping, trial_norm, 1.0), 1.0)
        traction = np.where(frictional[:, None], scale[:, None] * trial, 0.0)
        direction = trial / np.where(trial_norm > 0.0, trial_norm, 1.0)[:, None]
        return Friction(traction, slipping, direction, scale)

    def slip_tangent(self, friction: Friction, frictional: np.ndarray) -> np.ndarray:
        """dt/ds [Pa/m], (P, 2, 2), of :meth:`friction`'s state (``frictional`` as passed to it):
        eps_T I sticking, eps_T c/|t*| (I - n n^T) slipping, 0 without shear."""
        projection = np.eye(2) - np.where(friction.slipping, 1.0, 0.0)[:, None, None] * np.einsum(
            "ni,nj->nij", friction.direction, friction.direction)
        stiffness = np.where(frictional, self.tangential_penalty * friction.scale, 0.0)
        return stiffness[:, None, None] * projection

    def pressure_coupling(self, friction: Friction, pressure: np.ndarray) -> np.ndarray:
        """dt/dp [-], (P, 2): (dc/dp) n for a slipping point below p_r, else 0."""
        return self.cap_slope(pressure, friction.slipping)[:, None] * friction.direction
