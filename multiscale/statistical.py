"""Statistical static-friction models the paper compares with: CKE (Eq. 8) and LET (Eq. 20).

Both are fits of Greenwood–Williamson-type models and hold only in the range they were fitted
over. The value is always computed; ``valid`` and ``reason`` say whether (ψ, F*) lies in the
published range, and the caller decides how to show a point outside it.

Ranges, in the paper's words:

* CKE: "the theoretical equation for static friction in Cohen et al. [10] is not valid for
  plasticity indices above 8" (Sect. 1).
* LET: "The empirical expressions of plasticity values in the range of 0 < ψ ≤ 32, were
  derived [11]" (Sect. 1).
* Both: "most existing friction models [10, 11] have limitations on the range of normal load
  and plasticity: F_n/(A_n S_y) ≤ 0.3 and Ψ ≤ 30" (Sect. 6); LET at F* = 0.62 "is outside of
  its applicable range" (Sect. 5.3.1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from roughfriction.errors import InputError

CKE_MAX_PSI = 8.0  # Sect. 1
LET_MAX_PSI = 32.0  # Sect. 1
MAX_LOAD_STAR = 0.3  # Sect. 6


@dataclass(frozen=True)
class StatisticalFriction:
    """Static friction coefficient of a statistical model and whether it is in its range.

    Attributes
    ----------
    mu_s : float
        Static friction coefficient [-] (computed even outside the range).
    valid : bool
        Whether (ψ, F*) lies in the model's published range.
    reason : str
        Why not, in one line ("" when valid).
    """

    mu_s: float
    valid: bool
    reason: str


def _check_inputs(psi, load_star) -> None:
    """Raise InputError unless ψ and F* are finite and > 0."""
    if not (math.isfinite(psi) and psi > 0):
        raise InputError(f"plasticity index psi must be a finite number > 0, got {psi}")
    if not (math.isfinite(load_star) and load_star > 0):
        raise InputError(f"dimensionless load F* must be a finite number > 0, got {load_star}")


def _range_reason(model, psi, max_psi, load_star) -> str:
    """One line saying which of ψ ≤ max_psi and F* ≤ 0.3 fails ("" if neither)."""
    failures = []
    if psi > max_psi:
        failures.append(f"psi = {psi:.4g} > {max_psi:g}")
    if load_star > MAX_LOAD_STAR:
        failures.append(f"F* = {load_star:.4g} > {MAX_LOAD_STAR:g}")
    if not failures:
        return ""
    return f"{model} is outside its published range: " + " and ".join(failures)


def cke_friction(psi, load_star) -> StatisticalFriction:
    """Cohen–Kligerman–Etsion (2008) static friction, full stick (Eq. 8).

    Parameters
    ----------
    psi : float
        Plasticity index ψ [-] (Eq. 11).
    load_star : float
        F* = F_n / (A_n S_y) [-] (Eq. 10).

    Returns
    -------
    StatisticalFriction
        μ_s = (0.26 + 0.43/ψ) F*^(0.0095ψ − 0.09); valid for ψ ≤ 8 and F* ≤ 0.3.
    """
    _check_inputs(psi, load_star)
    mu_s = (0.26 + 0.43 / psi) * load_star ** (0.0095 * psi - 0.09)  # Eq. 8
    reason = _range_reason("CKE (Eq. 8)", psi, CKE_MAX_PSI, load_star)
    return StatisticalFriction(mu_s=mu_s, valid=not reason, reason=reason)


def let_friction(psi, load_star) -> StatisticalFriction:
    """Li–Etsion–Talke (2010) static friction (Eq. 20).

    Parameters
    ----------
    psi : float
        Plasticity index ψ [-] (Eq. 11).
    load_star : float
        F* = F_n / (A_n S_y) [-] (Eq. 10).

    Returns
    -------
    StatisticalFriction
        μ_s = [0.26 + 0.32 exp(−0.34 ψ^1.19)] F*^(−exp(−1.9 ψ^0.4)); valid for 0 < ψ ≤ 32 and
        F* ≤ 0.3.
    """
    _check_inputs(psi, load_star)
    prefactor = 0.26 + 0.32 * math.exp(-0.34 * psi**1.19)
    mu_s = prefactor * load_star ** (-math.exp(-1.9 * psi**0.4))  # Eq. 20
    reason = _range_reason("LET (Eq. 20)", psi, LET_MAX_PSI, load_star)
    return StatisticalFriction(mu_s=mu_s, valid=not reason, reason=reason)
