"""The unit of cost (``benchmarks.elastic_solve``): one plain elasticity solve of a block,
checked against uniaxial strain under a body force."""

import numpy as np
import pytest
from roughfriction.case import FemCase, Loading, Material
from roughfriction.geometry.surface import Surface

from benchmarks.elastic_solve import BODY_FORCE, elastic_solve

pytestmark = pytest.mark.fem


def test_a_flat_block_under_a_body_force_is_in_uniaxial_strain():
    """A flat periodic block fixed at its base, loaded by a uniform body force b: u_z at the
    top is -b H^2 / (2 M), M = E (1 - nu) / ((1 + nu)(1 - 2 nu)) (Q1 elements are nodally
    exact in this 1D problem); the times are positive and add up."""
    from mpi4py import MPI
    from roughfriction.geometry.adaptive import block_layout
    from roughfriction.solver.memory import block_size
    from roughfriction.studies.refinement import level_case

    material = Material(E=200e9, nu=0.3)
    case = FemCase(Surface(np.zeros((8, 8)), 1e-6, "flat"), Loading(0.155), material)
    result = elastic_solve(case, MPI.COMM_WORLD)
    depth = 8 * 1e-6  # one period (MeshOptions.depth)
    modulus = material.E * (1 - material.nu) / ((1 + material.nu) * (1 - 2 * material.nu))
    expected = -BODY_FORCE * depth**2 / (2 * modulus)
    assert result["top_displacement_m"] == pytest.approx(expected, rel=1e-6)
    assert result["reduced_dofs"] == block_size(block_layout(8, 1e-6, case.mesh))[1]
    assert 0 < result["assembly_s"] and 0 < result["solve_s"] and result["krylov_iterations"] > 0
    assert result["elastic_solve_s"] == pytest.approx(result["assembly_s"] + result["solve_s"])
    finer = elastic_solve(level_case(case, 1), MPI.COMM_WORLD)  # the uniform 2x mesh
    assert finer["top_displacement_m"] == pytest.approx(expected, rel=1e-6)
    assert finer["reduced_dofs"] > 4 * result["reduced_dofs"]
