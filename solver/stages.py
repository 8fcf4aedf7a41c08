"""Named stages of an FEM run, timed by dolfinx and announced to listeners.

A stage is a piece of the solver's work (the residual assembly, a linear solve, ...) run inside
:func:`stage`. Each outermost call of a stage is timed into the global dolfinx ``Timer`` named
:data:`PREFIX` + its name (``dolfinx.common.timing`` gives its calls and cumulative seconds on
this rank; a call of a stage from inside the same stage is part of the outer one), and its end
is told to every listener registered with :func:`listening` (``listener(name)``). Stages only
time and notify: they do not change what the solver computes.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import contextmanager

from dolfinx.common import Timer, timing

#: What the names of the solver's dolfinx timers start with.
PREFIX = "roughfriction: "

#: Meshing the block (``solver.block.build_block``).
MESH = "mesh"
#: The solid's spaces, quadrature functions and forms (``Solid.__init__``).
SOLID_SETUP = "solid set-up"
#: The periodic reduction u = P u_red (``PeriodicReduction.__init__``).
REDUCTION = "periodic reduction"
#: The reduced system's vectors and linear solver (``ReducedSystem.__init__``).
SYSTEM_SETUP = "system set-up"
#: The tangent's pattern and reduced elastic part, once (``ReducedSystem._create_tangent``).
ELASTIC_TANGENT = "reduced elastic tangent"
#: R, b and c at an iterate (``ReducedSystem.assemble``).
RESIDUAL = "residual assembly"
#: The return map of the solid (``Solid.update_stress``), inside :data:`RESIDUAL`.
STRESS_UPDATE = "stress update"
#: The contact law of the flat (``RigidFlat.respond``), inside :data:`RESIDUAL`.
CONTACT_LAW = "contact law"
#: The reduced tangent K (``ReducedSystem.assemble_tangent``).
TANGENT = "reduced tangent"
#: One linear solve with its retries (``LinearSolver.solve``).
LINEAR_SOLVE = "linear solve"
#: One Krylov solve, building the preconditioner if it is fresh (``LinearSolver._apply``).
KRYLOV_SOLVE = "Krylov solve"

#: Depth of the calls of each stage under way.
_depth: dict[str, int] = {}
#: The callables told of each stage's end.
_listeners: list[Callable[[str], None]] = []


def timer_name(name: str) -> str:
    """The name of the dolfinx timer of stage ``name``."""
    return PREFIX + name


def stage_timing(name: str) -> tuple[int, float]:
    """Outermost calls [-] and their wall time [s] of stage ``name`` so far on this rank
    (cumulative over the process; (0, 0.0) before its first call)."""
    try:
        calls, wall, _, _ = timing(timer_name(name))
    except RuntimeError:  # dolfinx has no timer of that name yet
        return 0, 0.0
    return calls, wall


@contextmanager
def stage(name: str):
    """Run the block (or, as a decorator, the function) as stage ``name``: timed into its
    dolfinx timer and, when it ends (returning or raising), announced to the listeners, unless
    it runs inside a call of the same stage (counted with that one)."""
    depth = _depth.get(name, 0)
    _depth[name] = depth + 1
    try:
        if depth:
            yield
        else:
            with Timer(timer_name(name)):
                yield
    finally:
        _depth[name] = depth
        if not depth:
            for listener in tuple(_listeners):
                listener(name)


@contextmanager
def listening(listener: Callable[[str], None]):
    """Tell ``listener(name)`` of the end of every outermost stage while the block runs."""
    _listeners.append(listener)
    try:
        yield listener
    finally:
        _listeners.remove(listener)
