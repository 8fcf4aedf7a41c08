"""Equilibrium of the solid pressed and dragged by the flat: the iterate, its steps and the path.

Unknowns: the reduced displacement u_red (periodic, bottom fixed) and the flat height h, held
by the force condition r(h) = sum_k p_k a_k - F_n = 0 (force control, the paper's pilot node).
:class:`Equilibrium` keeps the iterate (u_red, h) and the converged steps it returns to; its
equations are assembled and solved by :class:`solver.reduced_system.ReducedSystem`, and a load
step is driven to convergence by :func:`solver.newton.solve_load_step`.
"""

from __future__ import annotations

from dataclasses import dataclass

from petsc4py import PETSc
from roughfriction.case import SolverOptions
from roughfriction.solver.contact import (
    FRICTIONLESS,
    ContactHistory,
    ContactResponse,
    RigidFlat,
    Trial,
)
from roughfriction.solver.newton import LoadStep, NewtonReport, solve_load_step
from roughfriction.solver.periodic import PeriodicReduction
from roughfriction.solver.reduced_system import ReducedSystem
from roughfriction.solver.solid import Solid

#: Relative Krylov tolerance of the path tangent du/dh (:meth:`Equilibrium.path_slope`): a
#: predictor, which Newton corrects [-].
PATH_SLOPE_TOLERANCE = 1e-4


@dataclass(frozen=True)
class Committed:
    """Everything a converged step leaves behind: the state a later step starts from.

    Attributes
    ----------
    displacement : petsc4py.PETSc.Vec
        u_red [m] (owned by this record: never changed).
    flat_height : float
        h [m].
    plastic : object
        The solid's plastic history (:attr:`Solid.committed`).
    contact : ContactHistory
        The flat's stick points, slip and contact flags and multipliers.
    """

    displacement: PETSc.Vec
    flat_height: float
    plastic: object
    contact: ContactHistory


class Equilibrium:
    """The iterate (u_red, h) of the contact problem, its equations and its converged steps.

    Parameters
    ----------
    solid : Solid
        The deformable block.
    reduction : PeriodicReduction
        u = P u_red.
    flat : RigidFlat
        Contact nodes owned by this rank.
    options : SolverOptions
        Tolerances and the linear-solver choice.
    spacing : float
        Grid spacing h [m] (scale of the increment tolerance).

    Attributes
    ----------
    system : ReducedSystem
        R, b, c, K and the bordered solve.
    displacement : petsc4py.PETSc.Vec
        The current u_red [m].
    flat_height : float
        The current h [m].
    committed : Committed
        The last converged step.
    """

    def __init__(self, solid: Solid, reduction: PeriodicReduction, flat: RigidFlat,
                 options: SolverOptions, spacing: float):
        self.solid, self.reduction, self.flat = solid, reduction, flat
        self.options, self.spacing = options, spacing
        self.system = ReducedSystem(solid, reduction, flat, options)
        self.displacement = reduction.create_reduced_vector()
        self.flat_height = 0.0  # set by the first load step
        self.committed = Committed(self.displacement.copy(), self.flat_height, solid.committed,
                                   flat.committed)
        self._previous = None  # the converged step before the committed one, if any
        self._path_tangent = None  # du/dh at the last path_slope

    @property
    def linear_solver(self):
        """The :class:`solver.linear.LinearSolver` of the system."""
        return self.system.linear_solver

    # --- the iterate --------------------------------------------------------------------------

    def assemble(self, flat_slide: float, trial: Trial = FRICTIONLESS) -> ContactResponse:
        """R, b and c at the current iterate with the contact evaluated as ``trial`` says
        (:meth:`ReducedSystem.assemble`)."""
        return self.system.assemble(self.displacement, self.flat_height, flat_slide, trial)

    def assemble_tangent(self, contact: ContactResponse) -> None:
        """K at the iterate of the last :meth:`assemble`, whose ``contact`` state is passed
        (:meth:`ReducedSystem.assemble_tangent`)."""
        self.system.assemble_tangent(contact)

    def advance(self, length: float, height_increment: float) -> None:
        """Move the iterate by ``length`` times the last Newton direction: u += length du (du in
        ``system.x1``), h += length dh (``height_increment`` dh [m])."""
        self.displacement.axpy(length, self.system.x1)
        self.flat_height += length * height_increment

    def solve(self, step: LoadStep) -> NewtonReport:
        """One load step from the current iterate (:func:`solver.newton.solve_load_step`)."""
        return solve_load_step(self, step)

    # --- the path predictor -------------------------------------------------------------------

    def path_slope(self) -> float:
        """dF_n/dh along the frictionless equilibrium path at the current, converged iterate
        [N/m] (< 0: lowering the flat loads it): residual, b, c and tangent assembled there,
        one linear solve K du/dh = -b, c.du/dh + d. du/dh is kept for :meth:`follow_path`."""
        system = self.system
        self.assemble_tangent(self.assemble(0.0))
        system.set_operator()
        system.solve_height_column(PATH_SLOPE_TOLERANCE)
        if self._path_tangent is None:
            self._path_tangent = system.x2.duplicate()
        system.x2.copy(self._path_tangent)
        return system.height_slope()

    def follow_path(self, height_change: float) -> None:
        """Move the current iterate along the path tangent of the last :meth:`path_slope` by
        dh = ``height_change`` [m]: u += du/dh dh, h += dh (the first iterate of a held
        step)."""
        self.displacement.axpy(height_change, self._path_tangent)
        self.flat_height += height_change

    def place_flat(self, normal_force: float) -> None:
        """Lower the flat onto the current surface so that it roughly carries
        ``normal_force`` [N] (:meth:`RigidFlat.touching_height`): the first iterate of a step
        that starts without contact."""
        self.flat_height = self.flat.touching_height(
            self.solid.displacement.x.array.reshape(-1, 3), normal_force,
            self.solid.material.E_star)

    def extrapolate(self, ratio: float) -> None:
        """First iterate of the next step: the last two converged steps extrapolated linearly,
        u = u_c + ratio (u_c - u_p) and the same for h, where ``ratio`` is the next load
        increment over the last one [-]: the step's contact and slip sets then start close to
        their final ones. The caller says when the last two steps belong to one monotonic path
        (:meth:`resume` forgets the older one)."""
        last, older = self.committed, self._previous
        last.displacement.copy(self.displacement)
        self.displacement.axpy(ratio, last.displacement)
        self.displacement.axpy(-ratio, older.displacement)
        self.flat_height = last.flat_height + ratio * (last.flat_height - older.flat_height)

    # --- converged steps ----------------------------------------------------------------------

    def commit(self, contact: ContactResponse) -> None:
        """Accept the current iterate, with the contact state ``contact``, as a converged
        step."""
        self.solid.commit()
        self.flat.commit(contact)
        self._previous = self.committed
        self.committed = Committed(self.displacement.copy(), self.flat_height,
                                   self.solid.committed, self.flat.committed)

    def restore(self) -> None:
        """Return the iterate, the plastic and the contact history to the last committed step
        (after a failed step)."""
        committed = self.committed
        committed.displacement.copy(self.displacement)
        self.flat_height = committed.flat_height
        self.solid.committed = committed.plastic
        self.flat.resume(committed.contact)
        self.reduction.expand(self.displacement, self.solid.displacement)

    def committed_state(self) -> Committed:
        """The last converged step, to :meth:`resume` from later (several loadings branch from
        one state)."""
        return Committed(self.committed.displacement.copy(), self.committed.flat_height,
                         self.committed.plastic, self.committed.contact)

    def resume(self, state: Committed) -> None:
        """Return to a :meth:`committed_state` (it stays valid for further resumes)."""
        self.committed = Committed(state.displacement.copy(), state.flat_height, state.plastic,
                                   state.contact)
        self._previous = None
        self.restore()

    def destroy(self) -> None:
        """Free this model's PETSc objects (matrices, vectors, the KSP, P): petsc4py 3.18 does
        not free objects that reference each other, so a batch of runs in one process would
        keep every finished run's memory. The model is unusable afterwards."""
        committed = [self.committed] + ([self._previous] if self._previous else [])
        for item in (self.displacement, *(step.displacement for step in committed),
                     self._path_tangent):
            if item is not None:
                item.destroy()
        self.system.destroy()
        self.reduction.destroy()
