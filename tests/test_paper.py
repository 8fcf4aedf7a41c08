"""The FEM surfaces of the paper's figures (studies.paper): the psi on the axis is meshed."""

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.generate import builtin_surface
from roughfriction.geometry.statistics import surface_statistics
from roughfriction.material import Material
from roughfriction.studies.paper import GAUSSIAN_SURFACES, fem_case, fem_surface


def psi(surface) -> float:
    return surface_statistics(surface, Material()).psi


@pytest.mark.parametrize("n", [8, 16, 32, 64])
def test_gaussian_surfaces_are_meshed_as_windows_with_their_own_psi(n):
    for name in GAUSSIAN_SURFACES:
        whole, meshed = builtin_surface(name), fem_surface(name, n)
        assert meshed.n == n and meshed.spacing == whole.spacing
        assert abs(psi(meshed) / psi(whole) - 1.0) <= 0.03, name
        # a block of the surface's own points, not a re-grid
        start = np.argwhere(whole.heights == meshed.heights[0, 0])[0]
        window = whole.heights[start[0]:start[0] + n, start[1]:start[1] + n]
        np.testing.assert_array_equal(meshed.heights, window)


def test_explicit_windows_and_their_range():
    first, second = fem_surface("G5", 64, window=0), fem_surface("G5", 64, window=1)
    np.testing.assert_array_equal(first.heights, builtin_surface("G5").heights[:64, :64])
    np.testing.assert_array_equal(second.heights, builtin_surface("G5").heights[:64, 64:])
    with pytest.raises(InputError, match="4 windows of 64 x 64 points"):
        fem_surface("G5", 64, window=4)


def test_stand_ins_and_the_native_grid_are_regridded():
    """A window of a self-affine stand-in loses its long wavelengths: it is re-gridded, and the
    smoother surface's psi is what the figures report as psi_fem."""
    whole = builtin_surface("2L")
    meshed = fem_surface("2L", 32)
    assert meshed.n == 32 and meshed.spacing > whole.spacing
    assert psi(meshed) < 0.5 * psi(whole)
    np.testing.assert_array_equal(fem_surface("G5", 128).heights, builtin_surface("G5").heights)
    assert fem_case("G5", 0.155, 32).surface.spacing == whole.spacing


def test_the_curve_runs_slide_in_uniform_small_steps_and_no_other_run_does():
    """Figs. 21 and 29 draw runs whose sliding increments are all CURVE_SLIDE_INCREMENT; the
    same surfaces at the same load in Fig. 22 keep the default adaptive steps."""
    from roughfriction.case import SolverOptions
    from roughfriction.scripts import fig21, fig22, fig29
    from roughfriction.studies.paper import CURVE_LOAD, CURVE_SLIDE_INCREMENT

    curves = fig21.fem_cases(16)
    assert [case.inputs() for case in fig29.fem_cases(16)] == [case.inputs() for case in curves]
    assert {(case.solver.first_slide, case.solver.max_slide_increment) for case in curves} == {
        (CURVE_SLIDE_INCREMENT, CURVE_SLIDE_INCREMENT)}
    assert {case.loading.load_star for case in curves} == {CURVE_LOAD}
    defaults = SolverOptions()
    sweep = [case for case in fig22.fem_cases(16) if case.loading.load_star == CURVE_LOAD]
    assert sweep and all(case.solver == defaults for case in sweep)


@pytest.mark.fem
def test_a_curve_run_records_at_least_twelve_sliding_states_up_to_inception():
    """G5's curve run on a 16^2 window reaches inception (mu_s) through 12 or more recorded
    sliding states; the adaptive default run of the same case through fewer."""
    from mpi4py import MPI
    from roughfriction.solver.run import run
    from roughfriction.studies.paper import CURVE_LOAD, curve_case

    def sliding_states(case):
        result = run(case, MPI.COMM_SELF, progress=lambda record: None).result
        assert result.converged and result.mu_s is not None
        return sum(record.phase == "tangential" for record in result.records)

    curve, default = (sliding_states(case) for case in (curve_case("G5", 16),
                                                        fem_case("G5", CURVE_LOAD, 16)))
    assert curve >= 12 > default
