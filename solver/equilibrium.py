"""Equilibrium of the solid pressed and dragged by the flat: a Newton loop on the reduced system.

Unknowns: the reduced displacement u_red (periodic, bottom fixed) and the flat height h, held
by the force condition r(h) = sum_k p_k a_k - F_n = 0 (force control, the paper's pilot node).
Each Newton iteration solves the bordered system

    [ K    b ] [du]     [R]          b = dR/dh,  c = dr/du,  d = dr/dh = -sum_k c_k
    [ c^T  d ] [dh] = - [r]

with one operator: K x1 = -R, K x2 = -b, dh = -(r + c.x1) / (c.x2 + d), du = x1 + dh x2
(c = -b on the z rows; b also has x-y entries where a slipping point's shear cap follows its
pressure, see :mod:`solver.contact`).
A Newton solve is converged when ||R|| <= tol_R F_n, |r| <= tol_R F_n and the last
max |du| <= tol_u h. A line search along each Newton step (du, dh) seeks the root of the slope
s = du.R - dh r of the step's energy, which damps contact and yield overshoot; a solve whose
residual stops halving is abandoned (the step is then cut). A load step is converged
when, after Uzawa updates of the contact multipliers (Newton stops at looser tolerances between
updates), no contact point penetrates deeper than tol_g h. A step that only marks the path takes
one update at its end instead, which the next step's solve absorbs (``CARRIED_PENETRATION``).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc
from roughfriction.case import SolverOptions
from roughfriction.solver.contact import NEIGHBOURS, ContactResponse, RigidFlat
from roughfriction.solver.linear import LinearSolveError, LinearSolver
from roughfriction.solver.periodic import PeriodicReduction
from roughfriction.solver.solid import Solid

#: Trial steps of a line search after the full Newton step, before the last is taken anyway [-].
LINE_SEARCH_TRIALS = 5
#: A line search accepts a step length a where the slope of the energy along the Newton step,
#: s(a) = du.R(a) - dh r(a), has |s(a)| <= this times |s(0)| (s(1) <= it for the full step) [-].
LINE_SEARCH_SLACK = 0.25
#: Give a step up when ||R|| + |r| has not halved over this many iterations (stick/slip or
#: open/closed cycling; the step is then cut) [-].
STAGNATION_WINDOW = 4
#: A Newton solve that stagnates with ||R||, |r| and max |du| within this factor of their
#: tolerances, under the contact law itself, has reached the floor set by the inexact Krylov
#: solves and the kinks of the contact law: it is accepted, not cut (Newton tolerances 1e-4
#: and 1e-8 F_n give the same mu_s to 0.06 %). A solve to tolerances tighter than the path's
#: (``UZAWA_RESIDUAL_TOLERANCE``) is accepted there as soon as its line search has cut a step:
#: a kink lies between the iterate and the solution (a node at the edge of contact, whose shear
#: cap follows its pressure; points at the yield surface), and Newton only halves the residual
#: per iteration from there; and as soon as its residuals meet their tolerance: the forces are
#: converged, and an increment still above its own lies along a direction they hardly
#: constrain (slipping points on the cap's ramp make the exact tangent nearly singular) [-].
RESIDUAL_FLOOR = 10.0
#: Newton iterations with the contact law free; then the contact set is frozen until the
#: iterate converges: its nodes stay in contact, and nodes that penetrate join it (the set
#: only grows: no open/closed cycling, and a flat carried by a few yielding peaks cannot sink
#: through open nodes it does not see); the iterate is accepted if it also meets the
#: tolerances under the law itself, else the set is re-frozen at the law's set there (a primal
#: active-set strategy). The slip set is not frozen: a frozen slipping point below the cap has
#: a traction direction that jumps with a tiny trial vector [-].
FREEZE_AFTER = 3
#: Active-set rounds (freezes) per Newton solve [-]. Each round has its own budget of
#: ``max_iterations``, and a new round is started only while fewer nodes change their contact
#: state than at the last one (no cycling).
MAX_ROUNDS = 5
#: Newton solves between Uzawa updates stop at ||R||, |r| <= this times F_n and max |du| <=
#: UZAWA_INCREMENT_TOLERANCE h (or the solver's tolerances if looser); once the penetration is
#: within its tolerance, one more solve with the same multipliers meets the solver's
#: tolerances (multipliers need an equilibrium only as good as their own error) [-].
UZAWA_RESIDUAL_TOLERANCE = 1e-4
UZAWA_INCREMENT_TOLERANCE = 1e-2
#: A step that marks the path leaves its multiplier update to the next step while its deepest
#: penetration is within this times the penetration tolerance; deeper (a penalty soft against
#: the solid, e.g. a locking mesh), the update would shift the load the flat carries, and the
#: step is re-solved [-].
CARRIED_PENETRATION = 10.0
#: Krylov tolerance = FORCING_FACTOR x (||R|| + |r|) / F_n, clipped to [FORCING_MIN, FORCING_MAX].
FORCING_FACTOR = 0.1
FORCING_MIN = 1e-10
FORCING_MAX = 1e-3
#: ... but never tighter than FORCING_SAFEGUARD x the Newton tolerance / (||R|| + |r|) / F_n
#: (at most FORCING_SAFEGUARD_MAX): a linear residual below the Newton tolerance is not needed
#: to meet it (Eisenstat-Walker's safeguard; Kelley, Iterative Methods for Linear and Nonlinear
#: Equations, 1995, Sec. 6.3) [-].
FORCING_SAFEGUARD = 0.5
FORCING_SAFEGUARD_MAX = 0.1
#: Above this fraction of the cells yielding, the plastic correction is reduced with the elastic
#: part on the whole mesh (P^T K P with its pattern reused), below it on the yielding cells'
#: couplings alone (whose cost grows with them; measured crossover 15-20 % at N = 64) [-].
WHOLE_MESH_YIELDING = 0.15
#: Relative Krylov tolerance of the path tangent du/dh (:meth:`Equilibrium.path_slope`): a
#: predictor, which Newton corrects [-].
PATH_SLOPE_TOLERANCE = 1e-4


@dataclass(frozen=True)
class NewtonReport:
    """Outcome of one load step's Newton loop.

    Attributes
    ----------
    converged : bool
        Tolerances met within the iteration limit.
    iterations : int
        Newton iterations (linear solves of the bordered system) [-].
    krylov_iterations : int
        Sum of Krylov iterations over both solves of every iteration [-].
    residual : float
        Final ||R|| / F_n [-].
    contact : ContactResponse
        Contact state at the final iterate.
    reason : str
        Why it did not converge ("" if it did).
    """

    converged: bool
    iterations: int
    krylov_iterations: int
    residual: float
    contact: ContactResponse
    reason: str = ""


@dataclass(frozen=True)
class _Iterate:
    """Contact state and residual norms at one Newton iterate."""

    contact: ContactResponse
    residual: float  # ||R|| [N]
    force_error: float  # r = sum p a - F_n [N]

    @property
    def merit(self) -> float:
        """||R||^2 + r^2 [N^2]."""
        return self.residual**2 + self.force_error**2


def line_search_step(slope: Callable[[float], float], initial_slope: float) -> float:
    """Step length a in (0, 1] along a Newton step: the full step if the energy's slope there,
    s(1), is <= ``LINE_SEARCH_SLACK`` |s(0)|, else a root of s bracketed in [0, 1], by the
    secant through the last two trials (exact once both lie past a kink of s, e.g. a node that
    touches the flat) or bisection where that leaves the inner 80 % of the bracket, until
    |s(a)| <= ``LINE_SEARCH_SLACK`` |s(0)| or ``LINE_SEARCH_TRIALS`` trials (the last is taken).

    ``slope(a)`` moves the iterate to a and returns s(a) [J] (inf if the residual there is not
    finite); ``initial_slope`` is s(0) < 0 [J]. Returns the a of the last call of ``slope``.
    """
    threshold = LINE_SEARCH_SLACK * abs(initial_slope)
    low, high = 0.0, 1.0
    older, older_slope = 0.0, initial_slope
    last, last_slope = 1.0, slope(1.0)
    if last_slope <= threshold:
        return 1.0
    for _ in range(LINE_SEARCH_TRIALS):
        step = np.nan
        if np.isfinite(older_slope) and np.isfinite(last_slope) and last_slope != older_slope:
            step = last - last_slope * (last - older) / (last_slope - older_slope)
        width = high - low
        if not low + 0.1 * width <= step <= high - 0.1 * width:
            step = low + 0.5 * width
        older, older_slope = last, last_slope
        last, last_slope = step, slope(step)
        if abs(last_slope) <= threshold:
            break
        if last_slope > 0.0:
            high = step
        else:
            low = step
    return last


def forcing_term(state: _Iterate, normal_force: float, residual_tolerance: float) -> float:
    """Relative Krylov tolerance of a Newton solve to ``residual_tolerance`` F_n, proportional
    to the relative nonlinear residual (inexact Newton, Eisenstat-Walker choice 2 with exponent
    1): loose far from the solution, tight near it, so convergence stays quadratic without
    over-solving early iterations, and never tighter than the Newton tolerance
    ``residual_tolerance`` needs (0: no such bound) [-]."""
    relative_residual = (state.residual + abs(state.force_error)) / normal_force
    forcing = min(FORCING_MAX, max(FORCING_MIN, FORCING_FACTOR * relative_residual))
    if relative_residual == 0.0:
        return forcing
    return max(forcing, min(FORCING_SAFEGUARD_MAX,
                            FORCING_SAFEGUARD * residual_tolerance / relative_residual))


class Equilibrium:
    """Assemble and solve the contact problem; keep the committed state for step cuts.

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
    """

    def __init__(self, solid: Solid, reduction: PeriodicReduction, flat: RigidFlat,
                 options: SolverOptions, spacing: float):
        self.solid, self.reduction, self.flat = solid, reduction, flat
        self.options, self.spacing = options, spacing
        self.comm = solid.V.mesh.comm

        self.displacement = reduction.create_reduced_vector()  # u_red [m]
        self.flat_height = 0.0  # h [m], set by the first load step
        self._committed = (self.displacement.copy(), self.flat_height)
        self._previous = None  # the converged step before the committed one, if any

        self._elastic_tangent = fem_petsc.create_matrix(solid.elastic_tangent_forms[0])
        for form in solid.elastic_tangent_forms:
            fem_petsc.assemble_matrix(self._elastic_tangent, form)
        self._elastic_tangent.assemble()
        self._residual_full = fem_petsc.create_vector(solid.residual_forms[0])
        self._elastic_system = None  # P^T K_elastic P in the system's pattern, at first assembly
        self._tangent_full = None  # K_elastic + K_plastic on the whole mesh, once needed
        self._solid_tangent = None  # its P^T K P
        self.tangent = None  # P^T K P + contact, created at the first assembly
        self._uncoupled_tangent = None  # the tangent without dt/dp, once it is not symmetric
        self._symmetric = True  # the tangent, at its last assembly
        self._coupled = False  # some slipping point's cap followed its pressure there
        self.residual = reduction.create_reduced_vector()
        self._height_column = reduction.create_reduced_vector()  # b = dR/dh
        self._force_row = reduction.create_reduced_vector()  # c = dr/du
        self._x1 = reduction.create_reduced_vector()
        self._x2 = reduction.create_reduced_vector()
        self._path_tangent = None  # du/dh at the last path_slope

        num_dofs = 3 * reduction.num_reduced_global
        method = options.linear_solver
        if method == "auto":
            method = "direct" if num_dofs <= options.direct_limit else "iterative"
        self.linear_solver = LinearSolver(self.comm, method)
        self._near_nullspace = (reduction.near_nullspace(solid.V.tabulate_dof_coordinates())
                                if method == "iterative" else None)

        self._active = None  # frozen contact set of the surface nodes, or None
        self._hold_height = False  # displacement control of the current step
        # Reduced rows of the owned surface nodes and the reduced nodes of their 25 neighbours
        # on the periodic surface grid (the columns of the contact tangent).
        n = flat.grid_size
        node_reduced = flat.gather_nodes(reduction.reduced_node[flat.nodes])
        i, j = np.divmod(flat.owned_grid, n)
        neighbours = (((i[:, None] + NEIGHBOURS[:, 0]) % n) * n
                      + (j[:, None] + NEIGHBOURS[:, 1]) % n)
        self._contact_rows = (3 * node_reduced[flat.owned_grid][:, None]
                              + np.arange(3)).astype(PETSc.IntType)
        self._contact_columns = node_reduced[neighbours].astype(PETSc.IntType)
        self._owned_position = np.full(n * n, -1)  # grid node -> owned surface node, or -1
        self._owned_position[flat.owned_grid] = np.arange(len(flat.owned_grid))

    # --- assembly -------------------------------------------------------------------------

    def assemble(self, flat_slide: float, friction: bool, predictor: bool = False
                 ) -> ContactResponse:
        """Stress update, residual R and b = dR/dh at the current iterate
        (``predictor``: the tangential predictor of :meth:`RigidFlat.respond`). The tangent is
        assembled separately (:meth:`assemble_tangent`), only where a linear solve needs it:
        line-search trials need the residual alone."""
        solid = self.solid
        self.reduction.expand(self.displacement, solid.displacement)
        solid.update_stress()
        with self._residual_full.localForm() as local:
            local.set(0.0)
        for form in solid.residual_forms:
            fem_petsc.assemble_vector(self._residual_full, form)
        self._residual_full.ghostUpdate(PETSc.InsertMode.ADD_VALUES, PETSc.ScatterMode.REVERSE)
        self.reduction.restrict(self._residual_full, self.residual)

        contact = self.flat.respond(solid.displacement.x.array.reshape(-1, 3),
                                    self.flat_height, flat_slide, friction, predictor,
                                    self._active)
        owned = self.flat.owned_grid
        self.residual.setValues(self._contact_rows.ravel(), contact.node_force[owned].ravel(),
                                addv=PETSc.InsertMode.ADD_VALUES)
        self.residual.assemble()
        self._height_column.set(0.0)
        height_derivative = contact.node_height_derivative[owned]
        self._height_column.setValues(self._contact_rows.ravel(), height_derivative.ravel())
        self._height_column.assemble()
        self._force_row.set(0.0)  # r = sum p a - F_n: dr/du_z = eps a = -dR_z/dh
        self._force_row.setValues(self._contact_rows[:, 2], -height_derivative[:, 2])
        self._force_row.assemble()
        return contact

    def assemble_tangent(self, contact: ContactResponse) -> None:
        """K = P^T K_elastic P + P^T K_plastic P plus the contact's 3 x 3 blocks of each surface
        node and its 25 neighbours, at the iterate of the last :meth:`assemble` (whose
        ``contact`` response is passed).

        The reduced elastic part is built once, in a matrix with the contact's pattern as well
        (:meth:`_system_matrix`), and copied at each assembly. While few cells yield
        (``WHOLE_MESH_YIELDING``), the plastic correction is assembled and reduced on their
        couplings alone and added row by row; else the whole tangent is reduced on the whole
        mesh. The blocks of the nodes that touch are added row by row.
        """
        if self.tangent is None:
            elastic = self.reduction.reduce_matrix(self._elastic_tangent)
            self._elastic_system = self._system_matrix(elastic)
            self._elastic_system.axpy(1.0, elastic,
                                      structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            elastic.destroy()
            self.tangent = self._elastic_system.duplicate(copy=False)
            if self._near_nullspace is not None:
                self.tangent.setNearNullSpace(self._near_nullspace)
        plastic = self.solid.plastic_tangent_form()
        if plastic is not None and self.solid.yielding_fraction() > WHOLE_MESH_YIELDING:
            self._reduce_whole_mesh(plastic)
        else:
            self._elastic_system.copy(self.tangent,
                                      structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
            if plastic is not None:
                self._add_plastic_correction(plastic)
        self._add_node_blocks(self.tangent, *contact.node_blocks)
        self.tangent.assemble()
        self._symmetric = self.comm.allreduce(contact.symmetric, op=MPI.LAND)
        self._coupled = self.comm.allreduce(contact.coupled, op=MPI.LOR)
        if not self._symmetric:
            self._assemble_uncoupled_tangent(contact)

    def _add_node_blocks(self, matrix: PETSc.Mat, nodes: np.ndarray, blocks: np.ndarray,
                         scale: float = 1.0) -> None:
        """Add ``scale`` times the contact's 3 x 3 ``blocks`` [N/m] of the surface ``nodes``
        (grid nodes) and their 25 neighbours to ``matrix``: one block row (3 x 75 values,
        row-major) per owned node."""
        owned = self._owned_position[nodes]
        touching = owned >= 0
        if np.any(touching):
            owned = owned[touching]
            matrix.setValuesBlockedRCV(
                self._contact_rows[owned, :1] // 3, self._contact_columns[owned],
                scale * blocks[touching].transpose(0, 2, 1, 3).reshape(len(owned), -1),
                addv=PETSc.InsertMode.ADD_VALUES)

    def _assemble_uncoupled_tangent(self, contact: ContactResponse) -> None:
        """The preconditioning matrix of a non-symmetric tangent: the tangent without the
        ramp's coupling dt/dp (:attr:`ContactResponse.coupling_blocks`), i.e. the symmetric
        positive definite tangent of :attr:`RigidFlat.symmetric_tangent`."""
        if self._uncoupled_tangent is None:
            self._uncoupled_tangent = self.tangent.duplicate(copy=True)
            if self._near_nullspace is not None:
                self._uncoupled_tangent.setNearNullSpace(self._near_nullspace)
        else:
            self.tangent.copy(self._uncoupled_tangent,
                              structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        self._add_node_blocks(self._uncoupled_tangent, *contact.coupling_blocks, scale=-1.0)
        self._uncoupled_tangent.assemble()

    def _set_operator(self) -> None:
        """Hand the last assembled tangent to the linear solver, with the uncoupled tangent to
        build the preconditioner from if it is not symmetric."""
        self.linear_solver.set_operator(
            self.tangent, self._symmetric,
            preconditioning=None if self._symmetric else self._uncoupled_tangent)

    def _add_plastic_correction(self, plastic) -> None:
        """Add P^T K_plastic P to the tangent, assembled and reduced on the couplings of the
        yielding cells (the ``plastic`` form's cells) alone, row by row."""
        correction = fem_petsc.assemble_matrix(plastic)
        correction.assemble()
        reduced = self.reduction.reduce_matrix(correction)
        row_pointer, columns, values = reduced.getValuesCSR()
        rows = np.flatnonzero(np.diff(row_pointer))
        if len(rows):  # (petsc4py divides by the number of values)
            self.tangent.setValuesIJV(
                np.append(row_pointer[rows], row_pointer[-1]), columns, values,
                addv=PETSc.InsertMode.ADD_VALUES,
                rowmap=(rows + reduced.getOwnershipRange()[0]).astype(PETSc.IntType))
        correction.destroy()
        reduced.destroy()

    def _reduce_whole_mesh(self, plastic) -> None:
        """Set the tangent to P^T (K_elastic + K_plastic) P, assembled and reduced on the whole
        mesh (matrices kept, P^T K P's pattern reused)."""
        if self._tangent_full is None:
            self._tangent_full = self._elastic_tangent.duplicate(copy=True)
        else:
            self._elastic_tangent.copy(self._tangent_full,
                                       structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        fem_petsc.assemble_matrix(self._tangent_full, plastic)
        self._tangent_full.assemble()
        self._solid_tangent = self.reduction.reduce_matrix(self._tangent_full,
                                                           self._solid_tangent)
        self.tangent.zeroEntries()
        self.tangent.axpy(1.0, self._solid_tangent,
                          structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)

    def _system_matrix(self, solid: PETSc.Mat) -> PETSc.Mat:
        """A zero matrix with the nonzeros of ``solid`` (P^T K P) and of the contact blocks: the
        rows of each owned surface node gain the columns of its 25 neighbours."""
        start, end = solid.getOwnershipRange()
        row_pointer, columns, _ = solid.getValuesCSR()
        rows = np.repeat(np.arange(end - start), np.diff(row_pointer))
        contact_rows = self._contact_rows - start  # (m, 3)
        if np.any((contact_rows < 0) | (contact_rows >= end - start)):
            raise RuntimeError("a surface node's reduced rows are owned by another rank")
        contact_columns = (3 * self._contact_columns[:, :, None] + np.arange(3)).reshape(
            len(contact_rows), 1, -1)  # (m, 1, 75)
        rows = np.concatenate([rows, np.broadcast_to(
            contact_rows[:, :, None], (len(contact_rows), 3, contact_columns.shape[2])).ravel()])
        columns = np.concatenate([columns, np.broadcast_to(
            contact_columns, (len(contact_rows), 3, contact_columns.shape[2])).ravel()])
        size = solid.getSize()[1]
        pairs = np.unique(rows.astype(np.int64) * size + columns)
        rows, columns = np.divmod(pairs, size)
        row_pointer = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=end - start))])
        matrix = PETSc.Mat().createAIJ(
            solid.getSizes(), bsize=solid.getBlockSize(), comm=self.comm,
            csr=(row_pointer.astype(PETSc.IntType), columns.astype(PETSc.IntType),
                 np.zeros(len(columns))))
        matrix.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        return matrix

    # --- Newton -----------------------------------------------------------------------------

    def solve(self, normal_force: float, flat_slide: float, friction: bool,
              hold_height: bool = False, predictor: bool = True, marks_path: bool = False,
              exact_tangent: bool = False) -> NewtonReport:
        """One load step: Newton solves with Uzawa updates of the contact multipliers until no
        contact node penetrates deeper than the tolerance.

        Parameters
        ----------
        normal_force : float
            F_n to hold [N]; with ``hold_height``, only the force scale of the tolerances.
        flat_slide : float
            Flat's x displacement U [m].
        friction : bool
            Frictional contact (tangential phase) or frictionless (preload).
        hold_height : bool
            Keep the flat at its current height h (displacement control: one linear solve per
            Newton iteration, and no limit point while a few yielding peaks carry the flat)
            instead of solving for the h that carries ``normal_force``.
        predictor : bool
            A tangential step's first solve starts with the tangential predictor (False: the
            caller has placed a first iterate, :meth:`extrapolate`).
        marks_path : bool
            The step only marks the loading path to the state that is reported (a preload step
            that sliding follows, a sliding step before inception): it ends at the looser
            Newton tolerances of the solves between Uzawa updates, after one solve: if a node
            penetrates deeper than the tolerance (but within ``CARRIED_PENETRATION`` times it),
            the multipliers are updated and the update is carried into the next step, whose
            first solve absorbs it, instead of a re-solve here.
        exact_tangent : bool
            Newton starts with the exact tangent instead of the symmetric one (:meth:`_newton`).
        """
        self._hold_height = hold_height
        options = self.options
        tolerance = options.penetration_tolerance * self.spacing
        tight = (options.residual_tolerance, options.increment_tolerance)
        tolerances = (max(tight[0], UZAWA_RESIDUAL_TOLERANCE),
                      max(tight[1], UZAWA_INCREMENT_TOLERANCE))
        if marks_path:
            tight = tolerances
        iterations = krylov = updates = solves = 0
        carried = False  # the last update is left to the next step
        while True:
            # the tangential predictor belongs to the first solve of a step only
            report = self._newton(normal_force, flat_slide, friction,
                                  predictor and friction and solves == 0, *tolerances,
                                  exact_tangent)
            solves += 1
            iterations += report.iterations
            krylov += report.krylov_iterations
            penetration = self.flat.penetration(report.contact)
            if not report.converged:
                break
            if penetration <= tolerance:
                if tolerances == tight:
                    break
                tolerances = tight  # the multipliers are good: solve to the tolerances
                continue
            if updates == options.max_augmentations:
                break
            self.flat.augment(report.contact)
            updates += 1
            carried = marks_path and penetration <= CARRIED_PENETRATION * tolerance
            if carried:
                break  # the next step's solve absorbs the update (commit keeps it)
        reason = report.reason
        if report.converged and penetration > tolerance and not carried:
            reason = (f"penetration {penetration / self.spacing:.2e} h > tolerance "
                      f"{options.penetration_tolerance:.0e} h after "
                      f"{options.max_augmentations} multiplier updates")
        return NewtonReport(not reason, iterations, krylov, report.residual, report.contact,
                            reason)

    def _newton(self, normal_force: float, flat_slide: float, friction: bool,
                predictor: bool, residual_tolerance: float, increment_tolerance: float,
                exact_tangent: bool) -> NewtonReport:
        """Newton iterations from the current iterate with fixed multipliers (``predictor``:
        start with the tangential predictor of :meth:`RigidFlat.respond`) until ||R||, |r| <=
        ``residual_tolerance`` F_n and max |du| <= ``increment_tolerance`` h; other arguments as
        in :meth:`solve`.

        The iterations start with the symmetric tangent (:attr:`RigidFlat.symmetric_tangent`:
        CG, and no stick/slip cycling driven by the cap's ramp) and go on with the exact one if
        they stagnate or reach the iteration limit while slipping points sit on the ramp (the
        symmetric tangent then converges only linearly); with ``exact_tangent`` they start with
        the exact one. Where the exact tangent says that lowering the flat would unload it
        (dr/dh >= 0: singular, through the ramp's coupling, whose friction coefficient
        tau_c / p_r is far above 1), that Newton step is taken with the symmetric one."""
        tolerance_force = residual_tolerance * normal_force
        tolerance_increment = increment_tolerance * self.spacing
        # the forcing term's safeguard for the iterative method only: CG on reused Cholesky
        # factors gains nothing from it, and its Newton path then stays the same on any number
        # of ranks to round-off (GAMG's aggregates depend on the partition anyway)
        safeguarded = residual_tolerance if self.linear_solver.method == "iterative" else 0.0
        self._active = None
        self.flat.symmetric_tangent = not exact_tangent
        state = self._evaluate(normal_force, flat_slide, friction, predictor)
        increment, krylov = 0.0, 0
        cut = False  # the last line search cut the Newton step
        singular = False  # the exact tangent was singular at this iterate
        settles_on_kink = residual_tolerance < UZAWA_RESIDUAL_TOLERANCE  # (RESIDUAL_FLOOR)
        history = []
        rounds, changes, limit = 0, np.inf, self.options.max_iterations
        reason = ""

        def where(state: _Iterate) -> str:
            return (f"residual {state.residual / normal_force:.1e} F_n, force error "
                    f"{abs(state.force_error) / normal_force:.1e} F_n, last increment "
                    f"{increment / self.spacing:.1e} h")

        def forces_met(state: _Iterate, factor: float = 1.0) -> bool:
            return (state.residual <= factor * tolerance_force
                    and abs(state.force_error) <= factor * tolerance_force)

        def converged(state: _Iterate, factor: float = 1.0) -> bool:
            return (not predictor and forces_met(state, factor)
                    and increment <= factor * tolerance_increment)

        for iteration in itertools.count():
            if converged(state) and self._active is not None:
                # converged with a frozen set: judge the iterate by the contact law itself (nodes
                # that flip at a negligible force no longer cycle), else re-freeze at the law's
                # set there for a new round while the set settles
                frozen, self._active = self._active, None
                state = self._evaluate(normal_force, flat_slide, friction, predictor=False)
                if not converged(state):
                    previous, changes = changes, self.flat.count(
                        state.contact.node_active != frozen)
                    if changes >= previous or rounds == MAX_ROUNDS:
                        reason = (f"contact set cycling ({changes} nodes change state after "
                                  f"{rounds} frozen round(s))")
                        break
                    self._active = state.contact.node_active
                    rounds += 1
                    limit = iteration + self.options.max_iterations
                    history.clear()
            if converged(state) and self._active is None:
                return NewtonReport(True, iteration, krylov, state.residual / normal_force,
                                    state.contact)
            history.append(state.residual + abs(state.force_error))
            stagnating = (len(history) > STAGNATION_WINDOW + 2
                          and history[-1] > 0.5 * history[-1 - STAGNATION_WINDOW])
            if not np.isfinite(state.merit):
                reason = "residual not finite"
                break
            if stagnating or ((cut or forces_met(state)) and settles_on_kink
                              and converged(state, RESIDUAL_FLOOR)):
                frozen = self._active
                if frozen is not None:  # judge the floor under the contact law itself
                    self._active = None
                    state = self._evaluate(normal_force, flat_slide, friction, predictor=False)
                if converged(state, RESIDUAL_FLOOR):
                    return NewtonReport(True, iteration, krylov, state.residual / normal_force,
                                        state.contact)
                if not stagnating:  # above the floor under the law: the frozen round goes on
                    self._active = frozen
                    state = self._evaluate(normal_force, flat_slide, friction, predictor=False)
            if ((stagnating or iteration == limit) and self.flat.symmetric_tangent
                    and self._coupled and not singular):
                # slipping points on the cap's ramp: go on with the exact tangent
                self.flat.symmetric_tangent = False
                state = self._evaluate(normal_force, flat_slide, friction, predictor=False)
                history.clear()
                limit = iteration + self.options.max_iterations
                continue
            if stagnating:
                reason = (f"residual not halved in {STAGNATION_WINDOW} iterations (stick/slip "
                          f"or open/closed cycling; {where(state)})")
                break
            if iteration == limit:
                reason = f"iteration limit {self.options.max_iterations} ({where(state)})"
                break
            if self.flat.count(state.contact.node_active) == 0 and not self._hold_height:
                self.place_flat(normal_force)
                state = self._evaluate(normal_force, flat_slide, friction, predictor)
                increment = np.inf
                continue
            if iteration == FREEZE_AFTER and self._active is None:
                self._active = state.contact.node_active
                rounds = 1
                history.clear()  # the frozen problem's residuals start their own record
            self.assemble_tangent(state.contact)
            try:
                height_increment, its = self._bordered_solve(
                    state.force_error, forcing_term(state, normal_force, safeguarded))
            except LinearSolveError as error:
                reason = str(error)
                break
            krylov += its
            if not (self._hold_height or self._symmetric) and self._height_slope() >= 0.0:
                # lowering the flat would unload it: the exact tangent is singular here (the
                # ramp's coupling); this Newton step is taken with the symmetric one instead
                self.flat.symmetric_tangent, singular = True, True
                state = self._evaluate(normal_force, flat_slide, friction, predictor=False)
                continue
            step, state = self._line_search(height_increment, state, normal_force,
                                            flat_slide, friction, full_step=predictor)
            increment = step * self._x1.norm(PETSc.NormType.NORM_INFINITY)
            cut = step < 1.0
            predictor = False
            if singular:  # back to the exact tangent
                self.flat.symmetric_tangent, singular = False, False
                state = self._evaluate(normal_force, flat_slide, friction, predictor=False)
            if self._active is not None:  # nodes that entered contact stay in this round
                self._active = state.contact.node_active
        self._active = None
        return NewtonReport(False, iteration, krylov, state.residual / normal_force, state.contact,
                            reason)

    def _evaluate(self, normal_force: float, flat_slide: float, friction: bool,
                  predictor: bool) -> _Iterate:
        """Assemble at the current iterate and measure its residuals."""
        contact = self.assemble(flat_slide, friction, predictor)
        force_error = 0.0 if self._hold_height else self.flat.normal_force(contact) - normal_force
        return _Iterate(contact, self.residual.norm(), force_error)

    def _bordered_solve(self, force_error: float, tolerance: float) -> tuple[float, int]:
        """Solve the bordered Newton system to the relative ``tolerance``: du into x1; return
        (dh [m], Krylov iterations). With the height held, K du = -R alone (dh = 0).

        du = x1 + dh x2 with K x1 = -R and K x2 = -b, so x2's residual enters du's times dh:
        x2 is solved again, tighter, until dh ||K x2 + b|| <= ``tolerance`` (||R|| + |r|)
        (||b|| dh, the force of moving the flat, can be far above them near convergence)."""
        c = self._force_row
        self._set_operator()
        self.residual.scale(-1.0)
        krylov = self.linear_solver.solve(self.residual, self._x1, relative_tolerance=tolerance)
        self.residual.scale(-1.0)  # R again, for the line search
        if self._hold_height:
            return 0.0, krylov
        allowed = (tolerance * (self.residual.norm() + abs(force_error))
                   / self._height_column.norm())  # bound on dh x x2's relative tolerance
        height_tolerance = tolerance
        while True:
            krylov += self._solve_height_column(height_tolerance)
            height_increment = -(force_error + c.dot(self._x1)) / self._height_slope()
            if (abs(height_increment) * height_tolerance <= allowed
                    or height_tolerance <= FORCING_MIN):
                break
            height_tolerance = max(FORCING_MIN, 0.5 * allowed / abs(height_increment))
        self._x1.axpy(height_increment, self._x2)
        return height_increment, krylov

    def _line_search(self, height_increment: float, current: _Iterate, normal_force: float,
                     flat_slide: float, friction: bool, full_step: bool) -> tuple[float, _Iterate]:
        """Apply the Newton step (du in x1, dh) with the step length of :func:`line_search_step`.

        Frictionless, the step problem minimises a convex energy of (u, h): the solid's
        incremental J2 potential, the penalty's and F_n h. R and -r are its gradient, and
        s(a) = du.R(a) - dh r(a) its slope along the step, which grows with a. Contact and yield
        make it only piecewise smooth: a full step that pushes open nodes into the flat or
        unloads yielding points overshoots, and the root of s is where the energy is least.
        With friction s is the same projection of the residual (a heuristic: slip dissipates),
        used while the tangent is the symmetric one. With the exact tangent (slipping points
        whose cap follows their pressure), or where the energy does not descend along the step
        (s(0) >= 0), the step is halved while ||R||^2 + r^2 grows. The tangential
        predictor's step is always taken (its residual is not comparable). Returns the accepted
        step length and the iterate there.
        """
        position, state = 0.0, current

        def slope(step: float) -> float:
            nonlocal position, state
            self.displacement.axpy(step - position, self._x1)
            self.flat_height += (step - position) * height_increment
            position = step
            state = self._evaluate(normal_force, flat_slide, friction, predictor=False)
            if not np.isfinite(state.merit):
                return np.inf
            return self._x1.dot(self.residual) - height_increment * state.force_error

        if full_step:
            slope(1.0)
            return 1.0, state
        initial_slope = self._x1.dot(self.residual) - height_increment * current.force_error
        if initial_slope < 0.0 and (not friction or self.flat.symmetric_tangent):
            return line_search_step(slope, initial_slope), state
        step = 1.0
        slope(step)
        for _ in range(LINE_SEARCH_TRIALS):
            if state.merit < current.merit:
                break
            step *= 0.5
            slope(step)
        return step, state

    def path_slope(self) -> float:
        """dF_n/dh along the frictionless equilibrium path at the current, converged iterate
        [N/m] (< 0: lowering the flat loads it): residual, b, c and tangent assembled there,
        one linear solve K du/dh = -b, c.du/dh + d. du/dh is kept for :meth:`follow_path`."""
        self.assemble_tangent(self.assemble(0.0, friction=False))
        self._set_operator()
        self._solve_height_column(PATH_SLOPE_TOLERANCE)
        if self._path_tangent is None:
            self._path_tangent = self._x2.duplicate()
        self._x2.copy(self._path_tangent)
        return self._height_slope()

    def _solve_height_column(self, tolerance: float) -> int:
        """x2 = du/dh = -K^-1 b to the relative ``tolerance``, warm-started (x2 changes little
        from one iterate to the next); return the Krylov iterations."""
        b = self._height_column
        b.scale(-1.0)
        krylov = self.linear_solver.solve(b, self._x2, warm_start=True,
                                          relative_tolerance=tolerance)
        b.scale(-1.0)
        return krylov

    def _height_slope(self) -> float:
        """dr/dh along the solution: c.x2 + d with d = dr/dh = -sum c [N/m]."""
        c = self._force_row
        return c.dot(self._x2) - c.sum()

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

    def destroy(self) -> None:
        """Free this model's PETSc objects (matrices, vectors, the KSP, P): petsc4py 3.18 does
        not free objects that reference each other, so a batch of runs in one process would
        keep every finished run's memory. The model is unusable afterwards."""
        committed = [self._committed[0]] + ([self._previous[0]] if self._previous else [])
        for item in (self.displacement, *committed, self._elastic_tangent, self._elastic_system,
                     self._tangent_full, self._solid_tangent, self._residual_full, self.tangent,
                     self._uncoupled_tangent, self.residual,
                     self._height_column, self._force_row, self._x1, self._x2,
                     self._path_tangent, self._near_nullspace):
            if item is not None:
                item.destroy()
        self.linear_solver.destroy()
        self.reduction.destroy()

    # --- history ----------------------------------------------------------------------------

    def commit(self, contact: ContactResponse) -> None:
        """Accept the current iterate as a converged step."""
        self.solid.commit()
        self.flat.commit(contact)
        self._previous = self._committed
        self._committed = (self.displacement.copy(), self.flat_height)

    def extrapolate(self, ratio: float) -> None:
        """First iterate of the next step: the last two converged steps extrapolated linearly,
        u = u_c + ratio (u_c - u_p) and the same for h, where ``ratio`` is the next load
        increment over the last one [-]: the step's contact and slip sets then start close to
        their final ones. The caller says when the last two steps belong to one monotonic path
        (:meth:`resume` forgets the older one)."""
        (displacement, height), (older, older_height) = self._committed, self._previous
        displacement.copy(self.displacement)
        self.displacement.axpy(ratio, displacement)
        self.displacement.axpy(-ratio, older)
        self.flat_height = height + ratio * (height - older_height)

    def committed_state(self) -> tuple:
        """Everything a converged step leaves behind (displacement, flat height, plastic
        history, contact history), to branch several loadings from one state."""
        displacement, height = self._committed
        return (displacement.copy(), height, self.solid.committed, self.flat.committed)

    def resume(self, state: tuple) -> None:
        """Return to a :meth:`committed_state` (it stays valid for further resumes)."""
        displacement, height, self.solid.committed, flat_state = state
        self._committed = (displacement.copy(), height)
        self._previous = None
        self.flat.resume(flat_state)
        self.restore()

    def restore(self) -> None:
        """Return to the last committed step (after a failed step)."""
        displacement, self.flat_height = self._committed
        displacement.copy(self.displacement)
        self.flat.restore()
        self.reduction.expand(self.displacement, self.solid.displacement)
