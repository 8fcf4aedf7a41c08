"""One FEM run, read top to bottom like the paper's procedure:
mesh the block -> set up solid, periodicity and contact -> preload to F_n -> slide the flat until
every contact node slips -> report."""

from __future__ import annotations

import resource
import sys
import time
from collections.abc import Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from mpi4py import MPI
from roughfriction.case import FemCase, Loading
from roughfriction.geometry.mesh import Block, blend_layers_needed
from roughfriction.solver.block import build_block
from roughfriction.solver.contact import ContactResponse, RigidFlat
from roughfriction.solver.contact_law import ContactLaw
from roughfriction.solver.equilibrium import Equilibrium
from roughfriction.solver.fields import FieldWriter
from roughfriction.solver.memory import check_memory
from roughfriction.solver.periodic import PeriodicReduction, dof_node_grid_index
from roughfriction.solver.progress import LoadStarted, RunStarted
from roughfriction.solver.results import FemResult, near_flat_nodes
from roughfriction.solver.solid import Solid
from roughfriction.solver.stages import MESH, stage
from roughfriction.solver.stepping import LoadPath, Outcome


@dataclass(frozen=True, eq=False)
class FemRun:
    """A finished run and the objects behind it (for field output and tests).

    Attributes
    ----------
    result : FemResult
        Records and summary.
    maps : dict
        N x N surface maps ([i, j] at x = i h, y = j h; :meth:`RigidFlat.node_maps`) at the end
        of the preload: "contact_normal" (bool nodes), "pressure_normal" [Pa] and
        "contact_fraction_normal" (per face) [-]; and, when reached, at inception the same
        with "_sliding" plus "slip_sliding" (bool) and "shear_x_sliding" [Pa].
    equilibrium : Equilibrium
        Final state (solid, flat, reduced displacement).
    block : Block
        The mesh.
    """

    result: FemResult
    maps: dict
    equilibrium: Equilibrium
    block: Block


def peak_memory_gb() -> float:
    """Peak resident memory of this process so far [GB]: ``VmHWM`` of /proc/self/status (Linux;
    ``ru_maxrss`` counts a parent's peak at fork too), else ``ru_maxrss`` [KiB]."""
    try:
        status = Path("/proc/self/status").read_text()
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    kib = next(line.split()[1] for line in status.splitlines() if line.startswith("VmHWM:"))
    return int(kib) / 2**20


def near_flat(case: FemCase, fem_run: FemRun) -> np.ndarray:
    """Where a mesh of ``case`` twice as fine may touch besides the run's contact, on the
    run's finest grid (bool): ``solver.results.near_flat_nodes`` at the flat's lowest position
    in the run."""
    lowest = min(record.flat_height for record in fem_run.result.records)
    return near_flat_nodes(fem_run.maps, case.surface.heights, lowest, case.mesh.refinement)


def stderr_progress(comm):
    """A progress printer: each record as its line of text on stderr, from rank 0 only."""
    def progress(record) -> None:
        if comm.rank == 0:
            print(record, file=sys.stderr, flush=True)
    return progress


def with_blend_layers_needed(case: FemCase, progress) -> FemCase:
    """The case with at least the blend layers its surface's deepest valley needs
    (:func:`geometry.mesh.blend_layers_needed`; the case's own count if that is more). A raised
    count is stated through ``progress`` as a line of text."""
    heights, spacing = case.surface.heights, case.surface.spacing
    needed = blend_layers_needed(heights, spacing)
    if needed <= case.mesh.blend_layers:
        return case
    valley = float(heights.mean() - heights.min())
    progress(f"note: {needed} blend layers instead of {case.mesh.blend_layers}: the deepest "
             f"valley, {valley:.3g} m ({valley / spacing:.3g} grid spacings) below the mean "
             "plane, would invert cells under fewer")
    return replace(case, mesh=replace(case.mesh, blend_layers=needed))


def surface_contact(solid: Solid, block: Block, case: FemCase, reduction: PeriodicReduction
                    ) -> RigidFlat:
    """The rigid flat acting on the top faces of the block (of varying width where the block
    is refined), with the free surface nodes whose reduced dofs this rank owns (one per grid
    point: periodic images and hanging nodes have no dofs of their own); its penalty is set on
    the finest spacing h / 2^L, the faces' in the refined zone."""
    V = solid.V
    grid = dof_node_grid_index(V, block)
    masters = reduction.master_node
    on_surface = masters[grid[masters, 2] == block.num_layers]
    heights = V.tabulate_dof_coordinates()[on_surface, 2]
    material, spacing = case.material, block.spacing
    penalty = case.solver.penalty * material.E_star / spacing
    law = ContactLaw(penalty=penalty,
                     tangential_penalty=case.solver.tangential_penalty * penalty,
                     shear_strength=material.tau_c,
                     ramp_pressure=case.solver.friction_ramp * material.Sy)
    return RigidFlat(block.mesh.comm, on_surface, grid[on_surface, :2], block.cells, heights,
                     spacing, law, points_per_side=case.solver.contact_points)


def contact_maps(flat: RigidFlat, contact: ContactResponse, phase: str) -> dict:
    """The surface maps of a contact state, keyed ``<map>_<phase>`` (see ``FemRun.maps``)."""
    maps = flat.node_maps(contact)
    names = ("contact", "pressure", "contact_fraction", "gap") + (
        ("slip", "shear_x") if phase == "sliding" else ())
    return {f"{name}_{phase}": maps[name] for name in names}


def run(case: FemCase, comm: MPI.Comm = MPI.COMM_WORLD, progress=None,
        xdmf_directory=None) -> FemRun:
    """Preload and (unless normal-only) slide to inception.

    Parameters
    ----------
    case : FemCase
        What to compute.
    comm : mpi4py.MPI.Comm
        Communicator.
    progress : callable, optional
        Receives the run's progress records (:mod:`roughfriction.solver.progress`, a
        ``StepRecord`` per step; ``str()`` gives the line); default: stderr on rank 0.
    xdmf_directory : str or pathlib.Path, optional
        Write fields (end of preload, inception) to ``fields.xdmf`` there.

    Returns
    -------
    FemRun
    """
    runs = run_loads(case, [case.loading.load_star], comm, progress,
                     xdmf_directory and Path(xdmf_directory))
    return runs[0]


def run_loads(case: FemCase, loads: Sequence[float], comm: MPI.Comm = MPI.COMM_WORLD,
              progress=None, xdmf_directory=None, finished=None) -> list[FemRun]:
    """The case at several normal loads, sharing one normal loading path.

    The loads are taken in increasing order: the preload goes up to the smallest, the sliding
    branches from there, the state returns to the end of that preload, the preload continues to
    the next load, and so on. Each run's records are its own path (preload steps up to its load,
    then its sliding). A run reached through a shared path differs from a standalone one only
    by where the preload steps fall (path dependence of plasticity at step level; measured in
    ``tests/test_solver_verification.py``). If the preload fails at one load, it and every
    larger load are reported unconverged with the reason.

    Parameters
    ----------
    case : FemCase
        Surface, material, mesh, solver options and ``normal_only``; its load is ignored. The
        mesh takes at least the blend layers the surface needs (:func:`with_blend_layers_needed`,
        recorded as ``sizes["blend_layers"]``).
    loads : sequence of float
        Dimensionless normal loads F* [-].
    comm : mpi4py.MPI.Comm
        Communicator; every rank takes part.
    progress : callable, optional
        Receives the run's progress records (:mod:`roughfriction.solver.progress`, a
        ``StepRecord`` per step; ``str()`` gives the line); default: stderr on rank 0.
    xdmf_directory : str or pathlib.Path, optional
        Fields of a single load go to ``DIRECTORY/fields.xdmf``; of several loads to
        ``DIRECTORY/F<F*>/fields.xdmf``.
    finished : callable, optional
        Called on every rank as ``finished(index, fem_run)`` as soon as the run of
        ``loads[index]`` is done (so that a caller can save it before the next one starts).

    Returns
    -------
    list of FemRun
        One per load, in the order of ``loads``. They share the model (``equilibrium``,
        ``block``), which is left in the state of the last load computed.
    """
    progress = progress or stderr_progress(comm)
    clock = StageClock()
    case = with_blend_layers_needed(case, progress)
    model = build_model(case, comm)
    progress(model.run_started(case.surface.name))
    clock.setup_done()
    fields = LoadFields(xdmf_directory, len(loads) > 1, model.block, model.solid, model.flat)
    path = LoadPath(model.equilibrium, case, model.block.depth, progress)
    preload = Outcome(True)
    runs: list[FemRun | None] = [None] * len(loads)
    order = sorted(range(len(loads)), key=lambda k: loads[k])
    for position, index in enumerate(order):
        if len(loads) > 1:
            progress(LoadStarted(loads[index]))
        load_case = replace(case, loading=Loading(loads[index], case.loading.normal_only))
        preload, runs[index], branch = run_load(path, model, load_case, preload, clock, fields)
        if finished is not None:
            finished(index, runs[index])
        if position < len(order) - 1:
            path.return_to(branch)
    return runs


@dataclass(frozen=True, eq=False)
class Model:
    """The discrete problem of a case: the mesh, the solid, u = P u_red, the flat, the
    equilibrium over them and the sizes of the run (``FemResult.sizes``)."""

    block: Block
    solid: Solid
    reduction: PeriodicReduction
    flat: RigidFlat
    equilibrium: Equilibrium
    sizes: dict

    def run_started(self, name: str) -> RunStarted:
        """The progress record of the start of a run on this model of the surface ``name``."""
        block, sizes = self.block, self.sizes
        return RunStarted(name or "surface", block.n, sizes["cells"], block.num_layers,
                          sizes["reduced_dofs"], sizes["linear_solver"], sizes["ranks"])


def build_model(case: FemCase, comm: MPI.Comm) -> Model:
    """Mesh the block of ``case`` (after the memory gate) and set up its solid, periodic
    reduction, flat and equilibrium."""
    surface = case.surface
    check_memory(surface.n, case.mesh, comm, surface.spacing)
    with stage(MESH):
        block = build_block(surface.heights, surface.spacing, case.mesh, comm)
    solid = Solid(block.mesh, case.material, case.solver.elastic, case.solver.integration)
    reduction = PeriodicReduction(solid.V, block)
    flat = surface_contact(solid, block, case, reduction)
    equilibrium = Equilibrium(solid, reduction, flat, case.solver, block.spacing)
    sizes = {
        "cells": block.mesh.topology.index_map(3).size_global,
        "grid_size": block.n,
        "refinement_level": block.layout.level,
        "layers": block.num_layers,
        "blend_layers": case.mesh.blend_layers,
        "depth_m": block.depth,
        "reduced_dofs": 3 * reduction.num_reduced_global,
        "linear_solver": equilibrium.linear_solver.method,
        "ranks": comm.size,
    }
    return Model(block, solid, reduction, flat, equilibrium, sizes)


def run_load(path: LoadPath, model: Model, case: FemCase, preload: Outcome, clock: StageClock,
             fields: LoadFields) -> tuple[Outcome, FemRun, tuple]:
    """The run of the load of ``case`` on the shared path (:func:`load_on_path`) with its
    timings, memory and fallback (:class:`SolverProbe`) and fields. Returns the preload's
    outcome, the run and the branch point to return to."""
    probe = SolverProbe(model.equilibrium.linear_solver, model.block.mesh.comm)
    fields.start(case.loading.load_star)
    preload, outcome, maps, branch = load_on_path(path, case, preload, clock, fields)
    result = FemResult(list(path.records), outcome.converged, outcome.message,
                       case.loading.normal_only, clock.timings(),
                       {**model.sizes, **probe.sizes()})
    return preload, FemRun(result, maps, model.equilibrium, model.block), branch


def load_on_path(path: LoadPath, case: FemCase, preload: Outcome, clock: StageClock,
                 fields: LoadFields) -> tuple[Outcome, Outcome, dict, tuple]:
    """One load of ``case`` on the shared normal loading path: the preload goes on to its F_n
    (unless an earlier load's preload failed: ``preload`` is that outcome), its end is mapped
    and written, then, unless normal-only, the flat slides from there to inception, mapped and
    written again. Returns the preload's outcome, the load's, its maps (``FemRun.maps``) and the
    branch point to return to (:meth:`LoadPath.branch_point`)."""
    flat = path.equilibrium.flat
    with clock.preloading():
        if preload.converged:
            preload = path.preload(case.normal_force, then_slide=not case.loading.normal_only)
    outcome, maps = preload, {}
    if path.contact is not None:
        maps.update(contact_maps(flat, path.contact, "normal"))
        fields.write(0.0, path.contact)
    with clock.sliding():
        branch = path.branch_point()
        if preload.converged and not case.loading.normal_only:
            normal_records = len(path.records)
            outcome = path.slide()
            if len(path.records) > normal_records:
                maps.update(contact_maps(flat, path.contact, "sliding"))
                fields.write(1.0, path.contact)
        fields.close()
    return preload, outcome, maps, branch


# --- observers of a run: wall time, memory and solver fallbacks, field output ----------------


class StageClock:
    """Wall time of a run's stages [s]: the setup, the preload (shared by the loads: summed
    over those computed so far) and the last load's sliding."""

    def __init__(self):
        self.started = time.perf_counter()
        self.setup_s = self.preload_s = self.sliding_s = 0.0

    def setup_done(self) -> None:
        """The setup ends now."""
        self.setup_s = time.perf_counter() - self.started

    @contextmanager
    def preloading(self):
        """Add the time of the block to the preload's."""
        mark = time.perf_counter()
        yield
        self.preload_s += time.perf_counter() - mark

    @contextmanager
    def sliding(self):
        """The time of the block is the sliding's."""
        mark = time.perf_counter()
        yield
        self.sliding_s = time.perf_counter() - mark

    def timings(self) -> dict:
        """``FemResult.timings``: setup_s, preload_s, sliding_s and their sum total_s [s]."""
        return {"setup_s": self.setup_s, "preload_s": self.preload_s,
                "sliding_s": self.sliding_s,
                "total_s": self.setup_s + self.preload_s + self.sliding_s}


class SolverProbe:
    """What one load's run adds to the model's sizes, from its start (now) to :meth:`sizes`:
    the peak memory summed over the ranks [GB] and the linear solver's fallback, if it fell
    back meanwhile."""

    def __init__(self, linear_solver, comm: MPI.Comm):
        self.linear_solver, self.comm = linear_solver, comm
        self.fallbacks = linear_solver.fallbacks

    def sizes(self) -> dict:
        """``peak_memory_gb`` and ``linear_solver_fallback`` ("" if none) (a collective call)."""
        solver = self.linear_solver
        return {"peak_memory_gb": self.comm.allreduce(peak_memory_gb(), op=MPI.SUM),
                "linear_solver_fallback": (solver.fell_back
                                           if solver.fallbacks > self.fallbacks else "")}


class LoadFields:
    """XDMF fields of each load (:class:`solver.fields.FieldWriter`): at the end of its preload
    (time 0) and at inception (time 1), to ``directory/fields.xdmf``, or with ``several`` loads
    to ``directory/F<F*>/fields.xdmf``; nothing without a directory."""

    def __init__(self, directory, several: bool, block: Block, solid: Solid, flat: RigidFlat):
        self.directory, self.several = directory, several
        self.model = (block, solid, flat)
        self.writer = None

    def start(self, load: float) -> None:
        """Open the fields of the load F* = ``load``."""
        if self.directory:
            directory = Path(self.directory) / f"F{load:g}" if self.several else self.directory
            self.writer = FieldWriter(directory, *self.model)

    def write(self, time_value: float, contact: ContactResponse) -> None:
        """The fields of the current state, with its contact state, at ``time_value``."""
        if self.writer is not None:
            self.writer.write(time_value, contact)

    def close(self) -> None:
        """Close the load's fields."""
        if self.writer is not None:
            self.writer.close()
            self.writer = None
