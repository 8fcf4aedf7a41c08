"""Contact of the surface nodes (weighted gaps over their tributary areas) and friction at
integration points against the rigid flat (NumPy, one rank)."""

import numpy as np
import pytest
from mpi4py import MPI
from roughfriction.case import MeshOptions, SolverOptions
from roughfriction.errors import InputError
from roughfriction.geometry.adaptive import block_layout
from roughfriction.solver.contact import RigidFlat, Tangent, Trial
from roughfriction.solver.contact_faces import face_quadrature
from roughfriction.solver.contact_law import ContactLaw
from roughfriction.solver.contact_quadrature import NEIGHBOURS

TAU_C = 577e6  # [Pa]
RAMP = 10e6  # [Pa]
PENALTY = 1e18  # [Pa/m]
SPACING = 1e-6  # [m]
N = 4  # faces per side
#: The trial of a sliding step: frictional, no predictor, the law's contact set, exact tangent.
FRICTIONAL = Trial(friction=True)


def uniform_cells(n):
    """The cell sizes of an unrefined n x n surface: n x n top faces one spacing wide."""
    return block_layout(n, SPACING, MeshOptions()).cells


def flat_over(heights=None, ramp=RAMP, tangential=PENALTY, points=2):
    """A flat over an n x n grid of surface nodes whose displacement rows are the grid nodes
    i n + j (``heights``: n x n [m], default an N x N flat; ``tangential``: eps_T [Pa/m])."""
    heights = np.zeros((N, N)) if heights is None else np.asarray(heights, float)
    n = len(heights)
    i, j = np.divmod(np.arange(n * n), n)
    law = ContactLaw(PENALTY, tangential, TAU_C, ramp)
    return RigidFlat(MPI.COMM_SELF, np.arange(n * n), np.column_stack([i, j]), uniform_cells(n),
                     heights.ravel(), SPACING, law, points)


def anchored(flat):
    """Every point in contact and stuck at the last converged step (after a preload)."""
    flat.committed.anchored[:] = True
    return flat


def still():
    """Zero displacement of the N^2 surface nodes [m]."""
    return np.zeros((N * N, 3))


@pytest.mark.parametrize("points", [1, 2, 3, 4])
def test_face_quadrature_integrates_bilinear_products_exactly(points):
    shape, weight = face_quadrature(points)
    assert weight.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(shape.sum(axis=1), 1.0)
    if points >= 2:  # consistent mass matrix of the unit square: (1 + d_x)(1 + d_y) / 36
        mass = np.einsum("q,qa,qb->ab", weight, shape, shape)
        assert mass[0, 0] == pytest.approx(4 / 36) and mass[0, 3] == pytest.approx(1 / 36)


def test_points_see_the_bilinear_surface_through_the_nodes():
    rng = np.random.default_rng(0)
    heights = rng.normal(size=(N, N)) * 1e-8
    flat = flat_over(heights, points=3)
    shape, _ = face_quadrature(3)
    face = 2 * N + 3  # face (2, 3): corners (2,3), (3,3), (2,0), (3,0) across the period
    corners = heights[[2, 3, 2, 3], [3, 3, 0, 0]]
    np.testing.assert_allclose(flat.surface.heights.reshape(N * N, 9)[face], shape @ corners)


def test_uniform_pressure_gives_consistent_nodal_forces_and_full_area():
    pressure = 1e9
    flat = flat_over()
    response = flat.respond(still(), -pressure / PENALTY, 0.0)
    np.testing.assert_allclose(response.pressure, pressure)
    np.testing.assert_allclose(response.node_force, [[0.0, 0.0, pressure * SPACING**2]] * N**2)
    assert flat.normal_force(response) == pytest.approx(pressure * (N * SPACING) ** 2)
    assert flat.area_ratio(response.in_contact) == 1.0


@pytest.mark.parametrize("points", [2, 4, 8])
def test_a_raised_node_alone_touches_with_its_tributary_area(points):
    """One raised node, the flat at half its height: the node's weighted gap is the flat's
    height minus the mean height of its tributary quarters (0.622 of the node's height with 2 x 2
    points, (3/4)^2 in the limit of many), so it touches; its neighbours' quarters lie lower and
    stay open. The contact area is the node's tributary area h^2."""
    heights = np.zeros((N, N))
    heights[1, 1] = 1e-8
    flat = flat_over(heights, points=points)
    response = flat.respond(still(), 0.5e-8, 0.0)
    shape, weight = face_quadrature(points)
    mean = 4 * np.sum(weight * shape[:, 0] * (np.argmax(shape, axis=1) == 0))
    assert -response.node_gap[5] == pytest.approx(mean * 1e-8 - 0.5e-8)
    assert mean == pytest.approx(0.5625, abs=0.06)
    np.testing.assert_array_equal(np.flatnonzero(response.node_active), [5])
    assert flat.area_ratio(response.in_contact) == pytest.approx(1.0 / N**2)
    maps = flat.node_maps(response)
    assert maps["contact"].sum() == 1 and maps["contact"][1, 1]
    assert maps["contact_fraction"].sum() == pytest.approx(1.0)
    assert maps["gap"][1, 1] == response.node_gap[5] < 0.0  # penetrates; the others open
    assert np.all(np.delete(maps["gap"].ravel(), 5) > 0.0)
    assert flat.normal_force(response) == pytest.approx(
        PENALTY * (mean * 1e-8 - 0.5e-8) * SPACING**2)


def test_odd_points_per_side_are_rejected():
    """With an odd number of points per side a point would lie on a tributary boundary."""
    with pytest.raises(InputError, match="even"):
        SolverOptions(contact_points=3)


def test_a_frozen_set_keeps_its_nodes_and_takes_in_penetrating_ones():
    """With a frozen contact set its nodes stay active even in tension (their points pull on the
    flat), and nodes outside it join as soon as they penetrate (the set can only grow within a
    round)."""
    heights = np.zeros((N, N))
    heights[1, 1] = 1e-8
    flat = flat_over(heights)
    free = flat.respond(still(), 0.5e-8, 0.0)
    frozen = np.zeros_like(free.node_active)
    frozen[0] = True  # node (0, 0), below the flat: in tension
    response = flat.respond(still(), 0.5e-8, 0.0, Trial(active=frozen))
    np.testing.assert_array_equal(response.node_active, free.node_active | frozen)
    assert free.node_active.any() and not free.node_active[0]
    assert response.node_pressure[0] < 0.0
    np.testing.assert_array_equal(response.in_contact, free.in_contact)
    pulled = flat.normal_force(free) - flat.normal_force(response)  # node 0's tension [N]
    assert pulled == pytest.approx(-response.node_pressure[0] * SPACING**2)


@pytest.mark.parametrize("pressure", [2.5e6, 1e9])
def test_slipping_point_carries_the_cap_along_the_trial_direction(pressure):
    flat = anchored(flat_over())
    height = -pressure / PENALTY  # gap -p / eps: the surface presses with p
    slide = 3 * TAU_C / PENALTY  # trial traction 3 tau_c along x
    response = flat.respond(still(), height, slide, FRICTIONAL)
    cap = TAU_C * min(1.0, pressure / RAMP)
    assert response.slipping.all() and response.in_contact.all()
    np.testing.assert_allclose(response.traction, [[cap, 0.0]] * len(response.traction))
    np.testing.assert_allclose(response.pressure, pressure)
    # residual: each node is dragged along +x and pushed down by its tributary area
    np.testing.assert_allclose(response.node_force[0],
                               [-cap * SPACING**2, 0.0, pressure * SPACING**2])
    assert flat.tangential_force(response) == pytest.approx(cap * (N * SPACING) ** 2)
    assert response.symmetric == (pressure >= RAMP)
    np.testing.assert_allclose(response.stick_offset[:, 0], slide - cap / PENALTY)
    assert flat.node_maps(response)["slip"].all()


@pytest.mark.parametrize("tangential", [PENALTY, 0.1 * PENALTY])
def test_point_below_its_cap_sticks_with_the_full_stick_penalty(tangential):
    flat = anchored(flat_over(tangential=tangential))
    slide = 0.5 * TAU_C / tangential
    response = flat.respond(still(), -1e9 / PENALTY, slide, FRICTIONAL)
    assert not response.slipping.any()
    np.testing.assert_allclose(response.traction[:, 0], 0.5 * TAU_C)
    # a rigid translation of every node: the 25 blocks of a row sum to the point law times h^2
    row = response.node_stiffness[5].sum(axis=0)
    np.testing.assert_allclose(row, np.diag([tangential, tangential, PENALTY]) * SPACING**2)
    np.testing.assert_allclose(response.stick_offset, 0.0, atol=1e-12 * slide)
    assert not flat.node_maps(response)["slip"].any()


def test_slipping_point_drags_its_stick_point_to_the_cap_over_the_stick_penalty():
    """On commit the stick point lies tau_c / eps_T behind the flat, and the next step's trial
    traction starts from the cap again."""
    for tangential in (PENALTY, 0.1 * PENALTY):
        flat = anchored(flat_over(tangential=tangential))
        slide = 3 * TAU_C / tangential
        response = flat.respond(still(), -1e9 / PENALTY, slide, FRICTIONAL)
        assert response.slipping.all()
        np.testing.assert_allclose(response.stick_offset[:, 0], slide - TAU_C / tangential)
        flat.commit(response)
        again = flat.respond(still(), -1e9 / PENALTY, slide, FRICTIONAL)
        np.testing.assert_allclose(again.traction[:, 0], TAU_C)


def test_point_at_vanishing_pressure_carries_vanishing_shear():
    """As the pressure tends to 0 the shear does too, with the ramp; without it the shear stays
    at tau_c."""
    slide = 0.9 * TAU_C / PENALTY
    for pressure in (1e6, 1e3, 1.0):
        with_ramp = anchored(flat_over()).respond(still(), -pressure / PENALTY, slide, FRICTIONAL)
        pure = anchored(flat_over(ramp=0.0)).respond(still(), -pressure / PENALTY, slide,
                                                     FRICTIONAL)
        np.testing.assert_allclose(with_ramp.traction[:, 0], TAU_C * pressure / RAMP)
        np.testing.assert_allclose(pure.traction[:, 0], 0.9 * TAU_C)


def test_open_newly_touching_and_frictionless_points_carry_no_shear():
    heights = np.zeros((N, N))
    heights[:, 2:] = -1e-8  # the faces between j = 2 and 3 lie 10 nm below: open
    flat = anchored(flat_over(heights))
    newly = np.zeros(len(flat.committed.anchored), bool)
    newly[:4] = True  # face (0, 0) touches in this step
    flat.committed.anchored[newly] = False
    slide = 0.5 * TAU_C / PENALTY
    # nodes j = 0, 1 have a lowered neighbour: their tributary mean lies 1.25 nm below them
    response = flat.respond(still(), -5e9 / PENALTY, slide, FRICTIONAL)
    faces = response.in_contact.reshape(N, N, -1)
    assert faces[:, 0].all() and not faces[:, 2].any()
    np.testing.assert_allclose(response.traction[~response.in_contact | newly], 0.0)
    assert (response.traction[response.in_contact & ~newly, 0] > 0).all()
    frictionless = flat.respond(still(), -5e9 / PENALTY, slide)
    np.testing.assert_allclose(frictionless.traction, 0.0)


@pytest.mark.parametrize("tangential", [PENALTY, 0.1 * PENALTY])
@pytest.mark.parametrize("pressure, slide", [(2.5e6, 3.0), (1e9, 3.0), (1e9, 0.5), (2.5e6, 0.5)])
def test_nodal_tangent_and_height_derivative_match_finite_differences(pressure, slide,
                                                                      tangential):
    """dR_a/du_b over the 25 neighbours of a node (on this 4 x 4 grid some offsets meet the
    same node, whose block is held once) and dR/dh, for points slipping below and above p_r and
    sticking, on a rough surface with a random displacement (so that points differ), against
    central differences of the nodal residual."""
    rng = np.random.default_rng(1)
    heights = rng.normal(size=(N, N)) * 1e-3 * pressure / PENALTY
    flat = anchored(flat_over(heights, tangential=tangential))
    flat.committed.stick_offset[:] = [[0.0, -0.5 * slide * TAU_C / tangential]]
    height, flat_slide = -pressure / PENALTY, slide * TAU_C / tangential * np.sqrt(0.75)
    u0 = rng.normal(size=(N * N, 3)) * 1e-3 * pressure / PENALTY
    response = flat.respond(u0, height, flat_slide, FRICTIONAL)
    step = 1e-5 * pressure / PENALTY  # [m], well inside every regime
    scale = PENALTY * SPACING**2

    def force(u, h=height):
        return flat.respond(u, h, flat_slide, FRICTIONAL).node_force

    row = 5  # node (1, 1)
    i, j = divmod(row, N)
    columns = np.array([((i + di) % N) * N + (j + dj) % N for di, dj in NEIGHBOURS])
    assert len(set(columns)) == N * N  # every node is within 2 steps on this grid
    for column_node in set(columns):
        blocks = response.node_stiffness[row, columns == column_node].sum(axis=0)
        for c in range(3):
            e = np.zeros_like(u0)
            e[column_node, c] = step
            column = (force(u0 + e)[row] - force(u0 - e)[row]) / (2 * step)
            np.testing.assert_allclose(blocks[:, c], column, rtol=1e-5, atol=1e-7 * scale)
    column = (force(u0, height + step) - force(u0, height - step)) / (2 * step)
    np.testing.assert_allclose(response.node_height_derivative, column, rtol=1e-5,
                               atol=1e-7 * scale)


def test_the_symmetric_tangent_drops_only_the_ramp_coupling():
    """With ``Tangent.SYMMETRIC`` the forces are unchanged and the tangent loses exactly the
    dt/dp blocks of points slipping below p_r (the pressure columns of the shear rows)."""
    rng = np.random.default_rng(2)
    pressure = 2.5e6  # below the ramp pressure: the slipping points couple
    heights = rng.normal(size=(N, N)) * 1e-3 * pressure / PENALTY
    flat = anchored(flat_over(heights))
    u0 = rng.normal(size=(N * N, 3)) * 1e-3 * pressure / PENALTY
    args = (u0, -pressure / PENALTY, 3 * TAU_C / PENALTY)
    exact = flat.respond(*args, FRICTIONAL)
    approximate = flat.respond(*args, Trial(friction=True, tangent=Tangent.SYMMETRIC))
    assert exact.coupled and approximate.coupled
    assert not exact.symmetric and approximate.symmetric
    np.testing.assert_array_equal(approximate.node_force, exact.node_force)
    dropped = exact.node_stiffness - approximate.node_stiffness
    assert np.abs(dropped[:, :, :2, 2]).max() > 0.1 * np.abs(exact.node_stiffness).max()
    dropped[:, :, :2, 2] = 0.0
    np.testing.assert_array_equal(dropped, 0.0)
    np.testing.assert_array_equal(approximate.node_height_derivative[:, 2],
                                  exact.node_height_derivative[:, 2])
    np.testing.assert_array_equal(approximate.node_height_derivative[:, :2], 0.0)


def test_touching_height_carries_the_force_with_springs_at_the_nodes():
    heights = np.zeros((N, N))
    heights[1, 1] = 1e-8
    flat = flat_over(heights)
    force = 1e-3  # [N]
    h = flat.touching_height(still(), force, 2.2e11)
    tops = -flat.respond(still(), 0.0, 0.0).node_gap  # h - g~_a [m]
    assert 0.0 < h < tops.max()
    stiffness = 1.0 / (1.0 / (PENALTY * SPACING**2) + 0.95 / (2.2e11 * SPACING))
    assert np.sum(stiffness * np.maximum(tops - h, 0.0)) == pytest.approx(force)


def central_differences(flat, u0, height, slide, step):
    """dR_a/du_b of the sliding contact by central differences of step [m], shape
    (N^2 grid nodes a, 3, displacement rows b, 3)."""
    jacobian = np.zeros((flat.grid_size**2, 3) + u0.shape)
    for b in range(len(u0)):
        for c in range(3):
            e = np.zeros_like(u0)
            e[b, c] = step
            forward = flat.respond(u0 + e, height, slide, FRICTIONAL).node_force
            backward = flat.respond(u0 - e, height, slide, FRICTIONAL).node_force
            jacobian[:, :, b, c] = (forward - backward) / (2 * step)
    return jacobian


def test_nodal_tangent_of_a_partial_contact_is_held_for_the_stiff_nodes_only():
    """One peak of an 8 x 8 grid in contact, sliding: node_blocks holds the nodes within two
    grid steps of it (no others), and every node's row of node_stiffness, those left out
    included, matches central differences of the nodal residual."""
    n, pressure = 8, 1e9
    heights = np.zeros((n, n))
    heights[3, 4] = 2 * pressure / PENALTY  # the peak: the flat touches its tributary area only
    flat = anchored(flat_over(heights, tangential=0.1 * PENALTY))
    rng = np.random.default_rng(3)
    u0 = rng.normal(size=(n * n, 3)) * 1e-3 * pressure / PENALTY
    height, flat_slide = heights[3, 4] - pressure / PENALTY, 2 * TAU_C / PENALTY
    response = flat.respond(u0, height, flat_slide, FRICTIONAL)
    assert 0 < np.count_nonzero(response.in_contact) < response.in_contact.size
    nodes, _ = response.node_blocks
    near = [((3 + di) % n) * n + (4 + dj) % n for di in range(-2, 3) for dj in range(-2, 3)]
    assert set(nodes) <= set(near) and 3 * n + 4 in nodes

    jacobian = central_differences(flat, u0, height, flat_slide, 1e-5 * pressure / PENALTY)
    i, j = np.divmod(np.arange(n * n), n)
    neighbours = ((i[:, None] + NEIGHBOURS[:, 0]) % n) * n + (j[:, None] + NEIGHBOURS[:, 1]) % n
    tangent = np.zeros_like(jacobian)
    for a in range(n * n):
        tangent[a, :, neighbours[a], :] = response.node_stiffness[a]
    scale = PENALTY * SPACING**2
    np.testing.assert_allclose(tangent, jacobian, rtol=1e-5, atol=1e-7 * scale)


def test_a_failed_step_returns_to_the_committed_history():
    """Commit keeps a converged step's stick points, slip and contact flags and multipliers;
    after Uzawa updates of a failed step, restore brings the multipliers back, and resume
    returns to an older history whose arrays the later steps did not change."""
    flat = anchored(flat_over())
    start = flat.committed
    first = flat.respond(still(), -1e9 / PENALTY, 3 * TAU_C / PENALTY, FRICTIONAL)
    flat.augment(first)
    flat.commit(first)
    assert flat.committed.multiplier is flat.multiplier
    np.testing.assert_array_equal(flat.committed.stick_offset, first.stick_offset)
    second = flat.respond(still(), -2e9 / PENALTY, 6 * TAU_C / PENALTY, FRICTIONAL)
    flat.augment(second)
    assert not np.array_equal(flat.multiplier, flat.committed.multiplier)
    flat.restore()
    np.testing.assert_array_equal(flat.multiplier, first.node_pressure)
    flat.resume(start)
    assert flat.committed is start and not start.multiplier.any()
    assert not start.stick_offset.any() and start.anchored.all() and not start.slipped.any()


# --- a surface of faces of varying width (the contact-adaptive block) --------------------------

def adaptive_flat(level=1, own=4, tangential=0.1 * PENALTY, peak=None):
    """A flat over the top faces of an adaptive block (``geometry.adaptive``): own x own cells
    of side 2^level SPACING, own cell (1, 2) refined to SPACING; the free surface nodes' rows
    are 0..m-1. ``peak``: a finest grid node raised by that height [m] (else flat)."""
    from roughfriction.geometry.adaptive import adaptive_layout
    from roughfriction.solver.contact_faces import surface_faces

    zone = np.zeros((own, own), bool)
    zone[1, 2] = True
    cells = adaptive_layout(own, SPACING * 2**level, level, zone, MeshOptions()).cells
    n = cells.grid_size
    faces = surface_faces(cells)
    free = np.unique(faces.masters[faces.weights > 0.0])
    heights = np.zeros(len(free))
    if peak is not None:
        heights[np.flatnonzero(free == peak[0])] = peak[1]
    law = ContactLaw(PENALTY, tangential, TAU_C, RAMP)
    return RigidFlat(MPI.COMM_SELF, np.arange(len(free)), np.column_stack(np.divmod(free, n)),
                     cells, heights, SPACING, law, 2), faces


def test_faces_of_varying_width_tile_the_surface_and_carry_a_uniform_pressure():
    flat, faces = adaptive_flat(level=2)
    n = flat.grid_size
    assert not faces.uniform and set(faces.width) == {1, 2, 4}
    total = (n * SPACING) ** 2
    assert flat.surface.face_area.sum() == pytest.approx(total, rel=1e-12)
    assert flat.surface.node_area.sum() == pytest.approx(total, rel=1e-12)
    assert flat.integrate(np.ones(len(flat.surface.point_area))) == pytest.approx(total, rel=1e-12)
    depth = 1e9 / PENALTY  # penetration of the flat [m]: p = 1 GPa everywhere
    response = flat.respond(np.zeros((len(flat.nodes), 3)), -depth, 0.0)
    free = flat.surface.node_free
    np.testing.assert_allclose(response.node_pressure[free], 1e9, rtol=1e-9)
    assert flat.normal_force(response) == pytest.approx(1e9 * total, rel=1e-9)
    assert response.node_force[:, 2].sum() == pytest.approx(1e9 * total, rel=1e-9)
    assert np.all(response.node_force[~free] == 0.0)  # no force where no free node is
    assert flat.area_ratio(response.in_contact) == pytest.approx(1.0)
    maps = flat.node_maps(response)
    assert maps["contact"].sum() == free.sum() < n * n
    np.testing.assert_allclose(maps["contact_fraction"], 1.0)
    gap = maps["gap"].ravel()
    np.testing.assert_allclose(gap[free], -depth, rtol=1e-12)
    assert np.all(np.isnan(gap[~free]))  # no node of its own there
    cell_face = faces.on_grid(np.arange(len(faces.width)))  # each finest cell in its face
    for face, ((i0, j0), width) in enumerate(zip(faces.first, faces.width, strict=True)):
        assert np.all(cell_face[i0:i0 + width, j0:j0 + width] == face)


def test_the_tangent_of_faces_of_varying_width_matches_central_differences():
    """A peak at a free node next to the refined cell, sliding: the nodal tangent on the
    general coupling pattern (``SurfaceQuadrature.neighbours``) matches central differences of the
    nodal residual, hanging corners tied to their masters."""
    pressure = 1e9
    n = 8
    peak = (2 * n + 4, 2 * pressure / PENALTY)  # grid node (2, 4): a corner of the fine cells
    flat, _ = adaptive_flat(level=1, peak=peak)
    flat = anchored(flat)
    m = len(flat.nodes)
    rng = np.random.default_rng(4)
    u0 = rng.normal(size=(m, 3)) * 1e-3 * pressure / PENALTY
    height, slide = peak[1] - pressure / PENALTY, 2 * TAU_C / PENALTY
    response = flat.respond(u0, height, slide, FRICTIONAL)
    assert 0 < np.count_nonzero(response.in_contact) < response.in_contact.size
    row_of = np.full(n * n, -1)
    row_of[flat.owned_grid] = np.arange(m)
    jacobian = central_differences(flat, u0, height, slide, 1e-5 * pressure / PENALTY)
    tangent = np.zeros_like(jacobian)
    for a in flat.owned_grid:
        for slot, b in enumerate(flat.surface.neighbours_of(a)):
            if b >= 0:
                tangent[a, :, row_of[b], :] += response.node_stiffness[a, slot]
    assert np.abs(jacobian).max() > 0.1 * PENALTY * SPACING**2
    np.testing.assert_allclose(tangent, jacobian, rtol=1e-5, atol=1e-7 * PENALTY * SPACING**2)


# --- several ranks, each evaluating the faces near its own nodes -------------------------------

def tangent_entries_of(flat, response, owned):
    """The tangent blocks [N/m] of the ``owned`` nodes keyed by (node a, neighbour b)."""
    nodes, blocks = response.node_blocks
    neighbours = flat.surface.neighbours_of(nodes)
    return {(a, b): blocks[row, slot] for row, a in enumerate(nodes) if a in owned
            for slot, b in enumerate(neighbours[row]) if b >= 0 and blocks[row, slot].any()}


@pytest.mark.mpi
@pytest.mark.parametrize("uniform", [True, False], ids=["uniform", "adaptive"])
def test_ranks_evaluating_their_own_faces_reproduce_the_single_rank_contact(uniform):
    """Ownership in slabs of half the surface over the ranks: each rank's nodal forces, gaps,
    pressures and tangent rows of its own nodes, and the integrals, counts, maps and first flat
    height over all ranks, equal a single rank's over two sliding iterates and an Uzawa
    update (each rank evaluating fewer faces than the surface has)."""
    from roughfriction.geometry.adaptive import adaptive_layout
    from roughfriction.solver.contact_faces import surface_faces

    comm = MPI.COMM_WORLD
    if uniform:
        n, cells = 16, uniform_cells(16)
        grid = np.arange(n * n)
    else:
        zone = np.zeros((12, 12), bool)
        zone[1, 2] = zone[3, 0] = zone[6, 5] = zone[11, 11] = True
        cells = adaptive_layout(12, SPACING * 2, 1, zone, MeshOptions()).cells
        n = cells.grid_size
        faces = surface_faces(cells)
        grid = np.unique(faces.masters[faces.weights > 0.0])
    rng = np.random.default_rng(5)
    heights = rng.normal(size=len(grid)) * 1e-9  # [m]
    displacement = rng.normal(size=(len(grid), 3)) * 1e-11  # [m]
    i, j = np.divmod(grid, n)
    mine = (i // (n // 2)) % comm.size == comm.rank
    law = ContactLaw(PENALTY, 1e-3 * PENALTY, TAU_C, RAMP)

    def flat(communicator, keep):
        return anchored(RigidFlat(communicator, np.arange(np.count_nonzero(keep)),
                                  np.column_stack([i[keep], j[keep]]), cells, heights[keep],
                                  SPACING, law, 2))

    whole, part = flat(MPI.COMM_SELF, np.ones(len(grid), bool)), flat(comm, mine)
    owned = set(part.owned_grid)
    assert len(part.surface.face_ids) < part.surface.num_faces or comm.size == 1
    height = np.quantile(heights, 0.7)
    for predictor in (True, False):
        arguments = (height, 2 * TAU_C / (1e-3 * PENALTY), Trial(True, predictor))
        single = whole.respond(displacement, *arguments)
        shared = part.respond(displacement[mine], *arguments)
        assert 0 < whole.count(single.node_active) < len(grid)
        for name in ("node_gap", "node_pressure", "node_force", "node_height_derivative"):
            np.testing.assert_allclose(getattr(shared, name)[part.owned_grid],
                                       getattr(single, name)[part.owned_grid], rtol=1e-12,
                                       atol=0, err_msg=name)
        expected, got = tangent_entries_of(whole, single, owned), tangent_entries_of(
            part, shared, owned)
        assert expected.keys() == got.keys() and expected
        for key, block in expected.items():
            np.testing.assert_allclose(got[key], block, rtol=1e-12, atol=0)
        for measure in ("normal_force", "tangential_force", "penetration"):
            assert getattr(part, measure)(shared) == pytest.approx(
                getattr(whole, measure)(single), rel=1e-12)
        assert part.area_ratio(shared.in_contact) == pytest.approx(
            whole.area_ratio(single.in_contact), rel=1e-12)
        assert part.count(shared.node_active) == whole.count(single.node_active)
        single_maps, shared_maps = whole.node_maps(single), part.node_maps(shared)
        for name, values in single_maps.items():
            np.testing.assert_allclose(shared_maps[name], values, rtol=1e-12, atol=0,
                                       err_msg=name)
        for f, response in ((whole, single), (part, shared)):
            f.augment(response)
            f.commit(response)
    force = 0.5 * whole.normal_force(single)
    assert part.touching_height(displacement[mine], force, 200e9) == pytest.approx(
        whole.touching_height(displacement, force, 200e9), rel=1e-12)
