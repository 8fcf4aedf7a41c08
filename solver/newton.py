"""The Newton driver of one load step: Newton solves of the reduced system
(:mod:`solver.reduced_system`) at fixed contact multipliers, with a line search and a frozen
contact set, between Uzawa updates of the multipliers.

A Newton solve is converged when ||R|| <= tol_R F_n, |r| <= tol_R F_n and the last
max |du| <= tol_u h. A line search along each Newton step (du, dh) seeks the root of the slope
s = du.R - dh r of the step's energy, which damps contact and yield overshoot; a solve whose
residual stops halving is abandoned (the step is then cut). A load step is converged
when, after Uzawa updates of the contact multipliers (Newton stops at looser tolerances between
updates), no contact point penetrates deeper than tol_g h. A step that only marks the path takes
one update at its end instead, which the next step's solve absorbs
(``NewtonOptions.carried_penetration``). The settings are a :class:`NewtonOptions`.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

import numpy as np
from petsc4py import PETSc
from roughfriction.solver.contact import ContactResponse, Tangent, Trial
from roughfriction.solver.linear import LinearSolveError
from roughfriction.solver.newton_options import NewtonOptions

#: The options of every solve that is not given its own.
DEFAULT_OPTIONS = NewtonOptions()


class Friction(Enum):
    """The contact law of a load step and how its Newton solve starts.

    ``NONE``: frictionless (the preload; t = 0). The frictional ones differ in their start:
    ``PREDICTED``: the first solve starts with the tangential predictor of
    :meth:`RigidFlat.respond` (the first sliding step); ``PLACED``: from the first iterate the
    caller has placed; ``EXACT``: from there, with the exact tangent instead of the symmetric
    one (:class:`NewtonSolve`; a step solved on where every node slips).
    """

    NONE = "none"
    PREDICTED = "predicted"
    PLACED = "placed"
    EXACT = "exact"


class Control(Enum):
    """What holds the flat in a load step: ``FORCE`` solves for the height h that carries
    F_n; ``HEIGHT`` keeps the current h (displacement control: one linear solve per Newton
    iteration, and no limit point while a few yielding peaks carry the flat)."""

    FORCE = "force"
    HEIGHT = "height"


class Finish(Enum):
    """Where a load step ends: ``TOLERANCES``, at the solver's tolerances; ``PATH``, a step
    that only marks the loading path to the state that is reported (a preload step that
    sliding follows, a sliding step before inception): at the looser Newton tolerances of the
    solves between Uzawa updates, after one solve: if a node penetrates deeper than the
    tolerance (but within ``NewtonOptions.carried_penetration`` times it), the multipliers are
    updated and the update is carried into the next step, whose first solve absorbs it,
    instead of a re-solve here."""

    TOLERANCES = "tolerances"
    PATH = "path"


@dataclass(frozen=True)
class LoadStep:
    """One load step and how it is solved.

    Attributes
    ----------
    normal_force : float
        F_n to hold [N]; under ``Control.HEIGHT``, only the force scale of the tolerances.
    flat_slide : float
        The flat's x displacement U [m] (0 without friction: it would act on nothing).
    friction : Friction
        Frictionless, or frictional and how Newton starts.
    control : Control
        Force or height control of the flat.
    finish : Finish
        Solved to the tolerances, or only marking the path.
    """

    normal_force: float
    flat_slide: float = 0.0
    friction: Friction = Friction.NONE
    control: Control = Control.FORCE
    finish: Finish = Finish.TOLERANCES

    def __post_init__(self):
        for name, kind in (("friction", Friction), ("control", Control), ("finish", Finish)):
            if not isinstance(getattr(self, name), kind):
                raise TypeError(f"LoadStep.{name} must be a {kind.__name__}, "
                                f"not {getattr(self, name)!r}")
        if self.friction is Friction.NONE and self.flat_slide != 0.0:
            raise ValueError("a frictionless load step has no flat slide")

    @property
    def frictional(self) -> bool:
        """Frictional contact (the tangential phase)."""
        return self.friction is not Friction.NONE

    @property
    def predictor(self) -> bool:
        """The first solve starts with the tangential predictor."""
        return self.friction is Friction.PREDICTED

    @property
    def exact_tangent(self) -> bool:
        """Newton starts with the exact tangent."""
        return self.friction is Friction.EXACT

    @property
    def hold_height(self) -> bool:
        """The flat is held at its height."""
        return self.control is Control.HEIGHT

    @property
    def marks_path(self) -> bool:
        """The step only marks the path."""
        return self.finish is Finish.PATH


@dataclass(frozen=True)
class Tolerances:
    """Tolerances of a Newton solve: ||R||, |r| <= ``residual`` F_n and max |du| <=
    ``increment`` h [-]."""

    residual: float
    increment: float


@dataclass(frozen=True)
class NewtonReport:
    """Outcome of one load step's Newton loop.

    Attributes
    ----------
    converged : bool
        Tolerances met within the iteration limit.
    iterations : int
        Newton iterations (linear solves of the bordered system) [-].
    krylov_iterations : int
        Sum of Krylov iterations over both solves of every iteration [-].
    residual : float
        Final ||R|| / F_n [-].
    contact : ContactResponse
        Contact state at the final iterate.
    reason : str
        Why it did not converge ("" if it did).
    """

    converged: bool
    iterations: int
    krylov_iterations: int
    residual: float
    contact: ContactResponse
    reason: str = ""


@dataclass(frozen=True)
class _Iterate:
    """Contact state and residual norms at one Newton iterate."""

    contact: ContactResponse
    residual: float  # ||R|| [N]
    force_error: float  # r = sum p a - F_n [N]

    @property
    def merit(self) -> float:
        """||R||^2 + r^2 [N^2]."""
        return self.residual**2 + self.force_error**2


def line_search_step(slope: Callable[[float], float], initial_slope: float,
                     options: NewtonOptions = DEFAULT_OPTIONS) -> float:
    """Step length a in (0, 1] along a Newton step: the full step if the energy's slope there,
    s(1), is <= ``options.line_search_slack`` |s(0)|, else a root of s bracketed in [0, 1], by the
    secant through the last two trials (exact once both lie past a kink of s, e.g. a node that
    touches the flat) or bisection where that leaves the inner 80 % of the bracket, until
    |s(a)| <= ``line_search_slack`` |s(0)| or ``line_search_trials`` trials (the last is taken).

    ``slope(a)`` moves the iterate to a and returns s(a) [J] (inf if the residual there is not
    finite); ``initial_slope`` is s(0) < 0 [J]. Returns the a of the last call of ``slope``.
    """
    threshold = options.line_search_slack * abs(initial_slope)
    low, high = 0.0, 1.0
    older, older_slope = 0.0, initial_slope
    last, last_slope = 1.0, slope(1.0)
    if last_slope <= threshold:
        return 1.0
    for _ in range(options.line_search_trials):
        step = np.nan
        if np.isfinite(older_slope) and np.isfinite(last_slope) and last_slope != older_slope:
            step = last - last_slope * (last - older) / (last_slope - older_slope)
        width = high - low
        if not low + 0.1 * width <= step <= high - 0.1 * width:
            step = low + 0.5 * width
        older, older_slope = last, last_slope
        last, last_slope = step, slope(step)
        if abs(last_slope) <= threshold:
            break
        if last_slope > 0.0:
            high = step
        else:
            low = step
    return last


def forcing_term(state: _Iterate, normal_force: float, residual_tolerance: float,
                 options: NewtonOptions = DEFAULT_OPTIONS) -> float:
    """Relative Krylov tolerance of a Newton solve to ``residual_tolerance`` F_n, proportional
    to the relative nonlinear residual (inexact Newton, Eisenstat-Walker choice 2 with exponent
    1): loose far from the solution, tight near it, so convergence stays quadratic without
    over-solving early iterations, and never tighter than the Newton tolerance
    ``residual_tolerance`` needs (0: no such bound) [-]."""
    relative_residual = (state.residual + abs(state.force_error)) / normal_force
    forcing = min(options.forcing_max,
                  max(options.forcing_min, options.forcing_factor * relative_residual))
    if relative_residual == 0.0:
        return forcing
    return max(forcing, min(options.forcing_safeguard_max,
                            options.forcing_safeguard * residual_tolerance / relative_residual))


def solve_load_step(equilibrium, step: LoadStep, newton: NewtonOptions = DEFAULT_OPTIONS
                    ) -> NewtonReport:
    """One load step on ``equilibrium`` (:class:`solver.equilibrium.Equilibrium`, from its
    current iterate): Newton solves (:class:`NewtonSolve`) with Uzawa updates of the contact
    multipliers until no contact node penetrates deeper than the tolerance (``newton``: the
    driver's settings)."""
    options, flat = equilibrium.options, equilibrium.flat
    tolerance = options.penetration_tolerance * equilibrium.spacing
    tight = Tolerances(options.residual_tolerance, options.increment_tolerance)
    tolerances = Tolerances(max(tight.residual, newton.uzawa_residual_tolerance),
                            max(tight.increment, newton.uzawa_increment_tolerance))
    if step.marks_path:
        tight = tolerances
    iterations = krylov = updates = solves = 0
    carried = False  # the last update is left to the next step
    while True:
        # the tangential predictor belongs to the first solve of a step only
        predictor = step.predictor and solves == 0
        report = NewtonSolve(equilibrium, step, tolerances, predictor, newton).run()
        solves += 1
        iterations += report.iterations
        krylov += report.krylov_iterations
        penetration = flat.penetration(report.contact)
        if not report.converged:
            break
        if penetration <= tolerance:
            if tolerances == tight:
                break
            tolerances = tight  # the multipliers are good: solve to the tolerances
            continue
        if updates == options.max_augmentations:
            break
        flat.augment(report.contact)
        updates += 1
        carried = step.marks_path and penetration <= newton.carried_penetration * tolerance
        if carried:
            break  # the next step's solve absorbs the update (commit keeps it)
    reason = report.reason
    if report.converged and penetration > tolerance and not carried:
        reason = (f"penetration {penetration / equilibrium.spacing:.2e} h > tolerance "
                  f"{options.penetration_tolerance:.0e} h after "
                  f"{options.max_augmentations} multiplier updates")
    return NewtonReport(not reason, iterations, krylov, report.residual, report.contact, reason)


@dataclass(frozen=True)
class _Floor:
    """The floor judged under the contact law (:meth:`NewtonSolve._at_floor`): whether the
    solve stops there, and the trial and iterate it stops or goes on with."""

    reached: bool
    trial: Trial
    state: _Iterate


@dataclass(frozen=True)
class _Settled:
    """A frozen set's converged iterate judged under the contact law
    (:meth:`NewtonSolve._settle_frozen_set`): the trial and iterate to go on with, the nodes
    that changed their contact state, whether a new frozen round starts, and why the solve
    fails if the set cycles ("" else)."""

    trial: Trial
    state: _Iterate
    changes: float
    new_round: bool
    reason: str


class NewtonSolve:
    """Newton iterations from the current iterate of ``equilibrium`` with fixed multipliers
    until ||R||, |r| <= ``tolerances.residual`` F_n and max |du| <= ``tolerances.increment`` h
    (``predictor``: start with the tangential predictor of :meth:`RigidFlat.respond`;
    ``newton``: the driver's settings).

    The iterations start with the symmetric tangent (``Tangent.SYMMETRIC`` in the
    :class:`Trial` of the contact: CG, and no stick/slip cycling driven by the cap's ramp) and
    go on with the exact one if they stagnate or reach the iteration limit while slipping
    points sit on the ramp (the symmetric tangent then converges only linearly); with
    ``Friction.EXACT`` they start with the exact one. Where the exact tangent says that
    lowering the flat would unload it (dr/dh >= 0: singular, through the ramp's coupling, whose
    friction coefficient tau_c / p_r is far above 1), that Newton step is taken with the
    symmetric one.
    """

    def __init__(self, equilibrium, step: LoadStep, tolerances: Tolerances, predictor: bool,
                 newton: NewtonOptions = DEFAULT_OPTIONS):
        self.equilibrium, self.step, self.predictor = equilibrium, step, predictor
        self.newton = newton
        self.system, self.flat = equilibrium.system, equilibrium.flat
        self.max_iterations = equilibrium.options.max_iterations
        self.tolerance_force = tolerances.residual * step.normal_force
        self.tolerance_increment = tolerances.increment * equilibrium.spacing
        # the forcing term's safeguard for the iterative method only: CG on reused Cholesky
        # factors gains nothing from it, and its Newton path then stays the same on any number
        # of ranks to round-off (GAMG's aggregates depend on the partition anyway)
        iterative = self.system.linear_solver.method == "iterative"
        self.safeguarded = tolerances.residual if iterative else 0.0
        self.settles_on_kink = tolerances.residual < newton.uzawa_residual_tolerance  # the floor
        # how the contact is evaluated: friction, the frozen set (None: the law's) and tangent
        self.trial = Trial(step.frictional, tangent=(Tangent.EXACT if step.exact_tangent
                                                     else Tangent.SYMMETRIC))
        self.increment, self.krylov = 0.0, 0
        self.cut = False  # the last line search cut the Newton step
        self.singular = False  # the exact tangent was singular at this iterate
        self.history = []  # ||R|| + |r| of the iterates [N]
        self.rounds, self.changes, self.limit = 0, np.inf, self.max_iterations
        self.iteration, self.stagnating = 0, False
        self.state = None

    def run(self) -> NewtonReport:
        """Iterate to convergence or failure: at each iterate, settle a converged frozen set,
        stop if converged, failed or at the floor, else advance."""
        self.state = self._evaluate(self._first_trial())
        for self.iteration in itertools.count():
            if self._converged(self.state) and self.trial.active is not None:
                settled = self._settle_frozen_set()
                self._apply(settled)
                if settled.reason:
                    return self._report(settled.reason)
            if self._converged(self.state) and self.trial.active is None:
                return self._report()
            self._record(self.state)
            if not np.isfinite(self.state.merit):
                return self._report("residual not finite")
            if self._near_floor(self.state):
                floor = self._at_floor()
                self.trial, self.state = floor.trial, floor.state
                if floor.reached:
                    return self._report()
            reason = self._advance()
            if reason:
                return self._report(reason)

    def _first_trial(self) -> Trial:
        """The trial of a first iterate: with the tangential predictor while the solve has
        taken no Newton step from it."""
        return dataclasses.replace(self.trial, predictor=self.predictor)

    # --- judging an iterate -------------------------------------------------------------------

    def _forces_met(self, state: _Iterate, factor: float = 1.0) -> bool:
        return (state.residual <= factor * self.tolerance_force
                and abs(state.force_error) <= factor * self.tolerance_force)

    def _converged(self, state: _Iterate, factor: float = 1.0) -> bool:
        return (not self.predictor and self._forces_met(state, factor)
                and self.increment <= factor * self.tolerance_increment)

    def _record(self, state: _Iterate) -> None:
        """Add ||R|| + |r| of ``state`` to the history and note whether the solve stagnates
        (not halved over ``stagnation_window`` iterations)."""
        self.history.append(state.residual + abs(state.force_error))
        window = self.newton.stagnation_window
        self.stagnating = (len(self.history) > window + 2
                           and self.history[-1] > 0.5 * self.history[-1 - window])

    def _near_floor(self, state: _Iterate) -> bool:
        """The iterate is worth judging at the floor: the solve stagnates, or, to tolerances
        tighter than the path's, it is within ``residual_floor`` of them after a cut step or
        with its forces met."""
        return (self.stagnating or ((self.cut or self._forces_met(state)) and self.settles_on_kink
                                    and self._converged(state, self.newton.residual_floor)))

    def _settle_frozen_set(self) -> _Settled:
        """Converged with a frozen set: judge the iterate by the contact law itself (nodes that
        flip at a negligible force no longer cycle), else re-freeze at the law's set there for
        a new round while the set settles; fails if the set cycles."""
        frozen, free = self.trial.active, dataclasses.replace(self.trial, active=None)
        state = self._evaluate(free)
        if self._converged(state):
            return _Settled(free, state, self.changes, False, "")
        changes = self.flat.count(state.contact.node_active != frozen)
        if changes >= self.changes or self.rounds == self.newton.max_rounds:
            return _Settled(free, state, changes, False,
                            f"contact set cycling ({changes} nodes change state after "
                            f"{self.rounds} frozen round(s))")
        refrozen = dataclasses.replace(self.trial, active=state.contact.node_active)
        return _Settled(refrozen, state, changes, True, "")

    def _apply(self, settled: _Settled) -> None:
        """Go on from a :meth:`_settle_frozen_set`: its trial and iterate, and for a new round
        its own iteration budget and residual record."""
        self.trial, self.state, self.changes = settled.trial, settled.state, settled.changes
        if settled.new_round:
            self.rounds += 1
            self.limit = self.iteration + self.max_iterations
            self.history.clear()

    def _at_floor(self) -> _Floor:
        """Whether the iterate is within ``residual_floor`` of the tolerances under the contact
        law itself, with the trial and iterate to go on with: under the law if it is, or if the
        solve stagnates; else (a frozen round goes on) under the frozen set again."""
        frozen, trial, state = self.trial.active, self.trial, self.state
        if frozen is not None:  # judge the floor under the contact law itself
            trial = dataclasses.replace(trial, active=None)
            state = self._evaluate(trial)
        if self._converged(state, self.newton.residual_floor):
            return _Floor(True, trial, state)
        if not self.stagnating:  # above the floor under the law: the frozen round goes on
            trial = dataclasses.replace(trial, active=frozen)
            state = self._evaluate(trial)
        return _Floor(False, trial, state)

    def _where(self) -> str:
        state, normal_force = self.state, self.step.normal_force
        return (f"residual {state.residual / normal_force:.1e} F_n, force error "
                f"{abs(state.force_error) / normal_force:.1e} F_n, last increment "
                f"{self.increment / self.equilibrium.spacing:.1e} h")

    def _report(self, reason: str = "") -> NewtonReport:
        return NewtonReport(not reason, self.iteration, self.krylov,
                            self.state.residual / self.step.normal_force, self.state.contact,
                            reason)

    # --- one iteration ------------------------------------------------------------------------

    def _advance(self) -> str:
        """One Newton iteration, or a change of tangent or of the flat's height; returns why
        the solve fails ("" if it goes on)."""
        if ((self.stagnating or self.iteration == self.limit)
                and self.trial.tangent is Tangent.SYMMETRIC and self.system.coupled
                and not self.singular):
            # slipping points on the cap's ramp: go on with the exact tangent
            self.trial = dataclasses.replace(self.trial, tangent=Tangent.EXACT)
            self.state = self._evaluate(self.trial)
            self.history.clear()
            self.limit = self.iteration + self.max_iterations
            return ""
        if self.stagnating:
            return (f"residual not halved in {self.newton.stagnation_window} iterations "
                    f"(stick/slip or open/closed cycling; {self._where()})")
        if self.iteration == self.limit:
            return f"iteration limit {self.max_iterations} ({self._where()})"
        if self.flat.count(self.state.contact.node_active) == 0 and not self.step.hold_height:
            self.equilibrium.place_flat(self.step.normal_force)
            self.state = self._evaluate(self._first_trial())
            self.increment = np.inf
            return ""
        if self.iteration == self.newton.freeze_after and self.trial.active is None:
            self.trial = dataclasses.replace(self.trial, active=self.state.contact.node_active)
            self.rounds = 1
            self.history.clear()  # the frozen problem's residuals start their own record
        return self._newton_step()

    def _newton_step(self) -> str:
        """Solve for the Newton direction and move along it by the line search; returns why
        the linear solve failed ("" if it did not)."""
        system, step = self.system, self.step
        self.equilibrium.assemble_tangent(self.state.contact)
        try:
            height_increment, its = system.bordered_solve(
                self.state.force_error,
                forcing_term(self.state, step.normal_force, self.safeguarded, self.newton),
                step.hold_height)
        except LinearSolveError as error:
            return str(error)
        self.krylov += its
        if not (step.hold_height or system.symmetric) and system.height_slope() >= 0.0:
            # lowering the flat would unload it: the exact tangent is singular here (the
            # ramp's coupling); this Newton step is taken with the symmetric one instead
            self.trial = dataclasses.replace(self.trial, tangent=Tangent.SYMMETRIC)
            self.singular = True
            self.state = self._evaluate(self.trial)
            return ""
        length = self._line_search(height_increment)
        self.increment = length * system.x1.norm(PETSc.NormType.NORM_INFINITY)
        self.cut = length < 1.0
        self.predictor = False
        if self.singular:  # back to the exact tangent
            self.trial = dataclasses.replace(self.trial, tangent=Tangent.EXACT)
            self.singular = False
            self.state = self._evaluate(self.trial)
        if self.trial.active is not None:  # nodes that entered contact stay in this round
            self.trial = dataclasses.replace(self.trial, active=self.state.contact.node_active)
        return ""

    def _evaluate(self, trial: Trial) -> _Iterate:
        """Assemble at the current iterate, the contact evaluated as ``trial`` says, and
        measure its residuals."""
        step = self.step
        contact = self.equilibrium.assemble(step.flat_slide, trial)
        force_error = (0.0 if step.hold_height
                       else self.flat.normal_force(contact) - step.normal_force)
        return _Iterate(contact, self.system.residual.norm(), force_error)

    def _line_search(self, height_increment: float) -> float:
        """Apply the Newton step (du in x1, dh) with the step length of :func:`line_search_step`
        and return the step length (the iterate there becomes :attr:`state`).

        Frictionless, the step problem minimises a convex energy of (u, h): the solid's
        incremental J2 potential, the penalty's and F_n h. R and -r are its gradient, and
        s(a) = du.R(a) - dh r(a) its slope along the step, which grows with a. Contact and yield
        make it only piecewise smooth: a full step that pushes open nodes into the flat or
        unloads yielding points overshoots, and the root of s is where the energy is least.
        With friction s is the same projection of the residual (a heuristic: slip dissipates),
        used while the tangent is the symmetric one. With the exact tangent (slipping points
        whose cap follows their pressure), or where the energy does not descend along the step
        (s(0) >= 0), the step is halved while ||R||^2 + r^2 grows. The tangential
        predictor's step is always taken (its residual is not comparable).
        """
        system, current = self.system, self.state
        position = 0.0

        def slope(length: float) -> float:
            nonlocal position
            self.equilibrium.advance(length - position, height_increment)
            position = length
            self.state = self._evaluate(self.trial)
            if not np.isfinite(self.state.merit):
                return np.inf
            return system.x1.dot(system.residual) - height_increment * self.state.force_error

        if self.predictor:
            slope(1.0)
            return 1.0
        initial_slope = system.x1.dot(system.residual) - height_increment * current.force_error
        symmetric = self.trial.tangent is Tangent.SYMMETRIC
        if initial_slope < 0.0 and (not self.step.frictional or symmetric):
            return line_search_step(slope, initial_slope, self.newton)
        length = 1.0
        slope(length)
        for _ in range(self.newton.line_search_trials):
            if self.state.merit < current.merit:
                break
            length *= 0.5
            slope(length)
        return length
