"""The contact-adaptive block in a run: the all-zone mask is the uniform ladder's run."""

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from roughfriction.case import FemCase, Loading, MeshOptions, ZoneRefinement
from roughfriction.errors import InputError
from roughfriction.geometry.adaptive import block_layout, block_nodes, cells_at_nodes
from roughfriction.geometry.surface import Surface
from roughfriction.studies.refinement import refined_case

pytest.importorskip("dolfinx")
from mpi4py import MPI  # noqa: E402
from roughfriction.solver.block import build_block  # noqa: E402
from roughfriction.solver.results import touched_nodes  # noqa: E402
from roughfriction.solver.run import FemRun, near_flat, run  # noqa: E402
from roughfriction.studies.refinement import adaptive_level_case  # noqa: E402

SPACING = 1e-6  # [m]
LEVEL = 1
#: The layering of both ladders: the zone refined everywhere meshes the uniform ladder's block.
MESH = MeshOptions()
#: Layerings the two blocks are compared in: default, fine layers deeper than the blend zone,
#: a deep blend zone, no coarsening.
LAYERINGS = [MESH, MeshOptions(fine_layers=4, blend_layers=1), MeshOptions(blend_layers=3),
             MeshOptions(coarsen=False, growth=2.0)]


def gentle_case(n=4, load=0.155, normal_only=False, mesh=MESH) -> FemCase:
    """A small i.i.d. surface whose valleys need no more blend layers than the meshes take."""
    heights = np.random.default_rng(11).normal(0.0, 0.08 * SPACING, (n, n))
    return FemCase(Surface(heights, SPACING, "gentle"), Loading(load, normal_only), mesh=mesh)


def all_zone(case: FemCase, level: int = LEVEL) -> FemCase:
    """The case on the adaptive block refined everywhere to ``level``."""
    zone = np.ones((case.surface.n, case.surface.n), bool)
    return replace(case, mesh=replace(case.mesh, refinement=ZoneRefinement(level, zone)))


def uniform(case: FemCase, level: int = LEVEL) -> FemCase:
    """The uniform ladder's level ``level``: the case re-gridded 2^level times finer, without
    refinement."""
    return refined_case(case, 2**level)


def case_nodes(case: FemCase):
    """The block of a case on one process (``geometry.adaptive.block_nodes``)."""
    surface = case.surface
    return block_nodes(block_layout(surface.n, surface.spacing, case.mesh), surface.heights)


@pytest.mark.parametrize("level", [1, 2])
@pytest.mark.parametrize("options", LAYERINGS)
def test_the_all_zone_block_is_the_unrefined_block_of_the_refined_surface(level, options):
    case = gentle_case(mesh=options)
    adaptive, regridded = all_zone(case, level), uniform(case, level)
    a, s = case_nodes(adaptive), case_nodes(regridded)
    assert (a.n, a.spacing) == (s.n, s.spacing)
    # the blend zone as deep in metres as the case's own
    assert regridded.mesh.blend_layers * s.spacing == pytest.approx(
        options.blend_layers * SPACING, rel=1e-12)
    np.testing.assert_allclose(a.layer_z, s.layer_z, rtol=0, atol=1e-18)
    np.testing.assert_array_equal(a.layer_stride, s.layer_stride)
    position = {tuple(node): p for p, node in enumerate(s.grid)}
    same = np.array([position[tuple(node)] for node in a.grid])
    assert len(same) == len(s.grid)
    np.testing.assert_allclose(a.coordinates, s.coordinates[same], rtol=0, atol=1e-18)
    cells = {tuple(sorted(same[cell])) for cell in a.hexahedra}
    assert cells == {tuple(sorted(cell)) for cell in s.hexahedra}


def test_a_bad_zone_is_refused_on_every_rank_before_meshing():
    case = gentle_case()
    bad = replace(MESH, refinement=ZoneRefinement(1, np.ones((3, 3), bool)))
    with pytest.raises(InputError, match="refinement zone"):
        build_block(case.surface.heights, SPACING, bad, MPI.COMM_SELF)


@pytest.mark.fem
def test_the_all_zone_run_reproduces_the_uniformly_refined_run():
    case = gentle_case()
    results = {name: run(make(case), MPI.COMM_SELF, progress=lambda record: None).result
               for name, make in (("adaptive", all_zone), ("uniform", uniform))}
    adaptive, regridded = results["adaptive"], results["uniform"]
    assert adaptive.converged and regridded.converged
    assert adaptive.sizes["reduced_dofs"] == regridded.sizes["reduced_dofs"]
    assert adaptive.sizes["refinement_level"] == LEVEL
    assert regridded.mu_s > 0.05
    assert adaptive.mu_s == pytest.approx(regridded.mu_s, rel=1e-10, abs=0)


#: Largest relative change of mu_s the coarse blend zone may make on the gentle surface [-]
#: (its fine layers resolve the contact; the blend zone below carries a smooth field).
COARSE_BLEND_AGREEMENT = 1e-3


@pytest.mark.fem
def test_the_coarse_blend_zone_gives_the_fine_zone_s_mu_s_with_fewer_dofs():
    """The all-zone level 1 with the blend zone below the fine layers at the own grid's cells:
    fewer than half the dofs (block_size counts them), mu_s within 0.1 % of the fine zone's."""
    from roughfriction.solver.memory import block_size

    case = replace(gentle_case(n=6), mesh=MeshOptions(blend_layers=4))
    fine = all_zone(case)
    coarse = replace(fine, mesh=replace(fine.mesh, blend_zone="coarse"))
    results = [run(level, MPI.COMM_SELF, progress=lambda record: None).result
               for level in (fine, coarse)]
    assert all(result.converged for result in results)
    dofs = [result.sizes["reduced_dofs"] for result in results]
    assert dofs[1] == block_size(block_layout(6, SPACING, coarse.mesh))[1]
    assert dofs[1] < 0.5 * dofs[0]
    assert results[1].mu_s == pytest.approx(results[0].mu_s, rel=COARSE_BLEND_AGREEMENT)
    assert results[1].mu_s != results[0].mu_s  # a different mesh


@pytest.mark.mpi
@pytest.mark.fem
def test_the_all_zone_run_reproduces_the_uniformly_refined_run_across_ranks():
    """The same on 2 ranks: hanging-node ties and slab partition of the adaptive block."""
    case = gentle_case(normal_only=True)
    adaptive, regridded = (run(make(case), MPI.COMM_WORLD, progress=lambda record: None).result
                            for make in (all_zone, uniform))
    assert adaptive.converged and regridded.converged
    assert adaptive.records[-1].area_ratio == pytest.approx(regridded.records[-1].area_ratio,
                                                            rel=1e-10, abs=0)


def partial_zone_case() -> FemCase:
    """The gentle 8 x 8 case, refined once around its 1x contact (one cell of margin)."""
    case = gentle_case(n=8, normal_only=True)
    contact = np.zeros((8, 8), bool)
    contact[[2, 5], [3, 6]] = True
    return replace(case, mesh=replace(case.mesh, refinement=ZoneRefinement(
        1, cells_at_nodes(contact, 1))))


def next_level(case: FemCase, fem_run: FemRun) -> FemCase:
    """The adaptive level after ``case`` around ``fem_run``'s contact (no margin) and its
    nodes near the flat."""
    return adaptive_level_case(case, touched_nodes(fem_run.maps), 0, near_flat(case, fem_run))


def test_the_next_level_refines_the_cells_around_the_last_level_s_contact_and_near_nodes():
    case = partial_zone_case()
    far = np.full((16, 16), 1.0)  # every node's gap [m]: far above the limit
    maps = {"contact_normal": np.zeros((16, 16), bool), "contact_sliding": np.zeros((16, 16), bool),
            "gap_normal": far, "gap_sliding": far}
    maps["contact_normal"][4, 6] = True
    maps["contact_sliding"][5, 6] = True
    below = SimpleNamespace(records=[SimpleNamespace(flat_height=-SPACING)])  # overlaps all
    finer = next_level(case, FemRun(below, maps, None, None))
    assert finer.mesh.refinement.level == 2
    zone = finer.mesh.refinement.zone
    assert zone.shape == (16, 16) and zone.sum() == 6 and zone[3:6, 5:7].all()
    assert finer.surface is case.surface and finer.mesh.fine_layers == case.mesh.fine_layers
    # a node of the coarse own cell (1, 6) with a penetration, its cell's other grid points
    # without a free node (NaN): the gap interpolated in the cell is below the limit at the
    # node and along the cell's edges from it, so the cells around those grid points join
    gap = far.copy()
    gap[2:5, 12:15] = np.nan
    gap[[2, 4, 2, 4], [12, 12, 14, 14]] = [-1.0, 1.0, 1.0, 1.0]
    maps.update(gap_normal=gap, gap_sliding=gap)
    near = np.zeros((16, 16), bool)
    near[[2, 3, 2], [12, 12, 13]] = True
    zone = next_level(case, FemRun(below, maps, None, None)).mesh.refinement.zone
    np.testing.assert_array_equal(zone, cells_at_nodes(near) | finer.mesh.refinement.zone)
    # a flat that stayed above every peak of the undeformed surface overlapped none of them
    above = SimpleNamespace(records=[SimpleNamespace(flat_height=SPACING)])
    zone = next_level(case, FemRun(above, maps, None, None)).mesh.refinement.zone
    np.testing.assert_array_equal(zone, finer.mesh.refinement.zone)


@pytest.mark.fem
def test_a_partial_zone_run_converges_with_fewer_dofs_than_the_uniform_one():
    case = partial_zone_case()
    adaptive = run(case, MPI.COMM_SELF, progress=lambda record: None)
    regridded = run(uniform(case), MPI.COMM_SELF, progress=lambda record: None)
    assert adaptive.result.converged and regridded.result.converged
    assert adaptive.result.sizes["reduced_dofs"] < 0.8 * regridded.result.sizes["reduced_dofs"]
    assert adaptive.maps["contact_normal"].shape == (16, 16)
    assert adaptive.maps["contact_normal"].any()


@pytest.mark.mpi
@pytest.mark.fem
def test_a_partial_zone_run_is_the_same_on_two_ranks():
    """Gathers of the free surface nodes, hanging corners and their masters across ranks."""
    case = partial_zone_case()
    serial = run(case, MPI.COMM_SELF, progress=lambda record: None).result.records[-1]
    parallel = run(case, MPI.COMM_WORLD, progress=lambda record: None).result.records[-1]
    assert parallel.area_ratio == pytest.approx(serial.area_ratio, rel=1e-10, abs=0)
    assert parallel.flat_height == pytest.approx(serial.flat_height, rel=1e-8)


#: Relative difference of mu_s allowed between the adaptive and the uniform level 1 where the
#: zone holds every contact candidate [-]; a zone that misses one moves mu_s by several %.
AGREEMENT = 1e-3


@pytest.mark.fem
def test_an_adaptive_level_gives_the_uniform_level_s_mu_s():
    """G5's third 8 x 8 window at F* = 0.155 (4 nodes in contact at 1x): level 1 refined as
    the ladder does (the 1x contact with the default margin, and the nodes near the flat)
    against the uniform 2x mesh; the same level around the contact alone (a patch appears at
    2x where the deformed surface came near the flat at 1x) and with no zone at all both miss
    it."""
    from roughfriction.geometry.adaptive import refinement_after
    from roughfriction.studies.paper import fem_surface
    from roughfriction.studies.refinement import DEFAULT_MARGIN, level_case

    case = FemCase(fem_surface("G5", 8, 3), Loading(0.155))
    base = run(case, MPI.COMM_SELF, progress=lambda record: None)
    contact = touched_nodes(base.maps)
    adaptive = adaptive_level_case(case, contact, DEFAULT_MARGIN, near_flat(case, base))
    contact_only = replace(case, mesh=replace(case.mesh, refinement=refinement_after(
        None, contact, DEFAULT_MARGIN)))
    cells = [level.mesh.refinement.zone.sum() for level in (contact_only, adaptive)]
    assert 16 <= cells[0] < cells[1] < 64  # partial zones, the near nodes' cells added
    empty = replace(case, mesh=replace(case.mesh, refinement=ZoneRefinement(
        1, np.zeros((8, 8), bool))))
    mu_s = {name: run(level, MPI.COMM_SELF, progress=lambda record: None).result.mu_s
            for name, level in (("uniform", level_case(case, 1)), ("adaptive", adaptive),
                                ("contact only", contact_only), ("empty", empty))}
    uniform = mu_s.pop("uniform")
    assert mu_s.pop("adaptive") == pytest.approx(uniform, rel=AGREEMENT)
    for name, missed in mu_s.items():
        assert abs(missed - uniform) > 10 * AGREEMENT * uniform, name
