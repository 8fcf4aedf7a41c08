"""Fixtures shared by the test modules."""

import dataclasses

import pytest


@pytest.fixture
def only_mark_the_path(monkeypatch):
    """A function ``patch(rule)`` that patches Equilibrium.solve so that a step only marks the
    path where ``rule(marks_path, friction, hold_height)`` says so (the others are solved to
    the end)."""
    from roughfriction.solver.equilibrium import Equilibrium  # the FEM, only where used

    solve = Equilibrium.solve

    def patch(rule):
        def patched(self, step):
            marks_path = rule(step.marks_path, step.friction, step.hold_height)
            return solve(self, dataclasses.replace(step, marks_path=marks_path))

        monkeypatch.setattr(Equilibrium, "solve", patched)

    return patch
