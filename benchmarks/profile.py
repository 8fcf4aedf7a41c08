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
from pathlib import Path

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc


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
    """Run ``case`` (:func:`solver.run.run`) with its phases timed and its memory noted;
    return the run and :meth:`Profile.summary` with its ``memory`` (:func:`memory_summary`)
    (collective)."""
    from roughfriction.solver.run import run

    profile, marks = Profile(), MemoryMarks()
    start = time.perf_counter()
    with measured(profile), memory_marked(marks):
        fem = run(case, comm, progress=progress)
    summary = profile.summary(comm, time.perf_counter() - start)
    surface_nodes = fem.equilibrium.flat.grid_size ** 2
    summary["memory"] = memory_summary(comm, marks, memory_objects(fem.equilibrium),
                                       fem.result.sizes["reduced_dofs"], surface_nodes)
    return fem, summary


# --- memory -----------------------------------------------------------------------------------

#: Bytes of one stored nonzero of an AIJ matrix: the value (double) and its column (int32) [B].
NONZERO_BYTES = 12


def _status_kb(field_name: str) -> int:
    """A field of /proc/self/status (VmRSS, VmHWM) [kB]; 0 where it cannot be read."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(field_name + ":"):
                return int(line.split()[1])
    except OSError:
        pass
    return 0


def matrix_bytes(matrix) -> int:
    """Bytes of a PETSc AIJ matrix's values and column indices on this rank (allocated
    nonzeros times :data:`NONZERO_BYTES`, plus the row pointers) [B]; 0 for None."""
    if matrix is None:
        return 0
    info = matrix.getInfo()
    rows = matrix.getLocalSize()[0]
    return int(info["nz_allocated"]) * NONZERO_BYTES + 8 * (rows + 1)


def _arrays_bytes(*items) -> int:
    """Bytes of the numpy arrays among ``items`` and the attributes of the dataclasses and
    SciPy sparse matrices among them (one level deep) [B]."""
    total = 0
    for item in items:
        if isinstance(item, np.ndarray):
            total += item.nbytes
        elif hasattr(item, "data") and hasattr(item, "indices"):  # scipy.sparse CSR/CSC
            total += item.data.nbytes + item.indices.nbytes + item.indptr.nbytes
        elif hasattr(item, "__dataclass_fields__"):
            total += _arrays_bytes(*vars(item).values())
    return total


def _preconditioner_bytes(solver) -> int:
    """Bytes of the linear solver's preconditioner on this rank [B]: GAMG's coarse operators
    and interpolations (the finest operator is the system's own), or MUMPS's factors (its
    INFO(16), the working memory it allocated)."""
    pc = solver.ksp.getPC()
    kind = pc.getType()
    if kind == "gamg":
        try:
            levels = pc.getMGLevels()
        except PETSc.Error:  # not set up
            return 0
        total = 0
        for level in range(levels - 1):  # the finest level (levels - 1) is the operator
            total += matrix_bytes(pc.getMGSmoother(level).getOperators()[0])
        for level in range(1, levels):
            total += matrix_bytes(pc.getMGInterpolation(level))
        return total
    if kind in ("cholesky", "lu"):
        try:
            return int(pc.getFactorMatrix().getMumpsInfo(16)) * 2**20  # MB -> B
        except PETSc.Error:
            return 0
    return 0


def memory_objects(equilibrium) -> dict:
    """Bytes held on this rank by each object of an FEM model [B], by name: the matrices of
    :class:`solver.reduced_system.ReducedSystem` (allocated nonzeros), the reduction P, the
    preconditioner, the reduced vectors, the solid's quadrature state and the surface arrays
    of the contact."""
    system, solid, flat = equilibrium.system, equilibrium.solid, equilibrium.flat
    objects = {name: matrix_bytes(getattr(system, attribute, None))
               for name, attribute in MATRICES}
    objects["reduction P"] = matrix_bytes(equilibrium.reduction.P)
    objects["preconditioner"] = _preconditioner_bytes(system.linear_solver)
    vector = 8 * system.residual.getLocalSize()
    objects["reduced vectors"] = vector * (5 + 3)  # R, b, c, x1, x2; u_red, committed, previous
    quadrature = (solid.stress_deviator, solid.flow_direction, solid.beta, solid.gamma,
                  solid.yielded)
    objects["quadrature functions"] = sum(f.x.array.nbytes for f in quadrature)
    objects["quadrature state"] = _arrays_bytes(solid.trial_state, solid.yielding,
                                                solid.committed)
    objects["displacement field"] = solid.displacement.x.array.nbytes
    objects["contact surface arrays"] = _arrays_bytes(*vars(flat).values())
    return objects


#: (name in the breakdown, attribute of ReducedSystem) of the matrices it may hold.
MATRICES = (
    ("reduced tangent", "tangent"),
    ("contact coupling", "_coupling"),
)


@dataclass
class MemoryMarks:
    """Resident memory of this rank after the first call of each phase of :data:`MARKS`.

    Attributes
    ----------
    marks : dict
        Phase -> (VmRSS, VmHWM) [kB] just after its first call ended.
    """

    marks: dict = field(default_factory=dict)

    def note(self, phase: str) -> None:
        """Record the resident and peak memory after ``phase`` if it is its first call."""
        if phase not in self.marks:
            self.marks[phase] = (_status_kb("VmRSS"), _status_kb("VmHWM"))


#: (phase, module, class or None, function) after whose first call memory is noted, in run
#: order.
MARKS = (
    ("mesh", "roughfriction.solver.run", None, "build_block"),
    ("forms and spaces", "roughfriction.solver.solid", "Solid", "__init__"),
    ("reduction P", "roughfriction.solver.periodic", "PeriodicReduction", "__init__"),
    ("system set-up", "roughfriction.solver.reduced_system", "ReducedSystem", "__init__"),
    ("reduced elastic K", "roughfriction.solver.reduced_system", "ReducedSystem",
     "_create_tangent"),
    ("first tangent", "roughfriction.solver.reduced_system", "ReducedSystem",
     "assemble_tangent"),
    ("preconditioner and first solve", "roughfriction.solver.linear", "LinearSolver", "_apply"),
)


def _noting(marks: MemoryMarks, phase: str, function):
    """``function``, noting memory into ``marks`` after it returns."""
    def wrapper(*args, **kwargs):
        result = function(*args, **kwargs)
        marks.note(phase)
        return result
    return wrapper


@contextmanager
def memory_marked(marks: MemoryMarks):
    """Note memory after the first call of each of the :data:`MARKS` while the block runs."""
    originals = []
    try:
        for phase, module, name, function in MARKS:
            owner = importlib.import_module(module)
            owner = getattr(owner, name) if name else owner
            original = owner.__dict__[function]
            originals.append((owner, function, original))
            setattr(owner, function, _noting(marks, phase, original))
        yield marks
    finally:
        for owner, function, original in reversed(originals):
            setattr(owner, function, original)


def memory_summary(comm, marks: MemoryMarks, objects: dict, reduced_dofs: int,
                   surface_nodes: int) -> dict:
    """Memory of all ranks (collective): per phase the summed resident and peak memory [GB]
    and the peak per reduced dof [kB]; per object its bytes summed over the ranks per reduced
    dof and per surface node [kB]; the final peak (VmHWM) summed over the ranks [GB]."""
    def total(value):
        return comm.allreduce(value, op=MPI.SUM)

    phases = {}
    for phase, *_ in MARKS:
        rss, hwm = marks.marks.get(phase, (0, 0))
        phases[phase] = {"rss_gb": total(rss) / 2**20, "peak_gb": total(hwm) / 2**20,
                         "peak_kb_per_dof": total(hwm) * 1.024 / reduced_dofs}
    by_object = {name: {"gb": total(size) / 2**30,
                        "kb_per_dof": total(size) / 1e3 / reduced_dofs,
                        "kb_per_surface_node": total(size) / 1e3 / surface_nodes}
                 for name, size in objects.items()}
    peak = total(_status_kb("VmHWM"))
    return {"peak_gb": peak / 2**20, "peak_kb_per_dof": peak * 1.024 / reduced_dofs,
            "reduced_dofs": reduced_dofs, "phases": phases, "objects": by_object}
