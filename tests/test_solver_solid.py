"""The solid's forms: residual and tangent agree; periodic reduction is exact."""

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from dolfinx.fem import petsc as fem_petsc  # noqa: E402
from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402
from roughfriction.geometry.adaptive import hanging_masters  # noqa: E402
from roughfriction.geometry.mesh import MeshOptions  # noqa: E402
from roughfriction.material import Material  # noqa: E402
from roughfriction.solver import solid as solid_module  # noqa: E402
from roughfriction.solver.block import build_block  # noqa: E402
from roughfriction.solver.memory import block_size  # noqa: E402
from roughfriction.solver.periodic import PeriodicReduction, dof_node_grid_index  # noqa: E402
from roughfriction.solver.plasticity import radial_return, von_mises  # noqa: E402
from roughfriction.solver.solid import Solid  # noqa: E402

pytestmark = pytest.mark.fem


#: 4 full-resolution layers over one 2:1 coarsened level (on 8 x 8 cells).
ONE_LEVEL = MeshOptions(blend_layers=4, fine_layers=4)


@pytest.fixture(scope="module")
def block():
    """An 8 x 8 block with one 2:1 coarsened level under 4 full-resolution layers."""
    heights = np.random.default_rng(0).normal(0.0, 0.1e-6, (8, 8))
    return build_block(heights, 1e-6, ONE_LEVEL, MPI.COMM_WORLD)


def assemble(solid):
    residual = fem_petsc.create_vector(solid.residual_forms[0])
    for form in solid.residual_forms:
        fem_petsc.assemble_vector(residual, form)
    residual.ghostUpdate(PETSc.InsertMode.ADD_VALUES, PETSc.ScatterMode.REVERSE)
    tangent = fem_petsc.create_matrix(solid.elastic_tangent_forms[0])
    plastic = (solid.plastic_tangent_forms_on(solid.yielding_cells())[0]
               if solid.yielding_fraction() > 0.0 else None)
    for form in solid.elastic_tangent_forms + ((plastic,) if plastic else ()):
        fem_petsc.assemble_matrix(tangent, form)
    tangent.assemble()
    return residual, tangent


@pytest.mark.parametrize("integration", ["selective", "full"])
def test_elastic_residual_is_the_tangent_times_the_displacement(block, integration):
    """R(u) = K u for a linear solid: the deviatoric (8-point) and pressure (1-point) parts of
    residual and tangent use the same rules. (One form mixing both rules is assembled wrongly by
    FFCx 0.5: R and K u then differ by 0.4 %.)"""
    solid = Solid(block.mesh, Material(), elastic=True, integration=integration)
    solid.displacement.x.array[:] = np.random.default_rng(1).normal(
        0.0, 1e-8, solid.displacement.x.array.shape)
    solid.update_stress()
    residual, tangent = assemble(solid)
    product = residual.duplicate()
    tangent.mult(solid.displacement.vector, product)
    product.axpy(-1.0, residual)
    assert product.norm() <= 1e-12 * residual.norm()


def test_plastic_tangent_is_the_derivative_of_the_residual(block):
    """Elastic tangent (assembled once) + plastic correction (yielding cells only) = dR/du: a
    central difference of R along a random direction matches K w where part of the block has
    yielded. A wrong correction, or one bound to the wrong cells, fails this."""
    material = Material()
    solid = Solid(block.mesh, material)
    x = solid.V.tabulate_dof_coordinates()
    z = x[:, 2] / block.depth  # 0 at the mean plane, -1 at the bottom
    u = solid.displacement.x.array.reshape(-1, 3)
    u[:, 0] = 4.0 * material.Sy / material.shear_modulus * block.depth * z**2  # shear ~ |z|
    base = solid.displacement.x.array.copy()
    direction = np.random.default_rng(3).normal(0.0, 1.0, base.shape)
    step = 1e-7 * np.abs(base).max()

    def residual_at(values):
        solid.displacement.x.array[:] = values
        solid.update_stress()
        return assemble(solid)

    residual_plus, _ = residual_at(base + step * direction)
    residual_minus, _ = residual_at(base - step * direction)
    _, tangent = residual_at(base)
    yielding = solid.yielding.mean()
    assert 0.1 < yielding < 0.9, f"test needs a partly plastic block, yielding {yielding:.2f}"
    product = residual_plus.duplicate()
    solid.displacement.x.array[:] = direction
    tangent.mult(solid.displacement.vector, product)
    difference = residual_plus.copy()
    difference.axpy(-1.0, residual_minus)
    difference.scale(1.0 / (2.0 * step))
    difference.axpy(-1.0, product)
    assert difference.norm() <= 1e-5 * product.norm()


def _numpy_bytes(*items) -> int:
    """Bytes of the NumPy arrays among ``items`` and the fields of the dataclasses among them."""
    total = 0
    for item in items:
        if isinstance(item, np.ndarray):
            total += item.nbytes
        elif hasattr(item, "__dataclass_fields__"):
            total += _numpy_bytes(*vars(item).values())
    return total


def test_the_solid_keeps_the_stress_and_tangent_factors_once(block, monkeypatch):
    """A stress update with yielding points, return-mapped 5 cells at a time, gives the trial
    history, yielding points and quadrature values of one return map of all points; the
    solid's own NumPy arrays then hold no more than the trial and committed history at the
    yielded points (10 doubles and an int64 index each), and per Gauss point the yielding
    flag and two int32 indices (and one int32 per cell): stress deviator, flow direction and
    tangent factors live in the quadrature functions the forms read, not a second time in
    NumPy, and the history of points that never yielded is not stored."""
    monkeypatch.setattr(solid_module, "CELLS_AT_ONCE", 5)
    material = Material()
    solid = Solid(block.mesh, material)
    x = solid.V.tabulate_dof_coordinates()
    u = solid.displacement.x.array.reshape(-1, 3)
    u[:, 0] = 4.0 * material.Sy / material.shear_modulus * block.depth * (x[:, 2] / block.depth)**2
    solid.update_stress()
    whole = radial_return(solid._strain_deviator.eval(solid._cells).reshape(-1, 3, 3),
                          solid.committed.dense(), material)
    assert whole.yielding.any() and solid.num_cells > 5
    np.testing.assert_array_equal(solid.yielding, whole.yielding)
    trial = solid.trial_state.dense()
    np.testing.assert_array_equal(trial.plastic_strain, whole.state.plastic_strain)
    np.testing.assert_array_equal(trial.equivalent_plastic_strain,
                                  whole.state.equivalent_plastic_strain)
    np.testing.assert_array_equal(solid.gamma.x.array[solid._scalar_dofs], whole.gamma)
    q = von_mises(whole.stress_deviator)
    np.testing.assert_array_equal(
        solid.cell_von_mises(), q.reshape(solid.num_cells, solid.num_points).mean(axis=1))
    points = solid.num_cells * solid.num_points
    yielded = np.count_nonzero(whole.state.equivalent_plastic_strain)
    assert yielded < points
    budget = 2 * yielded * (80 + 8) + points * (1 + 2 * 4) + solid.num_cells * 4
    assert _numpy_bytes(*vars(solid).values()) <= budget


def random_reduced_field(block):
    """P times a random reduced vector: (reduction, nodal displacements (m, 3), grid index)."""
    solid = Solid(block.mesh, Material(), elastic=True)
    reduction = PeriodicReduction(solid.V, block)
    reduced = reduction.create_reduced_vector()
    reduced.setRandom()
    reduction.expand(reduced, solid.displacement)
    return (reduction, solid.displacement.x.array.reshape(-1, 3),
            dof_node_grid_index(solid.V, block))


def test_periodic_images_share_displacements_and_the_bottom_is_fixed(block):
    reduction, u, grid = random_reduced_field(block)
    n = block.n
    key = ((grid[:, 2] * n + grid[:, 0] % n) * n + grid[:, 1] % n)
    images = {}
    for node, k in enumerate(key):
        images.setdefault(k, []).append(node)
    for nodes in images.values():
        assert np.array_equal(u[nodes], np.broadcast_to(u[nodes[0]], u[nodes].shape))
    assert np.all(u[grid[:, 2] == 0] == 0.0)
    # above the bottom, a node layer's own dofs sit at the spacing of the cell layer below it
    assert reduction.num_reduced_global == sum((n // stride) ** 2 for stride in block.layer_stride)
    # the size estimate used to refuse oversized runs counts the same, without a mesh
    cells, dofs = block_size(block.layout)
    assert (cells, dofs) == (block.mesh.topology.index_map(3).size_global,
                             3 * reduction.num_reduced_global)


def test_hanging_nodes_follow_the_coarse_faces_bilinearly(block):
    """Every node's displacement is the weighted sum of its masters' (itself, or the corners of
    the coarse face it hangs on): the coarse and fine cells meet without gap or overlap."""
    assert set(block.layer_stride) == {1, 2}
    reduction, u, grid = random_reduced_field(block)
    n = block.n
    position = {(i % n, j % n, k): node for node, (i, j, k) in enumerate(grid)}
    masters, weights = hanging_masters(grid, block.cells)
    hanging = np.flatnonzero(weights[:, 0] < 1.0)
    # the fine grid of the interface layer less the coarse corners, periodic images included
    assert MPI.COMM_WORLD.allreduce(len(hanging)) == (n + 1) ** 2 - (n // 2 + 1) ** 2
    checked = 0
    for node in hanging:
        corners = [position.get((i % n, j % n, k)) for i, j, k in masters[node]]
        if None in corners:
            continue  # a master not on this rank
        expected = (weights[node, :, None] * u[corners]).sum(axis=0)
        np.testing.assert_allclose(u[node], expected, rtol=1e-12)
        checked += 1
    assert MPI.COMM_WORLD.allreduce(checked) > 0


def test_a_new_material_law_is_a_new_class(block):
    """The solid return-maps through its law (``solver.plasticity.MaterialLaw``): a law that
    yields nowhere (s = 2 G dev eps, beta = 1, gamma = 0), written as its own class, gives the
    residual of the elastic J2 solid, and J2 under the same strain yields where it does not."""
    from roughfriction.solver.plasticity import J2Response, J2State

    material = Material()

    class Hookean:
        def return_map(self, strain_deviator, committed):
            m = len(strain_deviator)
            return J2Response(2.0 * material.shear_modulus * strain_deviator,
                              J2State.virgin(m), np.ones(m), np.zeros(m),
                              np.zeros((m, 3, 3)), np.zeros(m, bool))

    residuals = []
    for solid in (Solid(block.mesh, material, law=Hookean()),
                  Solid(block.mesh, material, elastic=True), Solid(block.mesh, material)):
        x = solid.V.tabulate_dof_coordinates()
        u = solid.displacement.x.array.reshape(-1, 3)
        u[:, 0] = 4.0 * material.Sy / material.shear_modulus * block.depth * (
            x[:, 2] / block.depth)**2
        solid.update_stress()
        residuals.append(assemble(solid)[0].array.copy())
    assert solid.yielding.any()  # the J2 solid, last: it yields under this strain
    np.testing.assert_allclose(residuals[0], residuals[1], rtol=0,
                               atol=1e-12 * np.abs(residuals[1]).max())
    assert np.abs(residuals[2] - residuals[1]).max() > 1e-3 * np.abs(residuals[1]).max()
