"""Where an FEM run's time goes: wall time per phase of the Newton loop and the Krylov
iterations of every linear solve, read from the stages the solver runs its work in
(:mod:`solver.stages`) during one run.

Phases (seconds summed over the run on each rank; the summary gives the largest rank's):

* residual assembly, ``ReducedSystem.assemble`` (once per Newton iterate and line-search
  trial), of which the stress update (return map, ``Solid.update_stress``) and the contact law
  (``RigidFlat.respond``);
* reduced tangent, ``ReducedSystem.assemble_tangent`` (P^T K P and the contact blocks);
* linear solves, ``LinearSolver.solve``: the two solves of the bordered Newton system,
  K x1 = -R ("x1") and the warm-started K x2 = -b ("x2"), by Krylov method (cg, gmres), from
  the solver's record of its solves (``LinearSolver.krylov_solves``).

The seconds and calls of a phase are the change of its stage's dolfinx timer over the run; the
memory after each set-up stage is noted by a listener of the stages' ends
(``solver.stages.listening``). The solver's code is not wrapped or replaced.
"""

from __future__ import annotations

import time
from collections import defaultdict
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc
from roughfriction.solver import stages


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
        for phase, _ in PHASES:
            seconds = comm.allreduce(self.seconds.get(phase, 0.0), op=MPI.MAX)
            phases[phase.strip()] = {"seconds": seconds, "share": seconds / wall,
                                     "calls": self.calls.get(phase, 0)}
        solves = {kind: {"solves": len(its), "krylov_iterations": int(sum(its)),
                         "largest": int(max(its))}
                  for kind, its in sorted(self.krylov.items())}
        return {"wall_s": wall, "phases": phases, "linear_solves": solves}

    def note_krylov(self, solves) -> None:
        """Add the Krylov iterations of finished linear solves
        (:class:`solver.linear.KrylovSolve`): "x2" for the warm-started solve of the bordered
        system, else "x1", and the Krylov method."""
        for solve in solves:
            kind = "x2" if solve.warm_start else "x1"
            self.krylov[f"{kind} {solve.krylov}"].append(solve.iterations)


#: (phase, the solver's stage it times) of the profile; a phase nested in another is indented.
PHASES = (
    ("residual assembly", stages.RESIDUAL),
    ("  stress update", stages.STRESS_UPDATE),
    ("  contact law", stages.CONTACT_LAW),
    ("reduced tangent", stages.TANGENT),
    ("linear solves", stages.LINEAR_SOLVE),
)


@contextmanager
def measured(profile: Profile):
    """Add the seconds and calls of the :data:`PHASES` while the block runs to ``profile``:
    the change of their stages' dolfinx timers."""
    before = {name: stages.stage_timing(name) for _, name in PHASES}
    try:
        yield profile
    finally:
        for phase, name in PHASES:
            calls, seconds = stages.stage_timing(name)
            profile.calls[phase] += calls - before[name][0]
            profile.seconds[phase] += seconds - before[name][1]


def profile_run(case, comm, progress=None) -> tuple:
    """Run ``case`` (:func:`solver.run.run`) with its phases timed and its memory noted;
    return the run and :meth:`Profile.summary` with its ``memory`` (:func:`memory_summary`)
    (collective)."""
    from roughfriction.solver.run import run

    profile, marks = Profile(), MemoryMarks()
    start = time.perf_counter()
    with measured(profile), stages.listening(marks.note):
        fem = run(case, comm, progress=progress)
    wall = time.perf_counter() - start
    profile.note_krylov(fem.equilibrium.linear_solver.krylov_solves)
    summary = profile.summary(comm, wall)
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
    info = matrix.getInfo(PETSc.Mat.InfoType.LOCAL)  # petsc4py's default sums the ranks
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


#: (phase, the solver's stage after whose first end memory is noted), in run order.
MARKS = (
    ("mesh", stages.MESH),
    ("forms and spaces", stages.SOLID_SETUP),
    ("reduction P", stages.REDUCTION),
    ("system set-up", stages.SYSTEM_SETUP),
    ("reduced elastic K", stages.ELASTIC_TANGENT),
    ("first tangent", stages.TANGENT),
    ("preconditioner and first solve", stages.KRYLOV_SOLVE),
)


#: A rise of this rank's peak memory is noted when it exceeds the last noted peak by this
#: share [-].
RISE_SHARE = 0.02


@dataclass
class MemoryMarks:
    """Resident memory of this rank after the first end of each stage of :data:`MARKS`, and
    where its peak rose during the run.

    Attributes
    ----------
    marks : dict
        Phase -> (VmRSS, VmHWM) [kB] just after its stage first ended.
    rises : list
        (stage, its outermost call [-], VmHWM [kB]) at each stage end that found the peak
        :data:`RISE_SHARE` above the last one noted: when in the run the peak grew.
    """

    marks: dict = field(default_factory=dict)
    rises: list = field(default_factory=list)
    _ends: dict = field(default_factory=lambda: defaultdict(int))

    def note(self, stage: str) -> None:
        """Record the resident and peak memory after ``stage`` (a listener of
        :func:`solver.stages.listening`) if it is a marked stage's first end, and the peak if
        it rose."""
        self._ends[stage] += 1
        peak = _status_kb("VmHWM")
        phase = _MARKED.get(stage)
        if phase is not None and phase not in self.marks:
            self.marks[phase] = (_status_kb("VmRSS"), peak)
        last = self.rises[-1][2] if self.rises else 0
        if peak > (1.0 + RISE_SHARE) * last:
            self.rises.append((stage, self._ends[stage], peak))


#: Stage -> its phase in :data:`MARKS`.
_MARKED = {name: phase for phase, name in MARKS}


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
    rises = [{"stage": stage, "call": call, "peak_gb": hwm / 2**20}
             for stage, call, hwm in marks.rises]
    return {"peak_gb": peak / 2**20, "peak_kb_per_dof": peak * 1.024 / reduced_dofs,
            "reduced_dofs": reduced_dofs, "phases": phases, "objects": by_object,
            "peak_rises_by_rank": comm.allgather(rises)}
