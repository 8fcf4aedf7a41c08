"""The deformable solid: trilinear hexahedra, J2 plasticity at quadrature points, weak forms.

Selective reduced integration (SRI): the deviatoric stress (radial return) lives at the 2 x 2 x 2
Gauss points, the pressure K tr(eps) is integrated at the single cell-centre point. J2 does not
depend on pressure, so the split leaves the constitutive law unchanged and removes volumetric
locking of trilinear hexahedra under nearly isochoric plastic flow. ``integration="full"``
integrates the pressure at 2 x 2 x 2 points too (it locks; kept to show that it does).

Weak forms (u the displacement, v a test function, s the stress deviator from the return map)::

    R(u; v) = (s, eps(v))_8 + (K tr eps(u), tr eps(v))_q
    a(du, v) = (2 G dev eps(du), eps(v))_8 + (K tr eps(du), tr eps(v))_q     (elastic: once)
             + (2 G (beta - 1) dev eps(du) - 2 G gamma (n : eps(du)) n, eps(v))_8
                                                           (plastic correction: yielding cells)

with q = 1 (selective) or 8 (full) points.
"""

from __future__ import annotations

import basix
import numpy as np
import ufl
from dolfinx import fem
from dolfinx import mesh as dolfinx_mesh
from mpi4py import MPI
from roughfriction.material import Material
from roughfriction.solver.plasticity import (
    J2Plasticity,
    J2Response,
    MaterialLaw,
    PlasticHistory,
    von_mises,
)
from roughfriction.solver.stages import SOLID_SETUP, STRESS_UPDATE, stage

#: Quadrature degree of the 2 x 2 x 2 Gauss rule on hexahedra (basix: degree 2 and 3 give it).
DEVIATORIC_DEGREE = 2
#: Cells whose stress :meth:`Solid.update_stress` return-maps at once [-].
CELLS_AT_ONCE = 1024
#: Quadrature degree of the 1-point (cell-centre) rule.
VOLUMETRIC_DEGREE = {"selective": 1, "full": DEVIATORIC_DEGREE}


def _point_dofs(space, num_cells: int, num_points: int) -> np.ndarray:
    """(Block) dofs of a quadrature space at the points of the owned cells, cell-major order."""
    return space.dofmap.list.array.reshape(-1, num_points)[:num_cells].ravel()


def strain(displacement):
    """Small strain eps(u) = sym grad u [-]."""
    return ufl.sym(ufl.grad(displacement))


class Solid:
    """Displacement field, quadrature-point plastic state and the residual/tangent forms.

    Parameters
    ----------
    mesh : dolfinx.mesh.Mesh
        Hexahedral mesh [m].
    material : Material
        Elastic constants and hardening [Pa].
    elastic : bool
        Linear elastic solid (no yield check).
    integration : {"selective", "full"}
        Pressure at 1 point (SRI) or at the 2 x 2 x 2 points.
    law : MaterialLaw, optional
        The deviatoric law at the Gauss points; default J2 plasticity of ``material``
        (:class:`solver.plasticity.J2Plasticity`, elastic if ``elastic``).

    Attributes
    ----------
    committed, trial_state : PlasticHistory
        Plastic history of the last converged step and of the last stress update (held at
        the yielded points only).
    yielding : numpy.ndarray
        Gauss points on the yield surface in the last stress update, bool.
    """

    @stage(SOLID_SETUP)
    def __init__(self, mesh, material: Material, elastic: bool = False,
                 integration: str = "selective", law: MaterialLaw | None = None):
        if integration not in VOLUMETRIC_DEGREE:
            raise ValueError(f"integration must be one of {sorted(VOLUMETRIC_DEGREE)}")
        self.material = material
        self.elastic = elastic
        self.law = law or J2Plasticity(material, elastic)
        self.V = fem.VectorFunctionSpace(mesh, ("Lagrange", 1))
        self.displacement = fem.Function(self.V, name="displacement")

        cell = mesh.ufl_cell()
        tensor_space = fem.FunctionSpace(mesh, ufl.TensorElement(
            "Quadrature", cell, degree=DEVIATORIC_DEGREE, quad_scheme="default"))
        scalar_space = fem.FunctionSpace(mesh, ufl.FiniteElement(
            "Quadrature", cell, degree=DEVIATORIC_DEGREE, quad_scheme="default"))
        self.stress_deviator = fem.Function(tensor_space, name="stress_deviator")
        self.flow_direction = fem.Function(tensor_space)
        self.beta = fem.Function(scalar_space)
        self.gamma = fem.Function(scalar_space)
        self.yielded = fem.Function(scalar_space)  # 1 where p > 0, for the plastic volume

        self.num_cells = mesh.topology.index_map(3).size_local
        self._cells = np.arange(self.num_cells, dtype=np.int32)
        points, _ = basix.make_quadrature(basix.CellType.hexahedron, DEVIATORIC_DEGREE)
        self.num_points = len(points)
        self._scalar_dofs = _point_dofs(scalar_space, self.num_cells, self.num_points)
        self._tensor_dofs = _point_dofs(tensor_space, self.num_cells, self.num_points)
        self._strain_deviator = fem.Expression(ufl.dev(strain(self.displacement)), points)

        self.committed = PlasticHistory.virgin(self.num_cells * self.num_points)
        self._return_map()  # of the zero displacement: the virgin state
        self._build_forms(mesh, material, integration)

    def _build_forms(self, mesh, material: Material, integration: str) -> None:
        """The volume, plastic-volume, residual and tangent forms of the solid."""
        dx_dev = ufl.dx(metadata={"quadrature_degree": DEVIATORIC_DEGREE,
                                  "quadrature_scheme": "default"})
        dx_vol = ufl.dx(metadata={"quadrature_degree": VOLUMETRIC_DEGREE[integration],
                                  "quadrature_scheme": "default"})
        self.volume = mesh.comm.allreduce(
            fem.assemble_scalar(fem.form(fem.Constant(mesh, 1.0) * dx_dev)), op=MPI.SUM)
        self._plastic_volume = fem.form(self.yielded * dx_dev)

        v = ufl.TestFunction(self.V)
        du = ufl.TrialFunction(self.V)
        shear, bulk = material.shear_modulus, material.bulk_modulus
        s, n = self.stress_deviator, self.flow_direction
        # One form per quadrature rule: FFCx 0.5 assembles a form whose integrals use different
        # quadrature degrees wrongly (measured: 37 % off on hexahedra), so the deviatoric
        # (2 x 2 x 2) and volumetric (1 point) parts are separate forms, assembled one after the
        # other into the same vector or matrix.
        self.residual_forms = (
            fem.form(ufl.inner(s, strain(v)) * dx_dev),
            fem.form(bulk * ufl.tr(strain(self.displacement)) * ufl.tr(strain(v)) * dx_vol),
        )
        # Tangent = elastic part (assembled once by the caller) + the plastic correction on the
        # cells with a yielding point (assembling the full tangent at every iteration cost more
        # than the linear solve).
        self._elastic_integrands = (
            (2.0 * shear * ufl.inner(ufl.dev(strain(du)), strain(v)), dx_dev.metadata()),
            (bulk * ufl.tr(strain(du)) * ufl.tr(strain(v)), dx_vol.metadata()),
        )
        self.elastic_tangent_forms = (fem.form(self._elastic_integrands[0][0] * dx_dev),
                                      fem.form(self._elastic_integrands[1][0] * dx_vol))
        self._mesh = mesh
        correction = (2.0 * shear * (self.beta - 1.0) * ufl.dev(strain(du))
                      - 2.0 * shear * self.gamma * ufl.inner(n, strain(du)) * n)
        self._plastic_integrands = ((ufl.inner(correction, strain(v)), dx_dev.metadata()),)

    def elastic_tangent_forms_on(self, cells: np.ndarray) -> tuple:
        """The elastic tangent's forms (one per quadrature rule) over the owned ``cells``."""
        return self._forms_on(self._elastic_integrands, cells)

    def plastic_tangent_forms_on(self, cells: np.ndarray) -> tuple:
        """The plastic correction of the consistent tangent,
        (2 G (beta - 1) dev eps(du) - 2 G gamma (n : eps(du)) n, eps(v)), over the owned
        ``cells`` (the tangent factors of the last stress update)."""
        return self._forms_on(self._plastic_integrands, cells)

    def _forms_on(self, integrands, cells: np.ndarray) -> tuple:
        """Forms of (integrand, quadrature metadata) pairs over the owned ``cells`` (sorted),
        compiled once and re-bound to the cells at each call (binding is ~1 ms)."""
        tags = dolfinx_mesh.meshtags(self._mesh, 3, np.asarray(cells, dtype=np.int32),
                                     np.ones(len(cells), dtype=np.int32))
        return tuple(
            fem.form(integrand * ufl.Measure("dx", domain=self._mesh, subdomain_data=tags,
                                             subdomain_id=1, metadata=metadata))
            for integrand, metadata in integrands)

    def yielding_cells(self) -> np.ndarray:
        """Owned cells with a yielding Gauss point in the last stress update (int32)."""
        if self._yielding_cells is None:
            yielding = self.yielding.reshape(self.num_cells, self.num_points).any(axis=1)
            self._yielding_cells = np.flatnonzero(yielding).astype(np.int32)
        return self._yielding_cells

    def yielding_fraction(self) -> float:
        """Fraction of all cells (every rank) with a yielding Gauss point in the last stress
        update [-]."""
        if self._yielding_fraction is None:
            self._yielding_fraction = (
                self._mesh.comm.allreduce(len(self.yielding_cells()), op=MPI.SUM)
                / self._mesh.topology.index_map(3).size_global)
        return self._yielding_fraction

    @stage(STRESS_UPDATE)
    def update_stress(self) -> None:
        """Return-map the current displacement from the committed state, ``CELLS_AT_ONCE``
        cells at a time (the map is pointwise; this bounds its working memory); fill the
        quadrature functions the forms read with stress and tangent factors, and keep the trial
        history and yielding points. The result is a trial: :meth:`commit` accepts it."""
        self._return_map()

    def _return_map(self) -> None:
        """:meth:`update_stress` (also of the virgin state at construction, outside the
        stress-update stage)."""
        committed, num_points = self.committed, self.num_points
        yielding = np.empty(committed.num_points, dtype=bool)
        parts = [PlasticHistory.virgin(committed.num_points)]
        for first in range(0, self.num_cells, CELLS_AT_ONCE):
            cells = self._cells[first:first + CELLS_AT_ONCE]
            points = slice(first * num_points, (first + len(cells)) * num_points)
            strain_deviator = self._strain_deviator.eval(cells).reshape(-1, 3, 3)
            response = self.law.return_map(strain_deviator,
                                           committed.dense(points.start, points.stop))
            self._write_quadrature(response, points)
            parts.append(PlasticHistory.of_block(committed.num_points, points.start,
                                                 response.state))
            yielding[points] = response.yielding
        self.trial_state = PlasticHistory.concatenate(parts)
        self.yielding = yielding
        self._yielding_cells = self._yielding_fraction = None

    def commit(self) -> None:
        """Accept the last stress update as the history of a converged step."""
        self.committed = self.trial_state

    def _write_quadrature(self, response: J2Response, points: slice) -> None:
        """Copy stress, tangent factors and the yielded flag of the Gauss ``points`` (of the
        owned cells, cell-major) into the quadrature functions."""
        tensor, scalar = self._tensor_dofs[points], self._scalar_dofs[points]
        for function, values in ((self.stress_deviator, response.stress_deviator),
                                 (self.flow_direction, response.flow_direction)):
            function.x.array.reshape(-1, 9)[tensor] = values.reshape(-1, 9)
        self.beta.x.array[scalar] = response.beta
        self.gamma.x.array[scalar] = response.gamma
        self.yielded.x.array[scalar] = response.state.equivalent_plastic_strain > 0.0

    def plastic_volume_fraction(self) -> float:
        """Volume fraction of the block with equivalent plastic strain p > 0 in the last
        stress update [-]."""
        local = fem.assemble_scalar(self._plastic_volume)
        return self.V.mesh.comm.allreduce(local, op=MPI.SUM) / self.volume

    def cell_von_mises(self) -> np.ndarray:
        """Von Mises stress averaged over each owned cell's Gauss points [Pa] (deviator only:
        q does not depend on pressure)."""
        stress_deviator = self.stress_deviator.x.array.reshape(-1, 9)[self._tensor_dofs]
        q = von_mises(stress_deviator.reshape(-1, 3, 3))
        return q.reshape(self.num_cells, self.num_points).mean(axis=1)

    def cell_plastic_strain(self) -> np.ndarray:
        """Equivalent plastic strain averaged over each owned cell's Gauss points [-]."""
        p = self.trial_state.dense().equivalent_plastic_strain
        return p.reshape(self.num_cells, self.num_points).mean(axis=1)
