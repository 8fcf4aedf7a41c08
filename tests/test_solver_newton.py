"""solver.newton: when a Newton solve stops (over scripted iterates), the line search and the
forcing term."""

from types import SimpleNamespace

import dolfinx  # noqa: F401  (an install without the FEM fails here)
import numpy as np
import pytest
from roughfriction.case import SolverOptions  # noqa: E402
from roughfriction.solver import newton as newton_module  # noqa: E402
from roughfriction.solver.newton import (  # noqa: E402
    Control,
    Friction,
    LoadStep,
    NewtonSolve,
    Tolerances,
)

pytestmark = pytest.mark.fem


def test_the_forcing_term_is_never_tighter_than_the_newton_tolerance_needs():
    """Far from the solution the Krylov tolerance is 0.1 x the relative residual, at most 1e-3;
    near it, half the Newton tolerance over the relative residual (at most 0.1): a solve to
    1e-6 F_n from 2e-6 F_n needs only a linear residual below 0.5e-6 F_n."""
    forcing = newton_module.forcing_term
    contact = None
    assert forcing(newton_module._Iterate(contact, 1.0, 0.0), 1.0, 1e-6) == 1e-3
    assert forcing(newton_module._Iterate(contact, 1e-3, 0.0), 1.0, 1e-8) == (
        pytest.approx(1e-4))
    assert forcing(newton_module._Iterate(contact, 1e-3, 0.0), 1.0, 1e-6) == (
        pytest.approx(5e-4))
    assert forcing(newton_module._Iterate(contact, 1e-5, 1e-5), 1.0, 1e-6) == (
        pytest.approx(0.025))
    assert forcing(newton_module._Iterate(contact, 1e-6, 1e-6), 1.0, 1e-6) == 0.1


class ScriptedNewton(NewtonSolve):
    """The Newton loop of :class:`NewtonSolve` over scripted iterates: each line search returns
    the next (step length, ||R|| / F_n) of ``script``; F_n = 1, h = 1, the height held, the
    contact set fixed, and every full step ``increment`` long [h].
    ``law`` maps a number of line searches done to ||R|| / F_n under the free contact law there
    (else the same as under the frozen set)."""

    def __init__(self, start: float, script: list, tolerance: float, law: dict | None = None,
                 increment: float = 5e-5):
        system = SimpleNamespace(linear_solver=SimpleNamespace(method="iterative"),
                                 coupled=False, symmetric=True,
                                 bordered_solve=lambda *args: (0.0, 1),
                                 x1=SimpleNamespace(norm=lambda kind: increment))
        equilibrium = SimpleNamespace(
            system=system, options=SolverOptions(), spacing=1.0,
            flat=SimpleNamespace(count=np.count_nonzero),
            assemble_tangent=lambda contact: None)
        super().__init__(equilibrium, LoadStep(1.0, 0.0, Friction.PREDICTED, Control.HEIGHT),
                         Tolerances(tolerance, 1e-4), predictor=False)
        self._scripted = self._iterate(start)
        self._script = list(script)
        self._law, self._done = law or {}, 0

    @staticmethod
    def _iterate(residual: float):
        contact = SimpleNamespace(node_active=np.ones(4, dtype=bool))
        return newton_module._Iterate(contact, residual, 0.0)

    def _evaluate(self, trial):
        if trial.active is None and self._done in self._law:
            return self._iterate(self._law[self._done])
        return self._scripted

    def _line_search(self, height_increment):
        length, residual = self._script.pop(0)
        self.state = self._scripted = self._iterate(residual)
        self._done += 1
        return length


HALVING = [(0.5, 1.2e-5), (0.5, 6e-6), (0.5, 3e-6), (0.5, 1.5e-6), (1.0, 8e-7)]
FROZEN = [(0.5, 5e-5), (0.5, 3e-5), (0.5, 2e-5)] + HALVING


@pytest.mark.parametrize("start, script, law, tolerance, iterations, residual", [
    # tight: accepted at the first iterate within the residual floor after a cut step
    (2.5e-5, HALVING, None, 1e-6, 2, 6e-6),
    # ... also in the frozen round (from the 4th iteration), judged under the law
    (1e-4, FROZEN, None, 1e-6, 5, 6e-6),
    # ... where the law's residual is above the floor, the frozen round goes on
    (1e-4, FROZEN, {5: 5e-5}, 1e-6, 6, 3e-6),
    # a full step into the floor is Newton's quadratic regime: no early stop
    (2.5e-5, [(1.0, 6e-6), (1.0, 8e-7)], None, 1e-6, 2, 8e-7),
    # the path's loose solves (1e-4 F_n) go on to their tolerance: their floor would move
    # the path
    (2.5e-3, [(step, 100 * residual) for step, residual in HALVING], None, 1e-4, 5, 8e-5),
])
def test_a_tight_newton_solve_settles_at_the_floor_once_a_step_is_cut(
        start, script, law, tolerance, iterations, residual):
    """NewtonSolve accepts an iterate within the residual floor times its tolerances as soon
    as the line search has cut a step, in a solve tighter than the path's, judged under the
    contact law itself; otherwise it goes on to its tolerances."""
    report = ScriptedNewton(start, script, tolerance, law).run()
    assert report.converged
    assert report.iterations == iterations
    assert report.residual == pytest.approx(residual)


@pytest.mark.parametrize("tolerance, increment, iterations", [
    # tight: the forces meet their tolerance, the increment is within the floor: accepted
    (1e-6, 5e-4, 2),
    # ... an increment above the floor goes on (here to the iteration limit)
    (1e-6, 2e-3, None),
    # the path's loose solves (1e-4 F_n) go on to their tolerances
    (1e-4, 5e-4, None),
])
def test_a_tight_newton_solve_whose_forces_are_converged_settles_at_the_floor(
        tolerance, increment, iterations):
    """In a solve tighter than the path's, NewtonSolve accepts an iterate whose
    residuals meet their tolerance with an increment up to the residual floor times its own: full
    Newton steps whose increments do not shrink while the residual falls run along a direction
    the forces hardly constrain (G1 at F* = 0.155 on 256^2: 7.5e-4 h at 3.6e-8 F_n, 15
    iterations and a cut). Otherwise it goes on to its tolerances."""
    scale = tolerance / 1e-6
    script = [(1.0, scale * 2e-6 * 0.4**k) for k in range(20)]
    report = ScriptedNewton(scale * 2.5e-5, script, tolerance, increment=increment).run()
    assert report.converged == (iterations is not None), report.reason
    if iterations is not None:
        assert report.iterations == iterations
    else:
        assert "iteration limit" in report.reason


def kinked_slope(kink: float, soft: float, stiff: float, calls: list):
    """s(a) of a Newton step whose energy is quadratic with slope ``soft`` [J per unit step]
    up to a node touching the flat at a = ``kink``, ``stiff`` beyond; s(0) = -1 J. Records the
    step lengths it is called at."""
    def slope(step):
        calls.append(step)
        return -1.0 + soft * step + stiff * max(step - kink, 0.0)
    return slope


def test_a_line_search_takes_the_full_step_where_the_energy_is_quadratic():
    """An exact Newton step on a quadratic energy lands on its minimum: s(1) = 0."""
    calls = []
    step = newton_module.line_search_step(kinked_slope(2.0, 1.0, 0.0, calls), -1.0)
    assert step == 1.0 and calls == [1.0]


@pytest.mark.parametrize("kink, stiff", [(0.3, 1e3), (0.05, 1e5), (0.9, 50.0)])
def test_a_line_search_stops_near_the_least_energy_past_a_contact_kink(kink, stiff):
    """A node that touches the flat part-way along the step (the penalty ~1e3 times stiffer
    than the solid): the step ends where |s| <= line_search_slack |s(0)|, just past the kink,
    within the trial budget, and the iterate is left there (the last call)."""
    calls = []
    slope = kinked_slope(kink, 0.5, stiff, calls)
    step = newton_module.line_search_step(slope, -1.0)
    assert abs(slope(step)) <= newton_module.DEFAULT_OPTIONS.line_search_slack
    trials = newton_module.DEFAULT_OPTIONS.line_search_trials
    assert calls[-2] == step and len(calls) - 1 <= 1 + trials
    halved = 1.0  # what halving while the merit s^2 grows would have taken
    while kinked_slope(kink, 0.5, stiff, [])(halved) ** 2 >= 1.0 and halved > 1 / 32:
        halved /= 2
    assert abs(kinked_slope(kink, 0.5, stiff, [])(halved)) > abs(slope(step))


def test_a_line_search_bisects_where_the_residual_is_not_finite():
    """Past a = 0.6 the residual is not finite (inf); the root of s at a = 0.5 is found."""
    def slope(step):
        return np.inf if step > 0.6 else -1.0 + 2.0 * step
    step = newton_module.line_search_step(slope, -1.0)
    assert abs(slope(step)) <= newton_module.DEFAULT_OPTIONS.line_search_slack


def test_a_load_step_is_made_of_named_choices_and_refuses_meaningless_ones():
    """LoadStep's choices are enums (a bare flag is refused) and a frictionless step has no
    slide; the choices read back as the predicates the solver uses."""
    with pytest.raises(TypeError):
        LoadStep(1.0, 0.0, True)
    with pytest.raises(ValueError):
        LoadStep(1.0, 1e-9)
    step = LoadStep(1.0, 1e-9, Friction.EXACT, Control.HEIGHT, newton_module.Finish.PATH)
    assert (step.frictional, step.predictor, step.exact_tangent, step.hold_height,
            step.marks_path) == (True, False, True, True, True)
    assert not LoadStep(1.0).frictional and LoadStep(1.0, 0.0, Friction.PREDICTED).predictor
