"""Fixtures shared by the test modules."""

import pytest


@pytest.fixture
def only_mark_the_path(monkeypatch):
    """A function ``patch(rule)`` that patches Equilibrium.solve so that a step only marks the
    path where ``rule(marks_path, friction, hold_height)`` says so (the others are solved to
    the end)."""
    from roughfriction.solver.equilibrium import Equilibrium  # the FEM, only where used

    solve = Equilibrium.solve

    def patch(rule):
        def patched(self, normal_force, flat_slide, friction, hold_height=False,
                    predictor=True, marks_path=False, exact_tangent=False):
            return solve(self, normal_force, flat_slide, friction, hold_height, predictor,
                         rule(marks_path, friction, hold_height), exact_tangent)

        monkeypatch.setattr(Equilibrium, "solve", patched)

    return patch
