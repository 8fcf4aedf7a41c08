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
