"""Progress lines of a run (solver/progress.py): numbered steps, phases, plain step cuts."""

import itertools
import types

from roughfriction.solver.progress import CountedProgress, StepCut, plain_reason
from roughfriction.solver.results import StepRecord

ROOT = types.SimpleNamespace(rank=0)


def record(phase, normal_force, slipping=0, contact=10):
    return StepRecord(phase, normal_force, 0.0, 0.0, 0.0, 0.1, contact, 2, slipping, 0.0, 3, 9,
                      1.0)


def test_steps_are_numbered_with_the_preload_share_and_its_time_left(capsys):
    clock = itertools.count(0.0, 10.0).__next__  # 10 s per call
    progress = CountedProgress(ROOT, 2.0, clock)
    progress(record("normal", 0.5))
    progress(StepCut("normal", 6, 1e-4, "the held flat carries 3.37 x F_n"))
    progress(record("tangential", 2.0, slipping=7))
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("[step 1 | preload 25 % of F_n, 10 s, ~30 s left in it] normal ")
    assert lines[1].startswith("  preload step retried at a smaller size: the step overshot")
    assert lines[2].startswith("[step 2 | sliding, 7 of 10 contact nodes slip, 20 s] tangential")


def test_other_ranks_print_nothing(capsys):
    CountedProgress(types.SimpleNamespace(rank=1), 1.0)(record("normal", 0.5))
    assert capsys.readouterr().err == ""


def test_a_cut_reason_is_said_in_words_with_its_technical_text():
    assert plain_reason("residual not halved in 4 iterations (stick/slip)").startswith(
        "Newton stalled while contact points switched between stick and slip: residual not")
    assert plain_reason("KSP diverged") == "KSP diverged"
