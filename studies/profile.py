"""Where an FEM run's time goes: wall time per phase of the Newton loop and the Krylov
iterations of every linear solve, measured by wrapping the solver's methods during one run.

Phases (seconds summed over the run on each rank; the summary gives the largest rank's):

* residual assembly, ``Equilibrium.assemble`` (once per Newton iterate and line-search trial),
  of which the stress update (return map, ``Solid.update_stress``) and the contact law
  (``RigidFlat.respond``);
* reduced tangent, ``Equilibrium.assemble_tangent`` (P^T K P and the contact blocks);
* linear solves, ``LinearSolver.solve``: the two solves of the bordered Newton system,
  K x1 = -R ("x1") and the warm-started K x2 = -b ("x2"), by Krylov method (cg, gmres).

The solver's code is not changed: the wrappers are installed on the classes for the duration of
:func:`measured` and removed after it.
"""

from __future__ import annotations

import importlib
import time
from collections import defaultdict
from contextlib import contextmanager
from dataclasses import dataclass, field

from mpi4py import MPI


@dataclass
class Profile:
    """Seconds and calls per phase, and the Krylov iterations of each linear solve.

    Attributes
    ----------
    seconds : dict
        Phase -> wall time on this rank [s].
    calls : dict
        Phase -> number of calls [-].
    krylov : dict
        "x1 cg", "x2 gmres", ... -> Krylov iterations of each such solve [-].
    """

    seconds: dict = field(default_factory=lambda: defaultdict(float))
    calls: dict = field(default_factory=lambda: defaultdict(int))
    krylov: dict = field(default_factory=lambda: defaultdict(list))

    def summary(self, comm, wall: float) -> dict:
        """The profile of all ranks: per phase the largest rank's seconds [s], its share of
        ``wall`` [-] and the calls; per kind of linear solve the number of solves, their Krylov
        iterations and the largest [-]. Collective."""
        phases = {}
        for phase, *_ in PHASES:
            seconds = comm.allreduce(self.seconds.get(phase, 0.0), op=MPI.MAX)
            phases[phase.strip()] = {"seconds": seconds, "share": seconds / wall,
                                     "calls": self.calls.get(phase, 0)}
        solves = {kind: {"solves": len(its), "krylov_iterations": int(sum(its)),
                         "largest": int(max(its))}
                  for kind, its in sorted(self.krylov.items())}
        return {"wall_s": wall, "phases": phases, "linear_solves": solves}


def _record_krylov(profile: Profile, solver, rhs, solution, warm_start=False, *_, **__):
    """Note the Krylov iterations of a finished ``LinearSolver.solve``: "x2" for the
    warm-started solve of the bordered system, else "x1", and the Krylov method."""
    kind = "x2" if warm_start else "x1"
    profile.krylov[f"{kind} {solver.ksp.getType()}"].append(solver.last_iterations)


def _timed(profile: Profile, phase: str, method, after=None):
    """``method`` timed into ``profile``, then, if it returned, ``after(profile, *args,
    **kwargs)`` (re-entrant calls, e.g. a solve retried from inside itself, counted once)."""
    depth = [0]

    def wrapper(*args, **kwargs):
        depth[0] += 1
        start = time.perf_counter()
        try:
            result = method(*args, **kwargs)
        finally:
            depth[0] -= 1
            if depth[0] == 0:
                profile.seconds[phase] += time.perf_counter() - start
                profile.calls[phase] += 1
        if depth[0] == 0 and after is not None:
            after(profile, *args, **kwargs)
        return result

    return wrapper


#: (phase, module, class, method, what to note after a call) of the timed methods; a phase
#: nested in another is indented.
PHASES = (
    ("residual assembly", "roughfriction.solver.equilibrium", "Equilibrium", "assemble", None),
    ("  stress update", "roughfriction.solver.solid", "Solid", "update_stress", None),
    ("  contact law", "roughfriction.solver.contact", "RigidFlat", "respond", None),
    ("reduced tangent", "roughfriction.solver.equilibrium", "Equilibrium", "assemble_tangent",
     None),
    ("linear solves", "roughfriction.solver.linear", "LinearSolver", "solve", _record_krylov),
)


@contextmanager
def measured(profile: Profile):
    """Time the :data:`PHASES` into ``profile`` while the block runs."""
    originals = []
    try:
        for phase, module, name, method, after in PHASES:
            owner = getattr(importlib.import_module(module), name)
            original = owner.__dict__[method]
            originals.append((owner, method, original))
            setattr(owner, method, _timed(profile, phase, original, after))
        yield profile
    finally:
        for owner, method, original in reversed(originals):
            setattr(owner, method, original)


def profile_run(case, comm, progress=None) -> tuple:
    """Run ``case`` (:func:`solver.run.run`) with its phases timed; return the run and
    :meth:`Profile.summary` (collective)."""
    from roughfriction.solver.run import run

    profile = Profile()
    start = time.perf_counter()
    with measured(profile):
        fem = run(case, comm, progress=progress)
    return fem, profile.summary(comm, time.perf_counter() - start)
