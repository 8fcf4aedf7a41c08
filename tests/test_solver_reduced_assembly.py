"""solver.reduced_assembly: P^T K P assembled straight into the reduced unknowns."""

from dataclasses import replace

import numpy as np
import pytest
from roughfriction.case import FemCase, Loading, ZoneRefinement
from roughfriction.geometry.adaptive import cells_at_nodes
from roughfriction.geometry.surface import Surface
from roughfriction.solver.reduced_assembly import cell_masters, pair_keys

pytest.importorskip("dolfinx")
from dolfinx.fem import petsc as fem_petsc  # noqa: E402
from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402
from roughfriction.solver import reduced_assembly  # noqa: E402
from roughfriction.solver.block import build_block  # noqa: E402
from roughfriction.solver.periodic import PeriodicReduction  # noqa: E402
from roughfriction.solver.reduced_assembly import ReducedAssembler  # noqa: E402
from roughfriction.solver.solid import Solid  # noqa: E402


def test_a_cell_depends_on_the_distinct_masters_of_its_nodes():
    """Node 0 hangs on 4 masters, two of them other nodes of the cell; node 2 is fixed."""
    masters = np.full((8, 4), -1)
    masters[:, 0] = [10, 11, -1, 13, 14, 15, 16, 17]
    masters[0] = [11, 13, 20, 21]
    got = cell_masters(np.arange(8)[None, :], masters)
    assert got.shape == (1, 8)
    np.testing.assert_array_equal(got[0], [21, 20, 17, 16, 15, 14, 13, 11])


def test_pair_keys_skip_missing_nodes_and_repeats():
    keys = pair_keys(np.array([0, 0, -1, 2, 0]), np.array([1, 1, 3, -1, 2]), 5)
    np.testing.assert_array_equal(keys, [1, 2])


def _case(adaptive: bool) -> FemCase:
    """A random 8 x 8 surface, unrefined (hanging nodes where the layers below coarsen) or
    refined once around two nodes (hanging nodes in the surface zone too)."""
    heights = np.random.default_rng(11).normal(0.0, 0.08e-6, (8, 8))
    case = FemCase(Surface(heights, 1e-6, "assembly"), Loading(0.155))
    if not adaptive:
        return case
    contact = np.zeros((8, 8), bool)
    contact[[2, 5], [3, 6]] = True
    return replace(case, mesh=replace(case.mesh, refinement=ZoneRefinement(
        1, cells_at_nodes(contact, 1))))


def _assembled_both_ways(case: FemCase, comm, stride: int = 1) -> tuple:
    """(reduced assembly, MatPtAP of the full-dof K) of the elastic tangent over every
    ``stride``-th owned cell (all by default; else a matrix of those cells' couplings alone)."""
    surface = case.surface
    block = build_block(surface.heights, surface.spacing, case.mesh, comm)
    solid = Solid(block.mesh, case.material)
    reduction = PeriodicReduction(solid.V, block)
    assert comm.allreduce(int(reduction.hanging.sum()), op=MPI.SUM) > 0
    assembler = ReducedAssembler(solid.V, reduction)
    cells = np.arange(0, solid.num_cells, stride, dtype=np.int32)
    if stride == 1:
        direct = assembler.create_matrix(np.empty(0, int), np.empty(0, int))
        assembler.add(direct, solid.elastic_tangent_forms_on)
    else:
        direct = assembler.create_matrix(cells=cells)
        assembler.add(direct, solid.elastic_tangent_forms_on, cells)
    allocated = direct.getInfo(PETSc.Mat.InfoType.LOCAL)["nz_allocated"]
    direct.assemble()
    forms = solid.elastic_tangent_forms_on(cells)
    full = fem_petsc.create_matrix(forms[0])
    for form in forms:
        fem_petsc.assemble_matrix(full, form)
    full.assemble()
    reference = reduction.reduce_matrix(full)
    full.destroy()
    assert allocated == reference.getInfo(PETSc.Mat.InfoType.LOCAL)["nz_used"]  # exact pattern
    return direct, reference


def _check_equal(direct, reference) -> None:
    """Same rows, same nonzeros, values to round-off."""
    got, expected = direct.getValuesCSR(), reference.getValuesCSR()
    np.testing.assert_array_equal(got[0], expected[0])
    np.testing.assert_array_equal(got[1], expected[1])
    scale = np.abs(expected[2]).max()
    np.testing.assert_allclose(got[2], expected[2], rtol=0, atol=1e-13 * scale)


@pytest.mark.fem
@pytest.mark.parametrize("adaptive", [False, True])
@pytest.mark.parametrize("stride", [1, 3])
def test_the_reduced_assembly_is_p_transpose_k_p(monkeypatch, adaptive, stride):
    """Assembled through the local-to-reduced map, with the hanging cells reduced 16 at a
    time, the elastic tangent has the nonzeros and values of P^T K P of the whole mesh; over
    every third cell, in a matrix of their couplings alone, those of P^T K P of those cells
    (as the plastic correction of the yielding cells is assembled)."""
    monkeypatch.setattr(reduced_assembly, "HANGING_CELLS_AT_ONCE", 16)
    monkeypatch.setattr(reduced_assembly, "PATTERN_CELLS_AT_ONCE", 16)
    direct, reference = _assembled_both_ways(_case(adaptive), MPI.COMM_SELF, stride)
    _check_equal(direct, reference)


@pytest.mark.mpi
@pytest.mark.fem
@pytest.mark.parametrize("adaptive", [False, True])
def test_the_reduced_assembly_is_p_transpose_k_p_across_ranks(monkeypatch, adaptive):
    """The same on 2 ranks: cells add to rows another rank owns, and the ranks reduce their
    hanging cells in equally many products (one rank's may be empty)."""
    monkeypatch.setattr(reduced_assembly, "HANGING_CELLS_AT_ONCE", 16)
    direct, reference = _assembled_both_ways(_case(adaptive), MPI.COMM_WORLD)
    _check_equal(direct, reference)
