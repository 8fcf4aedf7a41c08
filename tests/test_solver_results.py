"""Run records and the sliding inception rule (solver/results.py)."""

import math

import pytest
from roughfriction.solver.results import (
    SlipState,
    StepRecord,
    at_inception,
    plateau_change,
    slip_state,
)

TOLERANCE = 1e-3


def test_every_contact_node_slipping_is_inception():
    assert at_inception(SlipState(12, 12, 0.0, math.inf), TOLERANCE)
    assert not at_inception(SlipState(0, 0, 0.0, 0.0), TOLERANCE)  # no contact


def test_just_touched_stuck_nodes_do_not_hold_a_plateau():
    """7 of 16 271 nodes stuck (just touched) with a negligible reserve, F_t flat: inception;
    a reserve or a force change above the tolerance, or too few sliding steps: not yet."""
    assert at_inception(SlipState(16_264, 16_271, 4e-4, 1e-4), TOLERANCE)
    assert not at_inception(SlipState(16_264, 16_271, 2e-3, 1e-4), TOLERANCE)
    assert not at_inception(SlipState(16_264, 16_271, 4e-4, 5e-3), TOLERANCE)
    assert not at_inception(SlipState(16_264, 16_271, 4e-4, math.inf), TOLERANCE)
    assert not at_inception(SlipState(3, 12, math.nan, 0.0), TOLERANCE)


def record(phase, tangential_force, slipping, share):
    return StepRecord(phase, 1.0, tangential_force, 1e-8, 0.0, 0.1, 12, 3, slipping, 0.0, 3, 10,
                      1.0, stuck_shear_share=share)


def test_the_plateau_is_f_t_within_the_tolerance_over_the_last_two_steps():
    """G5 F* = 0.93 at 128^2 crept +0.58, +0.08, +0.03, +0.06 % per step after its contact
    nodes slipped but for the ones just touched: the plateau is reached where two steps add
    at most 0.1 %; a 512^2 surface whose F_t wanders -0.1 % is on it too."""
    creeping = [3.48431, 3.50452, 3.50740, 3.50838, 3.51035]
    changes = [plateau_change(creeping[:k]) for k in range(1, len(creeping) + 1)]
    assert changes[:2] == [math.inf, math.inf]  # fewer than three sliding steps
    assert changes[2] == pytest.approx((3.50740 - 3.48431) / 3.50740)
    assert [change <= TOLERANCE for change in changes] == [False, False, False, False, True]
    assert plateau_change([9.21851, 9.38133, 9.37994, 9.37413]) <= TOLERANCE
    assert plateau_change([1.0, 2.0, 0.0]) == math.inf


def test_the_slip_state_of_the_last_record():
    records = [record("normal", 0.0, 0, math.nan), record("tangential", 0.2, 4, 0.3),
               record("tangential", 0.25, 11, 2e-4), record("tangential", 0.25, 11, 2e-4)]
    state = slip_state(records)
    assert (state.slipping_nodes, state.contact_nodes, state.stuck_shear_share) == (11, 12, 2e-4)
    assert state.force_change == pytest.approx(0.05 / 0.25)
    assert slip_state(records[:3]).force_change == math.inf  # two sliding steps


def test_the_progress_line_shows_the_stuck_share():
    assert " slip=11 stuck=2.0e-04 " in str(record("tangential", 0.25, 11, 2e-4))
