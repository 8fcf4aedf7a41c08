"""Richardson extrapolation, refined cases on the same bilinear surface, and the ladder of levels
with its certificate."""

import math
from functools import partial

import numpy as np
import pytest
from roughfriction.case import FemCase, Loading
from roughfriction.errors import InputError
from roughfriction.geometry.adaptive import cells_at_nodes
from roughfriction.geometry.mesh import blend_layers_needed
from roughfriction.geometry.surface import Surface
from roughfriction.solver.memory import block_size
from roughfriction.solver.results import count_boundary_nodes
from roughfriction.studies.certificate import LADDER_FACTOR, certify
from roughfriction.studies.refinement import (
    LadderLimits,
    LevelRun,
    level_case,
    level_layout,
    refined_case,
    richardson,
    run_ladder,
)


def test_two_meshes_assume_first_order():
    estimate = richardson([1.2, 1.1])
    assert estimate.extrapolated == pytest.approx(1.0)
    assert estimate.error == pytest.approx(0.1)
    assert estimate.order == 1.0 and not estimate.observed


@pytest.mark.parametrize("order", [1.0, 2.0, 1.5])
def test_three_meshes_recover_the_order_of_a_power_law(order):
    exact, constant = 0.4, 0.3
    values = [exact + constant * h**order for h in (1.0, 0.5, 0.25)]
    estimate = richardson(values)
    assert estimate.observed and estimate.order == pytest.approx(order)
    assert estimate.extrapolated == pytest.approx(exact)
    assert estimate.error == pytest.approx(abs(values[-1] - exact))


def test_non_converging_ladder_keeps_the_assumed_order():
    estimate = richardson([1.0, 1.1, 1.0])  # differences change sign: no asymptotic range
    assert not estimate.observed and estimate.order == 1.0
    assert estimate.error == pytest.approx(0.1)


def test_refined_case_samples_the_same_bilinear_surface():
    heights = np.random.default_rng(3).normal(size=(8, 8)) * 1e-7
    case = FemCase(Surface(heights, 1e-6, "s"), Loading(0.1))
    fine = refined_case(case, 2)
    assert fine.surface.n == 16 and fine.surface.spacing == pytest.approx(0.5e-6)
    assert fine.nominal_area == pytest.approx(case.nominal_area)
    np.testing.assert_allclose(fine.surface.heights[::2, ::2], heights)
    np.testing.assert_allclose(fine.surface.heights[1, 1], heights[:2, :2].mean())
    assert refined_case(case, 1) is case


@pytest.mark.fem
def test_a_refined_case_keeps_a_blend_deep_enough_for_its_thinner_layers():
    """A valley 1.25 h deep meshes with 2 blend layers of thickness h, but not with 2 of h/2
    (it needs 3): the refined case takes 4, the same depth, and meshes."""
    from mpi4py import MPI
    from roughfriction.errors import InputError
    from roughfriction.solver.block import build_block

    spacing = 1e-6
    heights = np.zeros((8, 8))
    heights[3, 4] = -1.25 * spacing
    case = FemCase(Surface(heights, spacing, "valley"), Loading(0.1))
    fine = refined_case(case, 2)
    assert case.mesh.blend_layers == 2 and fine.mesh.blend_layers == 4
    build_block(case.surface.heights, spacing, case.mesh, MPI.COMM_SELF)
    build_block(fine.surface.heights, fine.surface.spacing, fine.mesh, MPI.COMM_SELF)
    with pytest.raises(InputError, match="needs >= 3 blend layers"):
        build_block(fine.surface.heights, fine.surface.spacing, case.mesh, MPI.COMM_SELF)


@pytest.mark.parametrize("factor", [2, 4, 8])
@pytest.mark.parametrize("valley_depth", [0.2, 1.25, 4.0])  # [grid spacings h]
def test_the_blend_zone_has_the_same_physical_depth_on_every_level(factor, valley_depth):
    """The roughness fades over the same depth on every mesh of a ladder (the levels converge
    to one continuum problem): factor x the layers the case meshes, each h / factor thick; a
    valley deeper than the case's own layers (4 h needs 5 of h) sets the count to scale."""
    spacing = 1e-6
    heights = np.zeros((8, 8))
    heights[3, 4] = -valley_depth * spacing
    case = FemCase(Surface(heights, spacing, "valley"), Loading(0.1))
    meshed = max(case.mesh.blend_layers, blend_layers_needed(heights, spacing))
    fine = refined_case(case, factor)
    depth = fine.mesh.blend_layers * fine.surface.spacing
    assert depth == pytest.approx(meshed * spacing)
    assert fine.mesh.blend_layers >= blend_layers_needed(fine.surface.heights,
                                                         fine.surface.spacing)
    assert [level_case(case, level).surface.n for level in range(4)] == [8, 16, 32, 64]


# --- the ladder of levels (run_ladder), with a power-law runner instead of the FEM ------------

#: Wall time of the fake runner per reduced dof [s].
SECONDS_PER_DOF = 1e-3


#: Contact nodes and boundary nodes of the fake runner's level 0 (x 4 and x 2 per level) [-].
FAKE_CONTACT, FAKE_BOUNDARY = 400, 100


def power_law_runner(exact=0.2, constant=0.1, order=2.0):
    """A runner whose value on level k is exact + constant (2^-k)^order, with the level's
    real mesh size and a contact of FAKE_CONTACT 4^k nodes, FAKE_BOUNDARY 2^k on a boundary,
    taking SECONDS_PER_DOF per dof on its clock; it records the levels it ran and the
    ladders it was saved with."""
    ran, saved, now = [], [], [0.0]

    def run_level(level, level_case):
        ran.append((level, level_case.surface.n))
        cells, dofs = block_size(level_layout(level_case))
        now[0] += SECONDS_PER_DOF * dofs
        return LevelRun(exact + constant * 0.5**(order * level), dofs, cells, save=saved.append,
                        contact_nodes=FAKE_CONTACT * 4**level,
                        boundary_nodes=FAKE_BOUNDARY * 2**level)
    return run_level, ran, saved, lambda: now[0]


#: Limits of a uniform ladder (the power-law runner gives no contact maps).
UNIFORM = partial(LadderLimits, ladder="uniform")

CASE = FemCase(Surface(np.random.default_rng(1).normal(size=(4, 4)) * 1e-7, 1e-6, "s"),
               Loading(0.155))


def test_the_ladder_stops_at_the_first_level_whose_certificate_is_within_the_tolerance():
    """Values 0.3, 0.225, 0.20625: a tolerance between the 2x and the 4x certificates (relative)
    stops the ladder at 4x."""
    values = [0.2 + 0.1 / 4**k for k in range(3)]
    at_2x = certify(values[:2], FAKE_CONTACT * 4, FAKE_BOUNDARY * 2).relative_error
    at_4x = certify(values, FAKE_CONTACT * 16, FAKE_BOUNDARY * 4).relative_error
    assert at_4x < at_2x
    run_level, ran, saved, clock = power_law_runner()
    ladder = run_ladder(CASE, run_level, UNIFORM(tolerance=math.sqrt(at_2x * at_4x)),
                        lambda case: 1.0, clock)
    assert [n for _, n in ran] == [4, 8, 16]  # 1x, 2x, 4x of the same surface
    expected = certify(values, FAKE_CONTACT * 16, FAKE_BOUNDARY * 4)
    summary = ladder.summary()
    assert ladder.met and summary["mu_s"] == pytest.approx(values[-1])
    assert summary["mu_s_error"] == pytest.approx(expected.error)
    assert summary["error_ladder_term"] == pytest.approx(LADDER_FACTOR * (values[1] - values[2]))
    assert summary["error_resolution_term"] == pytest.approx(expected.resolution_term)
    assert summary["mu_s_coarse"] == pytest.approx(values[1])
    assert summary["levels"]["factor"] == [1, 2, 4]
    assert summary["levels"]["contact_nodes"] == [400, 1600, 6400]
    assert summary["levels"]["boundary_nodes"] == [100, 200, 400]
    dofs = [block_size(level_layout(level_case(CASE, level)))[1] for level in range(3)]
    assert summary["levels"]["reduced_dofs"] == dofs
    assert summary["levels"]["wall_s"] == pytest.approx([SECONDS_PER_DOF * d for d in dofs])
    assert summary["error_tolerance_met"]
    # each level is saved once, with the ladder as it stood when the level finished
    assert [len(ladder.levels) for ladder in saved] == [1, 2, 3]
    assert saved[0].summary()["mu_s_error"] is None
    assert saved[1].summary()["mu_s_error_relative"] == pytest.approx(at_2x)


def test_a_level_without_contact_counts_gives_no_certificate():
    def run_level(level, level_case):
        return LevelRun(0.2 + 0.1 * 0.5**level, 100, 10)
    ladder = run_ladder(CASE, run_level, UNIFORM(max_level=1), lambda case: 1.0)
    assert ladder.estimate is None and ladder.summary()["mu_s_error"] is None


def test_without_a_tolerance_the_ladder_runs_to_its_level_the_refine_shortcut():
    run_level, ran, _, _ = power_law_runner()
    ladder = run_ladder(CASE, run_level, UNIFORM(max_level=1), lambda case: 1.0)
    assert len(ran) == 2 and ladder.met and ladder.stopped == ""


def dofs_through(level):
    """Reduced dofs of CASE's levels 0..level together."""
    return sum(block_size(level_layout(level_case(CASE, k)))[1] for k in range(level + 1))


@pytest.mark.parametrize(("limits", "reason"), [
    (UNIFORM(tolerance=1e-4, max_level=2), "--max-level 2"),
    (UNIFORM(tolerance=1e-4, max_memory_gb=5.0), "the 8x level needs about 8 GB"),
    (UNIFORM(tolerance=1e-4, max_time_s=SECONDS_PER_DOF * (dofs_through(2) + dofs_through(3))
                  / 2), "the 8x level would take about"),
])
def test_a_limit_stops_the_ladder_short_of_the_tolerance_with_its_reason(limits, reason):
    """Memory: 8 GB at 8x, 1 GB at 4x; time: the 8x level is predicted from the 4x one's
    wall time scaled by dofs, which the fake runner makes exact."""
    run_level, ran, saved, clock = power_law_runner()
    ladder = run_ladder(CASE, run_level, limits, lambda case: (case.surface.n / 16)**3, clock)
    assert not ladder.met and reason in ladder.stopped
    assert len(ran) == 3  # the 8x level was refused before it started
    assert saved[-1].stopped == ladder.stopped  # the file of the last level says why
    line = ladder.shortfall()
    assert line.startswith("tolerance 0.01 % not met: mu_s = ") and "at 4x" in line
    assert "%, certified) at 4x" in line and "\n" not in line


# --- the adaptive ladder, with a runner whose contact is a disc of the same physical size -----

CASE8 = FemCase(Surface(np.random.default_rng(2).normal(size=(8, 8)) * 1e-7, 1e-6, "s"),
                Loading(0.155))


def disc_runner(radii, reach=(0.0, 0.0, 0.0)):
    """A runner whose contact on level k is the disc of radius ``radii[k]`` own spacings about
    the surface's centre, on the level's finest grid, and whose nodes near the flat reach
    ``reach[k]`` own spacings further; it records the cases it ran."""
    ran = []

    def run_level(level, level_case):
        ran.append(level_case)
        side = CASE8.surface.n << level
        contact, near = (disc(side, side // 2, radius * 2**level)
                         for radius in (radii[level], radii[level] + reach[level]))
        return LevelRun(0.2 + 0.1 * 0.5**level, 100 * (level + 1), 10, contact=contact,
                        near=near, contact_nodes=int(contact.sum()),
                        boundary_nodes=count_boundary_nodes(contact))
    return run_level, ran


def test_an_adaptive_level_refines_around_the_contact_and_near_nodes_of_the_level_before():
    run_level, ran = disc_runner([1.0, 1.0, 1.0], reach=[2.0, 2.0, 2.0])
    ladder = run_ladder(CASE8, run_level, LadderLimits(max_level=2), lambda case: 1.0)
    assert [case.surface for case in ran] == [CASE8.surface] * 3  # the own surface every level
    assert ran[0] is CASE8 and ran[1].mesh.blend_layers == CASE8.mesh.blend_layers
    first, second = (case.mesh.refinement for case in ran[1:])
    assert (first.level, first.zone.shape, second.level, second.zone.shape) == (
        1, (8, 8), 2, (16, 16))
    # level 0's contact: the 5 nodes within 1 h of the centre node (4, 4), their cells
    # dilated by the default margin of one cell; its nodes near the flat, within 3 h, their
    # cells undilated
    np.testing.assert_array_equal(first.zone, cells_at_nodes(disc(8, 4, 1.0), 1)
                                  | cells_at_nodes(disc(8, 4, 3.0)))
    np.testing.assert_array_equal(second.zone, cells_at_nodes(disc(16, 8, 2.0), 1)
                                  | cells_at_nodes(disc(16, 8, 6.0)))
    assert 0 < first.zone.sum() < 64 and second.zone.sum() < 4 * first.zone.sum()
    assert ladder.summary()["levels"]["zone_escaped"] == [False, False, False]
    assert ladder.summary()["error_ladder"] == "adaptive"


@pytest.mark.parametrize("margin, widened", [(0, 1), (1, 2)])
def test_contact_past_the_zone_is_reported_and_widens_the_next_margin(margin, widened):
    """Level 1's contact (radius 3.5 h) reaches past the zone made from level 0's (1 h):
    level 1 is marked, and level 2's zone is level 1's contact dilated by twice the margin
    (one cell from none)."""
    run_level, ran = disc_runner([1.0, 3.5, 3.5])
    limits = LadderLimits(max_level=2, margin=margin)
    ladder = run_ladder(CASE8, run_level, limits, lambda case: 1.0)
    assert ladder.summary()["levels"]["zone_escaped"] == [False, True, False]
    np.testing.assert_array_equal(ran[2].mesh.refinement.zone,
                                  cells_at_nodes(disc(16, 8, 7.0), widened))
    # the same ladder without the escape keeps its margin
    run_level, ran = disc_runner([1.0, 1.0, 1.0])
    run_ladder(CASE8, run_level, limits, lambda case: 1.0)
    np.testing.assert_array_equal(ran[2].mesh.refinement.zone,
                                  cells_at_nodes(disc(16, 8, 2.0), margin))


def test_near_nodes_past_the_zone_are_no_escape():
    """Level 1's nodes near the flat reach 3 h past its contact, and past its zone (level 0's
    contact's cells and margin); its contact stays inside: no escape, and level 2 refines
    around the near nodes too, the contact with the same margin."""
    run_level, ran = disc_runner([1.0, 1.0, 1.0], reach=[0.0, 3.0, 0.0])
    ladder = run_ladder(CASE8, run_level, LadderLimits(max_level=2), lambda case: 1.0)
    assert ladder.summary()["levels"]["zone_escaped"] == [False, False, False]
    near = cells_at_nodes(disc(16, 8, 8.0))
    assert not np.all(near <= np.repeat(np.repeat(ran[1].mesh.refinement.zone, 2, axis=0), 2,
                                        axis=1))  # the near nodes left the zone
    np.testing.assert_array_equal(ran[2].mesh.refinement.zone,
                                  near | cells_at_nodes(disc(16, 8, 2.0), 1))


def test_a_uniform_ladder_never_escapes_and_an_adaptive_one_needs_contact_maps():
    run_level, ran = disc_runner([1.0, 1.0])
    ladder = run_ladder(CASE8, run_level, UNIFORM(max_level=1), lambda case: 1.0)
    assert [case.surface.n for case in ran] == [8, 16] and ran[1].mesh.refinement is None
    assert ladder.summary()["levels"]["zone_escaped"] == [False, False]
    power_law, _, _, _ = power_law_runner()
    with pytest.raises(ValueError, match="contact map"):
        run_ladder(CASE, power_law, LadderLimits(max_level=1), lambda case: 1.0)


@pytest.mark.parametrize("limits", [{"ladder": "octree"}, {"margin": -1}, {"margin": 1.5}])
def test_bad_ladder_options_are_refused(limits):
    with pytest.raises(InputError):
        LadderLimits(**limits)


def disc(side, centre, radius):
    """Nodes of a side x side grid within ``radius`` grid spacings of node (centre, centre)."""
    i, j = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    return (i - centre)**2 + (j - centre)**2 <= radius**2
