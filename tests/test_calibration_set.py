"""The calibration set's runner (``benchmarks.calibration_set``): a small case end to end, and
a resumed run that computes nothing twice."""

import pytest
from roughfriction.studies.certificate import BOUNDARY_FACTOR, LADDER_FACTOR

from benchmarks import calibration, calibration_set

pytestmark = pytest.mark.fem


def test_a_small_case_runs_resumes_and_is_judged(tmp_path, monkeypatch, capsys):
    """A 4 x 4 window of G5 at F* = 0.155 on uniform levels 1x-8x: one row per level with its
    contact counts and physics; run again, nothing is computed; its 2x level is judged
    against the 8x reference."""
    from mpi4py import MPI
    from roughfriction.studies.physics import physics_stamp, physics_version

    path = tmp_path / "ladders.csv"
    set_of_one = {"windows": (("G5", 1),), "n": 4, "loads": (0.155,)}
    calibration_set.run_set(path, MPI.COMM_WORLD, levels=(0, 1, 2, 3), **set_of_one)
    rows = calibration_set.read_rows(path)
    assert [int(row["level"]) for row in rows] == [0, 1, 2, 3]
    progress = capsys.readouterr().err
    assert "G5 8x: FEM G5" in progress and "G5 8x: normal " in progress  # a line per step
    assert "G5 8x: tangential " in progress
    assert {row["physics"] for row in rows} == {physics_stamp(physics_version())}
    nodes = [int(row["contact_nodes"]) for row in rows]
    assert all(0 < int(row["boundary_nodes"]) <= node for row, node in zip(rows, nodes,
                                                                           strict=True))
    assert nodes == sorted(nodes)  # finer levels resolve the contact with more nodes

    import roughfriction.solver.run as solver_run
    monkeypatch.setattr(solver_run, "run_loads", lambda *a, **k: pytest.fail("recomputed"))
    calibration_set.run_set(path, MPI.COMM_WORLD, levels=(0, 1, 2, 3), **set_of_one)
    assert calibration_set.read_rows(path) == rows

    (case,) = calibration.read_cases(path)
    assert case.level == 1 and case.reference_factor == 8
    assert case.mu_reference == pytest.approx(float(rows[3]["mu_s"]))
    judged = calibration.judge(case, LADDER_FACTOR, BOUNDARY_FACTOR)
    assert judged["actual_error"] == pytest.approx(abs(float(rows[1]["mu_s"])
                                                       - float(rows[3]["mu_s"])))


@pytest.mark.parametrize(("stamp", "expected"), [("bbbbbbbbbbbb", True), ("aaaaaaaaaaaa", True),
                                                 ("cccccccccccc", False), ("", False)])
def test_a_level_counts_as_done_when_its_physics_is_carried_to_this_code(stamp, expected):
    """A row made by earlier physics that an equivalence record carries to today's is not
    re-run; one of unrelated or unstamped physics is."""
    from benchmarks.stamps import Physics

    physics = Physics("bbbbbbbbbbbb", {"aaaaaaaaaaaa": "bbbbbbbbbbbb"})
    rows = [{"surface": "G5", "window": "2", "level": "1", "physics": stamp}]
    assert calibration_set.done(rows, "G5", 1, 1, physics) is expected
    assert not calibration_set.done(rows, "G5", 1, 2, physics)


def test_a_level_run_at_some_loads_gets_the_others_later(tmp_path, monkeypatch):
    """A level first run at its low load is completed at the other load alone: the runner asks
    run_loads for the missing load only, and the table then holds both rows."""
    import roughfriction.solver.run as solver_run
    from mpi4py import MPI

    path = tmp_path / "ladders.csv"
    window = {"windows": (("G5", 1),), "n": 4, "levels": (0,)}
    calibration_set.run_set(path, MPI.COMM_WORLD, loads=(0.155,), **window)
    asked = []
    real = solver_run.run_loads
    monkeypatch.setattr(solver_run, "run_loads",
                        lambda case, loads, *a, **k: asked.append(loads) or real(case, loads, *a,
                                                                                   **k))
    calibration_set.run_set(path, MPI.COMM_WORLD, loads=(0.06, 0.155), **window)
    assert asked == [[0.06]]
    rows = calibration_set.read_rows(path)
    assert sorted(float(row["load_star"]) for row in rows) == [0.06, 0.155]


def test_the_command_picks_surfaces_of_the_set_and_refuses_others(capsys):
    assert calibration_set.set_windows("G1,2L") == (("G1", 9), ("2L", 54))
    assert calibration_set.main(["unused.csv", "3", "0.06", "G2"]) == 2
    assert "not in the calibration set: G2; it holds G1, G3" in capsys.readouterr().err


def test_each_level_frees_its_model_before_the_next_is_built(tmp_path, monkeypatch):
    """The set runs many levels in one process: each level's PETSc objects are freed before
    the next level is built (``tests/test_fem_cli_ladder.py`` says why)."""
    from mpi4py import MPI

    from tests.test_fem_cli_ladder import model_events

    events = model_events(monkeypatch)
    calibration_set.run_set(tmp_path / "ladders.csv", MPI.COMM_WORLD, windows=(("G5", 1),),
                            n=4, loads=(0.155,), levels=(0, 1))
    assert events == ["built", "freed", "built", "freed"]
