"""FEM verification against closed forms (small meshes, seconds each).

* J2 uniaxial strain of a flat block pressed by the flat: eps(sigma) within 0.5 %.
* Flat surface sheared under preload: (F_t)max = tau_c A_n within 0.5 %; F_n held.
* Elastic single sinusoid in complete contact: p* = sqrt(2) pi E' Delta / lambda within 3 %;
  below p*, the contact area between the JGH asymptotes; doubling the depth changes p* little.
* Volumetric locking: nearly incompressible, SRI keeps p*, full integration does not.
"""

import functools
import math

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from mpi4py import MPI  # noqa: E402
from roughfriction.case import FemCase, Loading, SolverOptions  # noqa: E402
from roughfriction.geometry.generate import builtin_surface  # noqa: E402
from roughfriction.geometry.mesh import MeshOptions  # noqa: E402
from roughfriction.geometry.surface import (
    Surface,  # noqa: E402
    surface_on_fem_grid,  # noqa: E402
)
from roughfriction.material import Material  # noqa: E402
from roughfriction.solver import stepping  # noqa: E402
from roughfriction.solver.results import at_inception, slip_state  # noqa: E402
from roughfriction.solver.run import run, run_loads  # noqa: E402

pytestmark = pytest.mark.fem

SPACING = 1e-6
PAPER_MATERIAL = Material()
DEFAULT_MESH = MeshOptions()
APPROACH_TOLERANCE = 1e-3  # measured: < 1e-5


def run_case(heights, load, material=PAPER_MATERIAL, mesh=DEFAULT_MESH, normal_only=False,
             **solver):
    case = FemCase(Surface(heights, SPACING, "test"), Loading(load, normal_only), material, mesh,
                   SolverOptions(**solver))
    return run(case, MPI.COMM_WORLD, progress=lambda record: None)


def top_settlement(fem_run) -> np.ndarray:
    """-u_z [m] of the surface nodes owned by this rank."""
    u = fem_run.equilibrium.solid.displacement.x.array.reshape(-1, 3)
    return -u[fem_run.equilibrium.flat.nodes, 2]


# --- J2 uniaxial strain ---------------------------------------------------------------------

@pytest.mark.parametrize("load_star", [1.0, 2.5])
def test_flat_block_follows_the_uniaxial_strain_closed_form(load_star):
    """Periodic sides and a fixed bottom make the pressed flat block a uniaxial-strain test:
    sigma = M eps up to eps_y = S_y / (2 G), then slope M_t = K + 4/3 G H / (3 G + H)."""
    m = Material()
    G, K, H = m.shear_modulus, m.bulk_modulus, m.hardening_modulus
    fem_run = run_case(np.zeros((4, 4)), load_star, normal_only=True)
    assert fem_run.result.converged
    stress = load_star * m.Sy
    yield_strain = m.Sy / (2 * G)
    yield_stress = (K + 4 / 3 * G) * yield_strain
    if stress <= yield_stress:
        expected = stress / (K + 4 / 3 * G)
    else:
        expected = yield_strain + (stress - yield_stress) / (K + 4 / 3 * G * H / (3 * G + H))
    strain = top_settlement(fem_run) / fem_run.block.depth
    np.testing.assert_allclose(strain, expected, rtol=5e-3)
    plastic = fem_run.result.records[-1].plastic_volume_fraction
    assert plastic == (pytest.approx(1.0) if stress > yield_stress else 0.0)


# --- flat surface sheared -------------------------------------------------------------------

@pytest.mark.parametrize("elastic, material", [(True, Material()),
                                               (False, Material(tau_c=0.3e9))])
def test_flat_surface_slides_at_tau_c_times_nominal_area(elastic, material):
    n, load_star = 4, 0.5
    fem_run = run_case(np.zeros((n, n)), load_star, material=material, elastic=elastic)
    result = fem_run.result
    assert result.converged
    nominal_area = (n * SPACING) ** 2
    summary = result.summary()
    assert summary["Ft_max"] == pytest.approx(material.tau_c * nominal_area, rel=5e-3)
    assert summary["area_ratio_sliding"] == summary["area_ratio_normal"] == 1.0
    normal_force = load_star * nominal_area * material.Sy
    tangential = [r for r in result.records if r.phase == "tangential"]
    assert len(tangential) > 3
    for record in tangential:  # force control holds F_n while sliding
        assert record.normal_force == pytest.approx(normal_force, rel=1e-6)


# --- elastic sinusoid -----------------------------------------------------------------------

def sinusoid(n, amplitude):
    """Delta cos(2 pi x / lambda) cos(2 pi y / lambda) with lambda the period n h."""
    phase = 2 * np.pi * np.arange(n) / n
    return amplitude * np.outer(np.cos(phase), np.cos(phase))


def complete_contact_pressure(material: Material, amplitude: float, wavelength: float) -> float:
    """JGH p* = sqrt(2) pi E' Delta / lambda [Pa]."""
    return math.sqrt(2) * math.pi * material.E_star * amplitude / wavelength


def fem_complete_contact_pressure(fem_run, amplitude) -> float:
    """p* of the discrete solid: the cos-cos mode of the pressure over the solid's surface
    deflection in that mode, times Delta (independent of how the contact is enforced)."""
    n = fem_run.block.n
    mode = sinusoid(n, 1.0)
    assert np.all(fem_run.maps["contact_normal"])
    flat = fem_run.equilibrium.flat
    settlement = flat.surface.gather_nodes(top_settlement(fem_run)).reshape(n, n)
    pressure = fem_run.maps["pressure_normal"]
    pressure_amplitude = np.sum(pressure * mode) / np.sum(mode**2)
    deflection_amplitude = np.sum(settlement * mode) / np.sum(mode**2)
    return pressure_amplitude * amplitude / deflection_amplitude


#: Cells per wavelength. The mode decays within lambda / (2 sqrt(2) pi) ~ 2 h below the surface,
#: so p* converges at second order in h (docs/verification.md: -2.3 % at 16, -1.0 % at 20 cells).
N_SINE = 20


def sinusoid_run(material, n=N_SINE, mesh=DEFAULT_MESH, integration="selective", ratio=1.4,
                 linear_solver="auto"):
    """Elastic sinusoid (lambda = n h) pressed to ratio p*: returns (FEM p*, closed-form p*)."""
    amplitude = 0.01 * SPACING
    p_star = complete_contact_pressure(material, amplitude, n * SPACING)
    fem_run = run_case(sinusoid(n, amplitude), ratio * p_star / material.Sy,
                       material=material, mesh=mesh, normal_only=True, elastic=True,
                       integration=integration, normal_increments=1,
                       linear_solver=linear_solver)
    assert fem_run.result.converged
    return fem_complete_contact_pressure(fem_run, amplitude), p_star


def test_sinusoid_complete_contact_pressure():
    fem_p_star, p_star = sinusoid_run(Material())
    assert fem_p_star == pytest.approx(p_star, rel=0.03)


def test_sinusoid_p_star_hardly_depends_on_block_depth():
    shallow, _ = sinusoid_run(Material(), 16, MeshOptions(depth=1.0))
    deep, _ = sinusoid_run(Material(), 16, MeshOptions(depth=2.0))
    assert deep == pytest.approx(shallow, rel=0.01)


def test_coarsened_base_gives_the_result_of_the_full_resolution_base(monkeypatch):
    """The 2:1 coarsened levels (hanging nodes tied bilinearly) leave the contact of a rough
    plastic surface unchanged: the same contact nodes, and the same approach of the flat once the
    uniform compression of the (differently deep) blocks, F* S_y H / M, is taken off. Untied
    hanging nodes would open the coarse interfaces and soften the block. Both preload under
    force control, at the same loads (held steps land at loads that depend on the block's
    stiffness, and the plastic path at them moved the approach by 0.17 %)."""
    monkeypatch.setattr(stepping, "FORCE_CONTROLLED", 1.0)
    heights = np.random.default_rng(7).normal(0.0, 0.1e-6, (16, 16))
    load_star, material = 0.3, PAPER_MATERIAL
    runs = [run_case(heights, load_star, mesh=MeshOptions(coarsen=coarsen), normal_only=True)
            for coarsen in (True, False)]
    assert set(runs[0].block.layer_stride) == {1, 2, 4} and set(runs[1].block.layer_stride) == {1}
    constrained = material.bulk_modulus + 4 / 3 * material.shear_modulus  # M [Pa]

    def local_approach(fem_run):
        """Highest point minus the flat's height, less the uniform compression [m]."""
        assert fem_run.result.converged
        normal = fem_run.result.records[-1]
        uniform = load_star * material.Sy * fem_run.block.depth / constrained
        return heights.max() - heights.mean() - normal.flat_height - uniform

    coarse, full = runs
    assert coarse.result.records[-1].contact_nodes == full.result.records[-1].contact_nodes
    assert local_approach(coarse) == pytest.approx(local_approach(full), rel=APPROACH_TOLERANCE,
                                                   abs=0.0)


@pytest.mark.parametrize("ratio", [0.2, 0.5])
def test_sinusoid_area_lies_between_the_jgh_asymptotes(ratio):
    """Node-counted area below p*. At 16 cells per wavelength it overshoots the upper asymptote
    at p/p* = 0.5 (0.773 > 0.761: a ring of edge nodes), at 32 it lies between the asymptotes
    (0.416 at 0.2, 0.732 at 0.5; the JS fit gives 0.353 and 0.682)."""
    material, n = Material(), 32
    amplitude = 0.01 * SPACING
    p_star = complete_contact_pressure(material, amplitude, n * SPACING)
    fem_run = run_case(sinusoid(n, amplitude), ratio * p_star / material.Sy,
                       normal_only=True, elastic=True, normal_increments=1)
    area = fem_run.result.summary()["area_ratio_normal"]
    low_load = math.pi * (3 * ratio / (8 * math.pi)) ** (2 / 3)  # JGH Eq. 26 (Hertz)
    near_complete = 1 - 3 / (2 * math.pi) * (1 - ratio)  # JGH Eq. 27
    assert low_load <= area <= near_complete


def test_selective_integration_does_not_lock_where_full_integration_does():
    """Nearly incompressible (nu = 0.4999) solid: p* from SRI within 3 % (-0.6 %; -1.0 % at
    nu = 0.3), while fully integrated trilinear hexahedra lock: p* 13 times too large (it needs
    20 p* to close the gaps at all; 4.5 times on the 4-layer mesh of version 0.4). Direct
    solves: GAMG-preconditioned CG does not converge in 1000 iterations on a nearly
    incompressible solid."""
    material = Material(nu=0.4999)
    selective, p_star = sinusoid_run(material, linear_solver="direct")
    full, _ = sinusoid_run(material, integration="full", ratio=20.0, linear_solver="direct")
    assert selective == pytest.approx(p_star, rel=0.03)
    assert full > 2.0 * p_star


# --- penalty independence -------------------------------------------------------------------

def test_penalty_from_a_quarter_to_ten_times_changes_mu_s_by_less_than_one_percent():
    """The augmented Lagrangian (Uzawa to 1e-4 h penetration) removes the penalty from the
    contact area. Below 10 E'/h (a quarter of the default) the Uzawa iterations stop at another
    contact set of this surface (eps = 1 and 4 E'/h: mu_s +25 %), hence the range."""
    heights = np.random.default_rng(7).normal(0.0, 0.1 * SPACING, (8, 8))
    mu = {penalty: run_case(heights, 0.155, penalty=penalty).result.mu_s
          for penalty in (10.0, 40.0, 400.0)}
    assert mu[10.0] == pytest.approx(mu[40.0], rel=0.01)
    assert mu[400.0] == pytest.approx(mu[40.0], rel=0.01)


def test_stick_penalty_times_ten_or_a_tenth_changes_mu_s_by_less_than_one_percent():
    """eps_T = 0.1 eps_N by default (solver.contact: the stiff stick law made Newton flip stick
    and slip near inception). Measured at N = 32: 8L at F* = 0.93 gives mu_s 0.4189, 0.4189,
    0.4187 and G5 at F* = 0.155 0.7565, 0.7564, 0.7566 for eps_T / eps_N = 0.01, 0.1, 1."""
    heights = np.random.default_rng(7).normal(0.0, 0.1 * SPACING, (8, 8))
    mu = {ratio: run_case(heights, 0.155, tangential_penalty=ratio).result.mu_s
          for ratio in (0.01, 0.1, 1.0)}
    assert mu[0.01] == pytest.approx(mu[0.1], rel=0.01)
    assert mu[1.0] == pytest.approx(mu[0.1], rel=0.01)


# --- friction at the edge of a contact patch --------------------------------------------------

@functools.cache
def g5_16_alone(load: float, friction_ramp: float):
    """The result of a standalone run of G5 re-gridded to 16 x 16 at F* = ``load`` with
    p_r = ``friction_ramp`` S_y (cached: the tests below share runs and only read them)."""
    case = FemCase(surface_on_fem_grid(builtin_surface("G5"), 16), Loading(load),
                   solver=SolverOptions(friction_ramp=friction_ramp))
    return run(case, MPI.COMM_WORLD, progress=lambda record: None).result


def assert_at_inception(result, min_contact_nodes: int) -> None:
    """Converged at inception (``solver.results.at_inception``) with more than
    ``min_contact_nodes`` contact nodes."""
    assert result.converged, result.message
    last = result.records[-1]
    assert last.contact_nodes > min_contact_nodes
    assert at_inception(slip_state(result.records), SolverOptions().stuck_shear_tolerance)


def test_the_ramp_pressure_leaves_mu_s_unchanged_up_to_twice_the_default():
    """G5 on 16 x 16 at F* = 0.62 (~130 contact nodes) slides to inception with the paper's pure
    cap (p_r = 0) and p_r = 0.0125, 0.025 (default) and 0.05 S_y to the same mu_s (measured:
    equal to 16 digits; every contact node carries more than 0.05 S_y at inception), while a
    ramp of 0.2 S_y lowers it (measured: -1.7 %), so the ramp is a regularisation the result
    does not see."""
    mu = {}
    for ramp in (0.0, 0.0125, 0.025, 0.05, 0.2):
        result = g5_16_alone(0.62, ramp)
        assert_at_inception(result, 100)
        mu[ramp] = result.mu_s
    for ramp in (0.0, 0.0125, 0.05):
        assert mu[ramp] == pytest.approx(mu[0.025], rel=1e-9)
    assert mu[0.2] < 0.99 * mu[0.025]  # the ramp acts when it reaches the contact pressures


def test_newton_accepts_a_residual_floor_near_inception():
    """G5 on 16 x 16 at F* = 0.62 with p_r = 0.05 S_y: near inception Newton stagnated at
    1.03-1.2e-6 F_n, just above the 1e-6 F_n tolerance, and the run ended with 205 of 209
    nodes slipping once the slide increment could not be cut further. A floor within
    the residual floor times the tolerance is accepted, and the run reaches inception."""
    assert_at_inception(g5_16_alone(0.62, 0.05), 100)


# --- shared normal loading path ---------------------------------------------------------------

def test_loads_sharing_one_preload_match_standalone_runs():
    """run_loads branches the sliding of each load from one normal loading path. Each branch
    keeps only its own records; the first load's path is a standalone run's, and a later load
    matches its standalone run to within the step discretisation of the path (G5 on 16 x 16,
    ~70-130 contact nodes; the preload areas to within two integration points). With a dozen
    contact nodes (an 8 x 8 random surface) the two paths
    differed by 9 % in mu_s: which node touches last before all slip depends on the steps
    there, the low-resolution regime the paper also calls unreliable."""
    surface = surface_on_fem_grid(builtin_surface("G5"), 16)
    case = FemCase(surface, Loading(0.155))
    low, high = run_loads(case, [0.62, 0.155], MPI.COMM_WORLD, progress=lambda record: None)
    alone = {load: g5_16_alone(load, case.solver.friction_ramp) for load in (0.155, 0.62)}

    assert high.result.summary()["mu_s"] == alone[0.155].summary()["mu_s"]
    assert [r.phase for r in high.result.records] == [r.phase for r in alone[0.155].records]
    shared = low.result
    assert shared.converged
    normal = [r for r in shared.records if r.phase == "normal"]
    assert normal[-1].normal_force == pytest.approx(case.nominal_area * 0.62 * case.material.Sy)
    assert [r.phase for r in shared.records] == sorted(
        (r.phase for r in shared.records), key=["normal", "tangential"].index)
    for key in ("mu_s", "area_ratio_sliding"):
        assert shared.summary()[key] == pytest.approx(alone[0.62].summary()[key], rel=0.01), key
    # the preload areas differ by whole integration points (measured: 2 of 1024, 1.0 %)
    point_area = 1.0 / (16 * 16 * case.solver.contact_points**2)
    assert abs(shared.summary()["area_ratio_normal"] - alone[0.62].summary()["area_ratio_normal"]
               ) <= max(0.01 * alone[0.62].summary()["area_ratio_normal"], 2 * point_area)
