"""Fixtures shared by the test modules, and a hook that stops every rank of an MPI test run
when a test fails on one."""

import dataclasses
import sys

import pytest


def pytest_runtest_logreport(report):
    """Under ``mpirun`` with several ranks, a test that fails on one rank aborts them all once
    its report is written: the other ranks would wait in their next collective call for ever
    (and a CI job with them)."""
    if not report.failed or "mpi4py.MPI" not in sys.modules:
        return
    comm = sys.modules["mpi4py.MPI"].COMM_WORLD
    if comm.size > 1:
        sys.stderr.write(f"\nrank {comm.rank}: {report.nodeid} failed:\n"
                         f"{report.longreprtext}\n")
        sys.stderr.flush()
        comm.Abort(1)


@pytest.fixture
def only_mark_the_path(monkeypatch):
    """A function ``patch(rule)`` that patches Equilibrium.solve so that a step only marks the
    path where ``rule(marks_path, friction, hold_height)`` says so (the others are solved to
    the end)."""
    from roughfriction.solver.equilibrium import Equilibrium  # the FEM, only where used
    from roughfriction.solver.newton import Finish

    solve = Equilibrium.solve

    def patch(rule):
        def patched(self, step):
            marks_path = rule(step.marks_path, step.frictional, step.hold_height)
            finish = Finish.PATH if marks_path else Finish.TOLERANCES
            return solve(self, dataclasses.replace(step, finish=finish))

        monkeypatch.setattr(Equilibrium, "solve", patched)

    return patch
