"""Progress of an FEM run as records: a run's ``progress`` callable receives one per event
(these, and a :class:`~roughfriction.solver.results.StepRecord` per converged step); ``str()``
of each is its line of text."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

#: What a step cut's technical reason means, by how the reason starts.
PLAIN_REASONS = (
    ("the held flat carries", "the step overshot the normal force it aimed at"),
    ("residual not halved", "Newton stalled while contact points switched between stick and slip"),
    ("penetration", "the flat still penetrates the surface beyond the tolerance"),
    ("iteration limit", "Newton needed more iterations than allowed"),
    ("contact set", "the set of contact points kept changing"),
)


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
        step = "preload" if self.phase == "normal" else "sliding"
        return (f"  {step} step retried at a smaller size: {plain_reason(self.reason)} (Newton "
                f"{self.newton_iterations} its, residual {self.residual:.2e} F_n)")


def plain_reason(reason: str) -> str:
    """A step cut's ``reason`` said in words (:data:`PLAIN_REASONS`), the technical text after
    it; the text alone where no plain wording is known."""
    plain = next((words for start, words in PLAIN_REASONS if reason.startswith(start)), None)
    return f"{plain}: {reason}" if plain else reason


class CountedProgress:
    """A progress printer for one run that numbers its steps and says how far each phase is:
    the preload as the share of F_n reached, the sliding as the contact nodes slipping, with
    the time elapsed and, in the preload, the time left at the pace so far. Lines go to stderr
    on rank 0 of ``comm``.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        The run's communicator.
    target_force : float
        F_n the preload ends at [N].
    clock : callable
        Wall clock [s].
    """

    def __init__(self, comm, target_force: float, clock=time.perf_counter):
        self.comm, self.target, self.clock = comm, target_force, clock
        self.started, self.steps = clock(), 0

    def __call__(self, record) -> None:
        line = str(record)
        if hasattr(record, "slipping_nodes"):  # a StepRecord
            self.steps += 1
            line = f"[step {self.steps} | {self._phase(record)}] {line}"
        if self.comm.rank == 0:
            print(line, file=sys.stderr, flush=True)

    def _phase(self, record) -> str:
        elapsed = self.clock() - self.started
        if record.phase == "normal":
            share = min(record.normal_force / self.target, 1.0)
            left = elapsed * (1.0 - share) / share if share > 0.0 else float("inf")
            return f"preload {100 * share:.0f} % of F_n, {elapsed:.0f} s, ~{left:.0f} s left in it"
        return (f"sliding, {record.slipping_nodes} of {record.contact_nodes} contact nodes "
                f"slip, {elapsed:.0f} s")
