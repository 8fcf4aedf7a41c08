"""The contact and friction law of the surface nodes against the rigid flat (NumPy, one rank)."""

import numpy as np
import pytest
from mpi4py import MPI
from roughfriction.solver.contact import RigidFlat

TAU_C = 577e6  # [Pa]
RAMP = 10e6  # [Pa]
PENALTY = 1e18  # [Pa/m]
AREA = 1e-12  # [m^2]


def flat_over(heights, ramp=RAMP, tangential=PENALTY):
    """A flat over len(heights) surface nodes whose displacement rows are 0, 1, ...
    (``tangential``: the stick penalty eps_T [Pa/m])."""
    n = len(heights)
    return RigidFlat(MPI.COMM_SELF, np.arange(n), np.column_stack([np.arange(n), np.zeros(n)]),
                     n, np.asarray(heights, float), AREA, PENALTY, TAU_C, ramp, tangential)


def anchored(flat):
    """Every node in contact and stuck at the last converged step (after a preload)."""
    flat.anchored[:] = True
    return flat


def test_shear_cap_rises_with_pressure_up_to_tau_c():
    flat = flat_over([0.0])
    cap = flat.shear_cap(np.array([-1e6, 0.0, 2.5e6, RAMP, 1e9]))
    np.testing.assert_allclose(cap, [0.0, 0.0, 0.25 * TAU_C, TAU_C, TAU_C])
    assert flat_over([0.0], ramp=0.0).shear_cap(np.array([1.0]))[0] == TAU_C


@pytest.mark.parametrize("pressure", [2.5e6, 1e9])
def test_slipping_node_carries_the_cap_along_the_trial_direction(pressure):
    flat = anchored(flat_over([0.0]))
    height = -pressure / PENALTY  # gap -p / eps: the node presses with p
    slide = 3 * TAU_C / PENALTY  # trial traction 3 tau_c along x
    response = flat.respond(np.zeros((1, 3)), height, slide, friction=True)
    cap = TAU_C * min(1.0, pressure / RAMP)
    assert response.slipping[0] and response.in_contact[0]
    np.testing.assert_allclose(response.traction[0], [cap, 0.0])
    assert response.pressure[0] == pytest.approx(pressure)
    # residual: the node is dragged along +x and pushed down
    np.testing.assert_allclose(response.force[0], [-cap * AREA, 0.0, pressure * AREA])
    # slip tangent: no stiffness along the slip, the cap's share across it; below p_r the
    # traction also follows the pressure (x row, z column), which makes the block non-symmetric
    block = response.stiffness[0]
    np.testing.assert_allclose(block[:2, :2], block[:2, :2].T)
    assert block[0, 0] == pytest.approx(0.0, abs=1e-12 * PENALTY * AREA)
    assert block[1, 1] == pytest.approx(PENALTY * AREA * cap / (3 * TAU_C))
    slope = TAU_C / RAMP if pressure < RAMP else 0.0
    assert block[0, 2] == pytest.approx(-AREA * PENALTY * slope)
    assert response.symmetric == (pressure >= RAMP)
    # the stick point is dragged to the cap's distance behind the flat
    np.testing.assert_allclose(response.stick_offset[0], [slide - cap / PENALTY, 0.0])


@pytest.mark.parametrize("tangential", [PENALTY, 0.1 * PENALTY])
def test_node_below_its_cap_sticks_with_the_full_stick_penalty(tangential):
    flat = anchored(flat_over([0.0], tangential=tangential))
    slide = 0.5 * TAU_C / tangential
    response = flat.respond(np.zeros((1, 3)), -1e9 / PENALTY, slide, friction=True)
    assert not response.slipping[0]
    np.testing.assert_allclose(response.traction[0], [0.5 * TAU_C, 0.0])
    np.testing.assert_allclose(response.stiffness[0][:2, :2], tangential * AREA * np.eye(2))
    assert response.stiffness[0][2, 2] == pytest.approx(PENALTY * AREA)
    np.testing.assert_allclose(response.stick_offset[0], [0.0, 0.0], atol=1e-12 * slide)


def test_slipping_node_drags_its_stick_point_to_the_cap_over_the_stick_penalty():
    """On commit the stick point lies tau_c / eps_T behind the flat: a softer eps_T widens the
    stick cone, and the next step's trial traction starts from the cap again."""
    for tangential in (PENALTY, 0.1 * PENALTY):
        flat = anchored(flat_over([0.0], tangential=tangential))
        slide = 3 * TAU_C / tangential
        response = flat.respond(np.zeros((1, 3)), -1e9 / PENALTY, slide, friction=True)
        assert response.slipping[0]
        np.testing.assert_allclose(response.stick_offset[0], [slide - TAU_C / tangential, 0.0])
        flat.commit(response)
        again = flat.respond(np.zeros((1, 3)), -1e9 / PENALTY, slide, friction=True)
        np.testing.assert_allclose(again.traction[0], [TAU_C, 0.0])


def test_node_at_vanishing_pressure_carries_vanishing_shear():
    """The edge node that had no consistent state under the pure cap: as its pressure tends to 0
    its shear does too, with the ramp; without it the shear stays at tau_c."""
    slide = 0.9 * TAU_C / PENALTY
    for pressure in (1e6, 1e3, 1.0):
        with_ramp = anchored(flat_over([0.0])).respond(
            np.zeros((1, 3)), -pressure / PENALTY, slide, friction=True)
        pure = anchored(flat_over([0.0], ramp=0.0)).respond(
            np.zeros((1, 3)), -pressure / PENALTY, slide, friction=True)
        assert with_ramp.traction[0, 0] == pytest.approx(TAU_C * pressure / RAMP)
        assert pure.traction[0, 0] == pytest.approx(0.9 * TAU_C)


def test_frictionless_open_and_newly_touching_nodes_carry_no_shear():
    flat = anchored(flat_over([0.0, -1e-9, 0.0]))
    flat.anchored[2] = False  # touches in this step
    slide = 0.5 * TAU_C / PENALTY
    height = -1e9 / PENALTY  # node 1 lies 1 nm below: open
    response = flat.respond(np.zeros((3, 3)), height, slide, friction=True)
    np.testing.assert_array_equal(response.in_contact, [True, False, True])
    np.testing.assert_allclose(response.traction[1:], 0.0)
    assert response.traction[0, 0] > 0
    frictionless = flat.respond(np.zeros((3, 3)), height, slide, friction=False)
    np.testing.assert_allclose(frictionless.traction, 0.0)


@pytest.mark.parametrize("tangential", [PENALTY, 0.1 * PENALTY])
@pytest.mark.parametrize("pressure, slide", [(2.5e6, 3.0), (1e9, 3.0), (1e9, 0.5), (2.5e6, 0.5)])
def test_tangent_and_height_derivative_match_finite_differences(pressure, slide, tangential):
    """dR/du (3 x 3 block) and dR/dh of a node slipping below and above p_r and sticking, against
    central differences of the residual force (the trial traction at 30 degrees from x), with
    eps_T = eps_N and eps_T = eps_N / 10."""
    flat = anchored(flat_over([0.0], tangential=tangential))
    flat.stick_offset[:] = [[0.0, -0.5 * slide * TAU_C / tangential]]
    height, flat_slide = -pressure / PENALTY, slide * TAU_C / tangential * np.sqrt(0.75)
    response = flat.respond(np.zeros((1, 3)), height, flat_slide, friction=True)
    step = 1e-4 * pressure / PENALTY  # [m], well inside every regime

    def force(u=None, h=height):
        u = np.zeros(3) if u is None else u
        return flat.respond(u[None, :], h, flat_slide, friction=True).force[0]

    for j in range(3):
        e = np.eye(3)[j] * step
        column = (force(e) - force(-e)) / (2 * step)
        np.testing.assert_allclose(response.stiffness[0][:, j], column, rtol=1e-6,
                                   atol=1e-9 * PENALTY * AREA)
    column = (force(h=height + step) - force(h=height - step)) / (2 * step)
    np.testing.assert_allclose(response.height_derivative[0], column, rtol=1e-6,
                               atol=1e-9 * PENALTY * AREA)
