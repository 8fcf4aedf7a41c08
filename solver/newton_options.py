"""The settings of the Newton driver (:mod:`solver.newton`): line search, stagnation and floor,
the frozen contact set, the Uzawa solves and the forcing term, as one frozen object."""

from __future__ import annotations

from dataclasses import dataclass

from roughfriction.solver.reduced_system import SMALLEST_TOLERANCE


@dataclass(frozen=True)
class NewtonOptions:
    """How a load step's Newton solves are driven (all dimensionless).

    Attributes
    ----------
    line_search_trials : int
        Trial steps of a line search after the full Newton step, before the last is taken
        anyway.
    line_search_slack : float
        A line search accepts a step length a where the slope of the energy along the Newton
        step, s(a) = du.R(a) - dh r(a), has |s(a)| <= this times |s(0)| (s(1) <= it for the
        full step).
    stagnation_window : int
        Give a step up when ||R|| + |r| has not halved over this many iterations (stick/slip or
        open/closed cycling; the step is then cut).
    residual_floor : float
        A Newton solve that stagnates with ||R||, |r| and max |du| within this factor of their
        tolerances, under the contact law itself, has reached the floor set by the inexact
        Krylov solves and the kinks of the contact law: it is accepted, not cut (Newton
        tolerances 1e-4 and 1e-8 F_n give the same mu_s to 0.06 %). A solve to tolerances
        tighter than the path's (``uzawa_residual_tolerance``) is accepted there as soon as its
        line search has cut a step: a kink lies between the iterate and the solution (a node at
        the edge of contact, whose shear cap follows its pressure; points at the yield
        surface), and Newton only halves the residual per iteration from there; and as soon as
        its residuals meet their tolerance: the forces are converged, and an increment still
        above its own lies along a direction they hardly constrain (slipping points on the
        cap's ramp make the exact tangent nearly singular).
    freeze_after : int
        Newton iterations with the contact law free; then the contact set is frozen until the
        iterate converges: its nodes stay in contact, and nodes that penetrate join it (the set
        only grows: no open/closed cycling, and a flat carried by a few yielding peaks cannot
        sink through open nodes it does not see); the iterate is accepted if it also meets the
        tolerances under the law itself, else the set is re-frozen at the law's set there (a
        primal active-set strategy). The slip set is not frozen: a frozen slipping point below
        the cap has a traction direction that jumps with a tiny trial vector.
    max_rounds : int
        Active-set rounds (freezes) per Newton solve. Each round has its own budget of
        ``max_iterations``, and a new round is started only while fewer nodes change their
        contact state than at the last one (no cycling).
    uzawa_residual_tolerance, uzawa_increment_tolerance : float
        Newton solves between Uzawa updates stop at ||R||, |r| <= the first times F_n and
        max |du| <= the second times h (or the solver's tolerances if looser); once the
        penetration is within its tolerance, one more solve with the same multipliers meets the
        solver's tolerances (multipliers need an equilibrium only as good as their own error).
    carried_penetration : float
        A step that marks the path leaves its multiplier update to the next step while its
        deepest penetration is within this times the penetration tolerance; deeper (a penalty
        soft against the solid, e.g. a locking mesh), the update would shift the load the flat
        carries, and the step is re-solved.
    forcing_factor, forcing_min, forcing_max : float
        Krylov tolerance = forcing_factor x (||R|| + |r|) / F_n, clipped to
        [forcing_min, forcing_max].
    forcing_safeguard, forcing_safeguard_max : float
        ... but never tighter than forcing_safeguard x the Newton tolerance / (||R|| + |r|) /
        F_n (at most forcing_safeguard_max): a linear residual below the Newton tolerance is
        not needed to meet it (Eisenstat-Walker's safeguard; Kelley, Iterative Methods for
        Linear and Nonlinear Equations, 1995, Sec. 6.3).
    """

    line_search_trials: int = 5
    line_search_slack: float = 0.25
    stagnation_window: int = 4
    residual_floor: float = 10.0
    freeze_after: int = 3
    max_rounds: int = 5
    uzawa_residual_tolerance: float = 1e-4
    uzawa_increment_tolerance: float = 1e-2
    carried_penetration: float = 10.0
    forcing_factor: float = 0.1
    forcing_min: float = SMALLEST_TOLERANCE
    forcing_max: float = 1e-3
    forcing_safeguard: float = 0.5
    forcing_safeguard_max: float = 0.1
