"""The paper's load path: normal preload to F_n, then tangential steps of the flat until every
contact node slips (sliding inception), with adaptive step sizes.

Step control: an increment grows by ``GROWTH`` after a step that converged in at most
``EASY_ITERATIONS`` Newton iterations and is halved after a failed step (the state returns to
the last converged step). A step smaller than ``MIN_FRACTION`` of the first one, or more than
``max_steps`` attempts, ends the run unconverged.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np
from roughfriction.case import FemCase
from roughfriction.solver.contact import ContactResponse
from roughfriction.solver.equilibrium import Equilibrium
from roughfriction.solver.newton import Control, Finish, Friction, LoadStep, NewtonReport
from roughfriction.solver.progress import StepCut
from roughfriction.solver.results import (
    SlipState,
    StepRecord,
    at_inception,
    count_boundary_nodes,
    count_patches,
    plateau_change,
    slip_state,
)

GROWTH = 1.5
#: Grow the step after at most this many Newton iterations [-].
EASY_ITERATIONS = 10
MIN_FRACTION = 1e-3
#: The preload's last step, to F_n under force control, starts within this fraction of F_n
#: (the steps before hold the flat, :meth:`LoadPath.preload`) [-].
FORCE_CONTROLLED = 0.1


def stuck_shear_share(flat, contact: ContactResponse) -> float:
    """``RigidFlat.stuck_shear_reserve`` over F_t [-] (inf where F_t <= 0 with a reserve, 0
    without contact)."""
    reserve, force = flat.stuck_shear_reserve(contact), flat.tangential_force(contact)
    if reserve <= 0.0:
        return 0.0
    return reserve / force if force > 0.0 else float("inf")


@dataclass(frozen=True)
class Outcome:
    """How a loading phase ended.

    Attributes
    ----------
    converged : bool
        The phase reached its goal (full preload; sliding inception).
    message : str
        Why not, if not converged.
    """

    converged: bool
    message: str = ""


class StepSize:
    """Adaptive increment: grows after easy steps, halves after failures.

    Parameters
    ----------
    first : float
        First increment (in the phase's unit).
    largest : float
        Upper bound on the increment.
    """

    def __init__(self, first: float, largest: float):
        self.value = min(first, largest)
        self.smallest = MIN_FRACTION * self.value
        self.largest = largest

    def after(self, report: NewtonReport) -> None:
        """Adapt after a converged step."""
        if report.iterations <= EASY_ITERATIONS:
            self.value = min(GROWTH * self.value, self.largest)

    def cut(self) -> bool:
        """Halve after a failed step; False if the increment became too small."""
        self.value *= 0.5
        return self.value >= self.smallest


class LoadPath:
    """Runs the preload and sliding phases on one :class:`Equilibrium` and records every step.

    Parameters
    ----------
    equilibrium : Equilibrium
        The discrete problem.
    case : FemCase
        Loads, material, options.
    depth : float
        Block depth H [m].
    progress : callable
        Receives a :class:`StepRecord` per converged step and a
        :class:`~roughfriction.solver.progress.StepCut` per failed one.
    """

    def __init__(self, equilibrium: Equilibrium, case: FemCase, depth: float, progress):
        self.equilibrium = equilibrium
        self.case = case
        self.depth = depth
        self.progress = progress
        self.records: list[StepRecord] = []
        self.attempts = 0
        self.failed_iterations = 0  # Newton iterations of failed attempts since the last step
        self.contact: ContactResponse | None = None  # at the last converged step
        self.normal_force = 0.0  # preload reached [N]
        self._path_slope = None  # dF_n/dh at the last converged step, once computed [N/m]
        self._overshoot = None  # (h [m], F_n [N]) of the last held attempt that carried too much
        self._started = time.perf_counter()

    def branch_point(self) -> tuple:
        """The current converged state (after a preload), to :meth:`return_to` after sliding:
        several loads share one normal loading path and branch their sliding from it."""
        return (self.equilibrium.committed_state(), len(self.records), self.contact,
                self.normal_force, self.attempts, time.perf_counter())

    def return_to(self, point: tuple) -> None:
        """Undo everything after :meth:`branch_point`: state, records and step count; the
        branch's wall time is not counted in later records."""
        state, num_records, self.contact, self.normal_force, self.attempts, taken = point
        self.failed_iterations, self._path_slope, self._overshoot = 0, None, None
        self.equilibrium.resume(state)
        del self.records[num_records:]
        self._started += time.perf_counter() - taken

    @property
    def flat_block_slide(self) -> float:
        """tau_c H / G [m]: the slide at which a flat block of depth H would slip."""
        material = self.case.material
        return material.tau_c * self.depth / material.shear_modulus

    def preload(self, target: float, then_slide: bool = False) -> Outcome:
        """Frictionless normal loading from the current preload (0 at first) to ``target`` [N]
        in adaptive increments of the load.

        Until the load is within ``FORCE_CONTROLLED`` of ``target``, a step holds the flat at a
        height aimed at the step's load (displacement control: while a few yielding peaks carry
        the flat, force control has a limit point where Newton stalls): the first from the
        spring estimate of :meth:`Equilibrium.place_flat`, the next ones along the path tangent
        (:meth:`_aim_height`, which falls short of its aim). A held step that carries more than
        ``target``, or adds more than the increment cap (at first contact the path slope is
        far too soft), is cut and re-aimed from it. Held steps end at the looser tolerances of
        a step that marks the path (:meth:`Equilibrium.solve`). The last step, to ``target``,
        is force-controlled; with ``then_slide`` (sliding follows from it) it marks the path
        too, else (a normal-only run ends there) it is solved to the solver's tolerances.
        """
        options = self.case.solver
        largest = 1.0 if options.elastic else options.max_preload_increment  # elastic: path-free
        size = StepSize(1.0 / options.normal_increments, largest)
        equilibrium = self.equilibrium
        last = None  # force increment of the last accepted step of this call [N]
        while self.normal_force < target:
            start = self.normal_force / target
            trial = min(1.0, start + size.value)
            hold = target - self.normal_force > FORCE_CONTROLLED * target
            if hold:  # aim short of the target: an overshoot past it costs a cut
                trial = min(trial, 1.0 - 0.5 * FORCE_CONTROLLED)
            aim = trial * target
            if self.normal_force == 0.0:
                equilibrium.place_flat(aim)
            elif hold:
                self._aim_height(aim)
            elif last is not None:
                equilibrium.extrapolate((aim - self.normal_force) / last)
            report = self._attempt(LoadStep(
                aim, control=Control.HEIGHT if hold else Control.FORCE,
                finish=Finish.PATH if hold or then_slide else Finish.TOLERANCES))
            if report is None:
                return Outcome(False, f"step limit reached during preload at F_n = {start:.4g}"
                                      " x target")
            force = equilibrium.flat.normal_force(report.contact) if hold else aim
            overshoot = (hold and report.converged and self.normal_force > 0.0
                         and force - self.normal_force > largest * target)
            if report.converged and (overshoot or not 0.0 < force <= target):  # aim lower
                if overshoot or force > target:  # re-aim from this attempt (_aim_height)
                    self._overshoot = (equilibrium.flat_height, force)
                report = NewtonReport(False, report.iterations, report.krylov_iterations,
                                      report.residual, report.contact,
                                      f"the held flat carries {force / target:.3g} x F_n")
                self._reject(report, friction=False)
            if not report.converged:
                if not size.cut():
                    return Outcome(False, f"preload did not converge beyond {start:.4g} x F_n "
                                          f"({report.reason})")
                continue
            # (not from the unloaded state: there the flat's height is not on the load path)
            last = force - self.normal_force if self.normal_force else None
            self.normal_force, self._path_slope, self._overshoot = force, None, None
            self._accept("normal", report, 0.0)
            size.after(report)
        return Outcome(True)

    def _aim_height(self, aim: float) -> None:
        """First iterate of a held preload step aimed at the load ``aim`` [N] from the
        committed step: the flat lowered by dh = ln(aim / F_n) / (d ln F_n / dh), the slope
        of the equilibrium path there (exact for an exponential load-approach curve, short of
        the aim for a power law F_n ~ d^a), and u along the path tangent. After an attempt
        that overshot the increment cap, dh is interpolated between the committed step and
        that attempt (where yielding peaks soften F_n(h) this may overshoot again; the cut then
        repeats from the newer attempt)."""
        equilibrium = self.equilibrium
        if self._path_slope is None:
            self._path_slope = equilibrium.path_slope()
        if self._overshoot is not None:
            height, force = self._overshoot
            equilibrium.follow_path((aim - self.normal_force) / (force - self.normal_force)
                                    * (height - equilibrium.flat_height))
            return
        equilibrium.follow_path(np.log(aim / self.normal_force) * self.normal_force
                                / self._path_slope)

    def slide(self) -> Outcome:
        """Tangential steps of the flat at the preload's constant F_n until every contact node
        slips. The first step starts from the preload's state with the tangential predictor
        (:meth:`RigidFlat.respond`); every later one from the last two steps extrapolated by
        its increment (:meth:`Equilibrium.extrapolate`), so that its slip and contact sets
        start close to their final ones. A step only marks the path (looser tolerances,
        :meth:`Equilibrium.solve`) until every contact node slips; that step, whose forces give
        mu_s, is then solved on to the solver's tolerances (:meth:`_tighten`)."""
        target = self.normal_force
        scale = self.flat_block_slide
        options = self.case.solver
        size = StepSize(options.first_slide * scale, options.max_slide_increment * scale)
        slide = 0.0
        last = None  # increment of the last accepted sliding step [m]
        forces = []  # F_t of the accepted sliding steps [N]
        while True:
            trial = slide + size.value
            if last is not None:
                self.equilibrium.extrapolate(size.value / last)
            report = self._attempt(LoadStep(
                target, trial, Friction.PREDICTED if last is None else Friction.PLACED,
                finish=Finish.PATH))
            if (report is not None and report.converged
                    and self._slips(report.contact, forces)):
                report = self._tighten(report, target, trial)
            if report is None:
                return Outcome(False, f"step limit reached while sliding at u_x = {slide:.4g} m")
            if not report.converged:
                if not size.cut():
                    return Outcome(False, f"tangential step did not converge at u_x = {slide:.4g}"
                                          f" m ({report.reason})")
                continue
            last, slide = trial - slide, trial
            record = self._accept("tangential", report, slide)
            forces.append(record.tangential_force)
            if at_inception(slip_state(self.records), options.stuck_shear_tolerance):
                return Outcome(True)
            if slide > options.max_slide * scale:
                return Outcome(False, f"no sliding inception up to u_x = {slide:.4g} m "
                                      f"({record.slipping_nodes} of {record.contact_nodes} "
                                      "contact nodes slip)")
            size.after(report)

    def _attempt(self, step: LoadStep) -> NewtonReport | None:
        """One load step (:meth:`Equilibrium.solve`); restores the committed state if it fails.
        None past the step limit."""
        self.attempts += 1
        if self.attempts > self.case.solver.max_steps:
            return None
        report = self.equilibrium.solve(step)
        if not report.converged:
            self._reject(report, step.frictional)
        return report

    def _slips(self, contact: ContactResponse, forces: list[float]) -> bool:
        """Sliding inception (:func:`at_inception`) in the contact state ``contact``, after
        sliding steps that carried ``forces`` [N]."""
        flat = self.equilibrium.flat
        maps = flat.node_maps(contact)
        state = SlipState(int(np.count_nonzero(maps["slip"])),
                          int(np.count_nonzero(maps["contact"])),
                          stuck_shear_share(flat, contact),
                          plateau_change([*forces, flat.tangential_force(contact)]))
        return at_inception(state, self.case.solver.stuck_shear_tolerance)

    def _tighten(self, report: NewtonReport, normal_force: float, slide: float
                 ) -> NewtonReport:
        """Solve a sliding step that converged at the looser tolerances of a path step on, from
        where it ended, to the solver's tolerances; the report counts the iterations of both
        (restores the committed state if it fails). Newton starts with the exact tangent: every
        contact node slips, and the slipping points below p_r at the patch edges couple their
        traction to their pressure, which the symmetric tangent leaves out (it then converges
        only linearly)."""
        final = self.equilibrium.solve(LoadStep(normal_force, slide, Friction.EXACT))
        final = dataclasses.replace(
            final, iterations=report.iterations + final.iterations,
            krylov_iterations=report.krylov_iterations + final.krylov_iterations)
        if not final.converged:
            self._reject(final, friction=True)
        return final

    def _reject(self, report: NewtonReport, friction: bool) -> None:
        """Return to the committed state after a failed attempt, and report the cut."""
        self.failed_iterations += report.iterations
        self.equilibrium.restore()
        self.progress(StepCut("tangential" if friction else "normal", report.iterations,
                              report.residual, report.reason))

    def _accept(self, phase: str, report: NewtonReport, slide: float) -> StepRecord:
        """Commit a converged step and record it."""
        equilibrium = self.equilibrium
        equilibrium.commit(report.contact)
        self.contact = report.contact
        flat = equilibrium.flat
        maps = flat.node_maps(report.contact)
        contact_grid = maps["contact"]
        record = StepRecord(
            phase=phase,
            normal_force=flat.normal_force(report.contact),
            tangential_force=flat.tangential_force(report.contact),
            slide=slide,
            flat_height=equilibrium.flat_height,
            area_ratio=flat.area_ratio(report.contact.in_contact),
            contact_nodes=int(np.count_nonzero(contact_grid)),
            contact_patches=count_patches(contact_grid),
            boundary_nodes=count_boundary_nodes(contact_grid),
            slipping_nodes=int(np.count_nonzero(maps["slip"])),
            plastic_volume_fraction=equilibrium.solid.plastic_volume_fraction(),
            newton_iterations=report.iterations,
            krylov_iterations=report.krylov_iterations,
            wall_s=time.perf_counter() - self._started,
            cuts=self.attempts - 1 - sum(record.cuts + 1 for record in self.records),
            cut_iterations=self.failed_iterations,
            stuck_shear_share=(stuck_shear_share(flat, report.contact) if phase == "tangential"
                               else float("nan")),
        )
        self.failed_iterations = 0
        self.records.append(record)
        self.progress(record)
        return record
