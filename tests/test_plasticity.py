"""J2 radial return (NumPy): closed forms of uniaxial strain, consistent tangent, invariants."""

import numpy as np
import pytest
from roughfriction.material import Material
from roughfriction.solver.plasticity import (
    J2State,
    PlasticHistory,
    deviator,
    radial_return,
    von_mises,
)

MATERIAL = Material()


def uniaxial_strain(strain_zz: np.ndarray) -> np.ndarray:
    """Stack of strain tensors diag(0, 0, eps) [-]."""
    strain = np.zeros((len(strain_zz), 3, 3))
    strain[:, 2, 2] = strain_zz
    return strain


def axial_stress_path(strains: np.ndarray, material: Material, elastic: bool = False):
    """sigma_zz [Pa] along a monotonic uniaxial-strain path, committing every increment."""
    state = J2State.virgin(1)
    stresses = []
    for strain in strains:
        tensor = uniaxial_strain(np.array([strain]))
        response = radial_return(deviator(tensor), state, material, elastic)
        state = response.state
        stresses.append(material.bulk_modulus * strain + response.stress_deviator[0, 2, 2])
    return np.array(stresses)


def test_uniaxial_strain_closed_form():
    """Yield at eps_y = S_y / (2 G) with sigma_zz = S_y (1 - nu) / (1 - 2 nu); tangent after yield
    M_t = K + 4/3 G H / (3 G + H) = 168.45 GPa for the paper's material."""
    m = MATERIAL
    G, K, H = m.shear_modulus, m.bulk_modulus, m.hardening_modulus
    yield_strain = m.Sy / (2.0 * G)
    assert yield_strain == pytest.approx(6.5e-3, rel=1e-12)
    plastic_modulus = K + 4.0 / 3.0 * G * H / (3.0 * G + H)
    assert plastic_modulus == pytest.approx(168.45e9, rel=1e-4)  # K + 4/3 G H / (H + 3 G)

    strains = np.linspace(0.0, 4.0 * yield_strain, 41)[1:]
    stresses = axial_stress_path(strains, m)
    yield_stress = m.Sy * (1.0 - m.nu) / (1.0 - 2.0 * m.nu)
    expected = np.where(strains <= yield_strain, (K + 4.0 / 3.0 * G) * strains,
                        yield_stress + plastic_modulus * (strains - yield_strain))
    np.testing.assert_allclose(stresses, expected, rtol=1e-10)
    assert yield_stress == pytest.approx(1.75e9)


def test_elastic_switch_never_yields():
    strains = np.linspace(0.0, 0.05, 11)[1:]
    stresses = axial_stress_path(strains, MATERIAL, elastic=True)
    m = MATERIAL
    np.testing.assert_allclose(stresses, (m.bulk_modulus + 4.0 / 3.0 * m.shear_modulus) * strains,
                               rtol=1e-12)


def random_strains(rng, count, scale):
    strain = rng.normal(0.0, scale, (count, 3, 3))
    return deviator(0.5 * (strain + strain.transpose(0, 2, 1)))


def test_return_map_lands_on_the_hardened_yield_surface_and_flows_isochorically():
    rng = np.random.default_rng(1)
    m = MATERIAL
    strain = random_strains(rng, 200, 0.003)
    response = radial_return(strain, J2State.virgin(200), m)
    assert response.yielding.any() and not response.yielding.all()
    p = response.state.equivalent_plastic_strain
    q = von_mises(response.stress_deviator)
    hardened = m.Sy + m.hardening_modulus * p
    np.testing.assert_allclose(q[response.yielding], hardened[response.yielding], rtol=1e-12)
    assert np.all(q[~response.yielding] <= m.Sy)
    np.testing.assert_allclose(np.trace(response.state.plastic_strain, axis1=1, axis2=2), 0.0,
                               atol=1e-15)
    # s = 2 G (dev eps - eps_p)
    np.testing.assert_allclose(response.stress_deviator,
                               2 * m.shear_modulus * (strain - response.state.plastic_strain),
                               rtol=1e-10, atol=1e-3)


def test_consistent_tangent_matches_finite_differences():
    """d s / d eps = 2 G beta P_dev - 2 G gamma n (x) n, from a plastic committed state."""
    rng = np.random.default_rng(2)
    m = MATERIAL
    committed = radial_return(random_strains(rng, 20, 0.01), J2State.virgin(20), m).state
    strain = random_strains(rng, 20, 0.01)
    response = radial_return(strain, committed, m)
    assert response.yielding.sum() >= 10
    G = m.shear_modulus
    step = 1e-9
    for direction in random_strains(rng, 3, 1.0):
        shifted = radial_return(strain + step * direction, committed, m)
        numeric = (shifted.stress_deviator - response.stress_deviator) / step
        n = response.flow_direction
        analytic = (2 * G * response.beta[:, None, None] * direction
                    - 2 * G * response.gamma[:, None, None]
                    * np.einsum("mij,ij->m", n, direction)[:, None, None] * n)
        np.testing.assert_allclose(numeric, analytic, rtol=1e-5, atol=1e-6 * 2 * G)


def test_a_history_holds_the_yielded_points_and_gives_back_the_dense_state():
    """Strained in blocks of 30 points (some yield, some stay elastic), the sparse history
    holds exactly the points with p > 0 and gives back every block's dense state bit for bit,
    also across two blocks."""
    rng = np.random.default_rng(5)
    strains = random_strains(rng, 90, 0.004)
    strains[::3] *= 1e-3  # elastic points
    dense = radial_return(strains, J2State.virgin(90), MATERIAL).state
    assert 0 < np.count_nonzero(dense.equivalent_plastic_strain) < 90
    history = PlasticHistory.concatenate(
        [PlasticHistory.virgin(90)]
        + [PlasticHistory.of_block(90, first, J2State(dense.plastic_strain[first:first + 30],
                                                      dense.equivalent_plastic_strain[
                                                          first:first + 30]))
           for first in range(0, 90, 30)])
    np.testing.assert_array_equal(history.points,
                                  np.flatnonzero(dense.equivalent_plastic_strain > 0))
    for first, last in ((0, 90), (30, 60), (17, 71)):
        got = history.dense(first, last)
        np.testing.assert_array_equal(got.plastic_strain, dense.plastic_strain[first:last])
        np.testing.assert_array_equal(got.equivalent_plastic_strain,
                                      dense.equivalent_plastic_strain[first:last])
    assert not np.any(PlasticHistory.virgin(4).dense().plastic_strain)
