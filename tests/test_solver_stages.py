"""solver.stages: stages timed by dolfinx timers and announced to listeners, and the stages
and Krylov record of the linear solver."""

import time

import dolfinx  # noqa: F401  (an install without the FEM fails here)
import pytest
from dolfinx.common import timing
from mpi4py import MPI
from roughfriction.solver import stages
from roughfriction.solver.linear import KrylovSolve, LinearSolver
from roughfriction.solver.stages import listening, stage, stage_timing
from test_solver_linear import skewed_laplacian, wavy_rhs

pytestmark = pytest.mark.fem

#: How long a timed stage sleeps [s].
NAP = 0.02


def test_a_stage_is_timed_into_its_dolfinx_timer_once_per_call():
    """Three calls of a stage: three more calls of the dolfinx timer named with the prefix and
    at least their sleep in seconds; a stage never run has no calls."""
    name = "test: three naps"
    assert stage_timing("test: never run") == (0, 0.0)
    calls, seconds = stage_timing(name)
    for _ in range(3):
        with stage(name):
            time.sleep(NAP)
    after_calls, after_seconds = stage_timing(name)
    assert after_calls - calls == 3
    assert 3 * NAP <= after_seconds - seconds < 3 * NAP + 1.0
    assert timing(stages.PREFIX + name)[:2] == (after_calls, after_seconds)


def test_a_stage_entered_from_inside_itself_counts_once():
    """A function run as a stage that calls itself twice more (as a linear solve retries from
    inside itself): one call of the timer, one end told to the listener, and the function's
    result; a different stage nested inside ends (and is told) before the outer one."""
    name, inner = "test: recursive", "test: nested"
    ended = []

    @stage(name)
    def countdown(depth: int) -> int:
        if depth == 0:
            with stage(inner):
                return 0
        return 1 + countdown(depth - 1)

    calls, _ = stage_timing(name)
    inner_calls, _ = stage_timing(inner)
    with listening(ended.append):
        assert countdown(2) == 2
        assert countdown.__name__ == "countdown"
    assert stage_timing(name)[0] - calls == 1
    assert stage_timing(inner)[0] - inner_calls == 1
    assert ended == [inner, name]


def test_listeners_hear_each_outermost_end_and_are_removed_after_their_block():
    """Two listeners hear every end while they listen, a stage that raises included (timed
    too); after the block neither is called, also when the block raised."""
    name = "test: listened"
    first, second = [], []
    calls, _ = stage_timing(name)
    with listening(first.append), listening(second.append):
        with stage(name):
            pass
        with pytest.raises(ValueError), stage(name):
            raise ValueError("the stage fails")
    assert first == second == [name, name]
    assert stage_timing(name)[0] - calls == 2
    with pytest.raises(KeyError), listening(first.append):
        raise KeyError("the block fails")
    with stage(name):
        pass
    assert first == second == [name, name]
    assert stage_timing(name)[0] - calls == 3


def test_a_linear_solve_that_falls_back_is_one_stage_and_one_record(monkeypatch):
    """A warm-started GMRES solve on Cholesky factors that stalls (3 iterations allowed) and is
    solved again on LU factors from inside the solve: one linear-solve stage, one Krylov solve
    stage per KSP solve (two or more), and one record, warm-started, of the iterations the
    solve returned, with the Krylov method it ended with."""
    monkeypatch.setattr("roughfriction.solver.linear.MAX_KRYLOV_ITERATIONS", 3)
    size = 200
    matrix = skewed_laplacian(size)
    rhs, solution = wavy_rhs(matrix)
    solver = LinearSolver(MPI.COMM_SELF, "direct", relative_tolerance=1e-10)
    solver.set_operator(matrix, symmetric=False)
    solves, _ = stage_timing(stages.LINEAR_SOLVE)
    krylov, _ = stage_timing(stages.KRYLOV_SOLVE)
    iterations = solver.solve(rhs, solution, warm_start=True)
    assert solver.fallbacks == 1 and solver.ksp.getPC().getType() == "lu"
    assert stage_timing(stages.LINEAR_SOLVE)[0] - solves == 1
    assert stage_timing(stages.KRYLOV_SOLVE)[0] - krylov >= 2
    assert solver.krylov_solves == [KrylovSolve(True, "gmres", iterations)]
    solver.destroy()
    matrix.destroy()
