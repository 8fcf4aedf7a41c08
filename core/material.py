"""Material constants, defined once for the theory and the FEM (NumPy only)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from roughfriction.errors import InputError


@dataclass(frozen=True)
class Material:
    """Elastic–plastic metal pressed by a rigid flat (the paper's values are the defaults).

    Parameters
    ----------
    E : float
        Young's modulus [Pa].
    nu : float
        Poisson's ratio [-].
    Sy : float
        Yield strength [Pa].
    Et : float, optional
        Tangent (linear hardening) modulus [Pa]; default 2 % of ``E`` as in the paper.
    tau_c : float, optional
        Critical interfacial shear strength [Pa]; default ``Sy / sqrt(3)`` (von Mises).
    """

    E: float = 200e9
    nu: float = 0.3
    Sy: float = 1e9
    Et: float | None = None
    tau_c: float | None = None

    def __post_init__(self):
        if self.Et is None:
            object.__setattr__(self, "Et", 0.02 * self.E)
        if self.tau_c is None:
            object.__setattr__(self, "tau_c", self.Sy / math.sqrt(3.0))
        if not (self.E > 0 and self.Sy > 0 and self.tau_c > 0 and 0 < self.Et < self.E):
            raise InputError(f"non-physical material {self}")
        if not -1.0 < self.nu < 0.5:
            raise InputError(f"Poisson's ratio must lie in (-1, 0.5), got {self.nu}")

    @property
    def E_star(self) -> float:
        """Effective modulus against a rigid flat, E' = E / (1 - nu^2) [Pa]."""
        return self.E / (1.0 - self.nu**2)

    @property
    def C(self) -> float:
        """Jackson–Green critical yield coefficient C(nu) = 1.295 exp(0.736 nu) [-] (Eq. 13)."""
        return 1.295 * math.exp(0.736 * self.nu)

    @property
    def shear_modulus(self) -> float:
        """G = E / (2 (1 + nu)) [Pa]."""
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def bulk_modulus(self) -> float:
        """K = E / (3 (1 - 2 nu)) [Pa]."""
        return self.E / (3.0 * (1.0 - 2.0 * self.nu))

    @property
    def hardening_modulus(self) -> float:
        """Plastic (isotropic) hardening modulus H = E Et / (E - Et) [Pa]."""
        return self.E * self.Et / (self.E - self.Et)
