"""Progress of an FEM run as records: a run's ``progress`` callable receives one per event
(these, and a :class:`~roughfriction.solver.results.StepRecord` per converged step); ``str()``
of each is its line of text."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class RunStarted:
    """The block is meshed and the solver set up."""

    surface: str
    n: int  # surface cells per side [-]
    cells: int  # hexahedra [-]
    layers: int  # cell layers [-]
    reduced_dofs: int  # unknowns after periodic reduction [-]
    linear_solver: str  # "direct" or "iterative"
    ranks: int

    def __str__(self) -> str:
        return (f"FEM {self.surface}: N={self.n}, {self.cells} hexahedra in {self.layers} "
                f"layers, {self.reduced_dofs} dofs, {self.linear_solver} solver, "
                f"{self.ranks} rank(s)")


@dataclass(frozen=True)
class LoadStarted:
    """The next load of a multi-load run starts (F* [-])."""

    load_star: float

    def __str__(self) -> str:
        return f"load F* = {self.load_star:g}"


@dataclass(frozen=True)
class StepCut:
    """A load step failed and is retried smaller from the last converged state.

    ``reason`` says why (Newton residual stagnating, contact-set cycling, the Krylov solver's
    converged reason, penetration left after the multiplier updates, the iteration limit).
    """

    phase: str  # "normal" or "tangential"
    newton_iterations: int
    residual: float  # ||R|| / F_n at the last iterate [-]
    reason: str

    def __str__(self) -> str:
        return (f"  {self.phase} step cut (Newton {self.newton_iterations} its, residual "
                f"{self.residual:.2e} F_n): {self.reason}")
