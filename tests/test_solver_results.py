"""Run records and the sliding inception rule (solver/results.py)."""

import math

import pytest
from roughfriction.solver.results import SlipState, StepRecord, at_inception, slip_state

TOLERANCE = 1e-3


def test_every_contact_node_slipping_is_inception():
    assert at_inception(SlipState(12, 12, 0.0, math.inf), TOLERANCE)
    assert not at_inception(SlipState(0, 0, 0.0, 0.0), TOLERANCE)  # no contact


def test_just_touched_stuck_nodes_do_not_hold_a_plateau():
    """7 of 16 271 nodes stuck (just touched) with a negligible reserve, F_t flat: inception;
    a reserve or a force change above the tolerance, or a first sliding step: not yet."""
    assert at_inception(SlipState(16_264, 16_271, 4e-4, 1e-4), TOLERANCE)
    assert not at_inception(SlipState(16_264, 16_271, 2e-3, 1e-4), TOLERANCE)
    assert not at_inception(SlipState(16_264, 16_271, 4e-4, 5e-3), TOLERANCE)
    assert not at_inception(SlipState(16_264, 16_271, 4e-4, math.inf), TOLERANCE)
    assert not at_inception(SlipState(3, 12, math.nan, 0.0), TOLERANCE)


def record(phase, tangential_force, slipping, share):
    return StepRecord(phase, 1.0, tangential_force, 1e-8, 0.0, 0.1, 12, 3, slipping, 0.0, 3, 10,
                      1.0, stuck_shear_share=share)


def test_the_slip_state_compares_the_last_two_sliding_steps():
    records = [record("normal", 0.0, 0, math.nan), record("tangential", 0.2, 4, 0.3),
               record("tangential", 0.25, 11, 2e-4)]
    state = slip_state(records)
    assert (state.slipping_nodes, state.contact_nodes, state.stuck_shear_share) == (11, 12, 2e-4)
    assert state.force_change == pytest.approx(0.05 / 0.25)
    assert slip_state(records[:2]).force_change == math.inf  # the first sliding step


def test_the_progress_line_shows_the_stuck_share():
    assert " slip=11 stuck=2.0e-04 " in str(record("tangential", 0.25, 11, 2e-4))
