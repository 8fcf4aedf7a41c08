"""The coarse-blend-zone benchmark (``benchmarks.blend_zone``): its level cases, a small set
run end to end and its docs table beside the uniform ladder's rows."""

import numpy as np
import pytest
from roughfriction.case import FemCase, Loading
from roughfriction.studies.paper import fem_surface

from benchmarks import blend_zone, calibration_set, doc_tables


def test_a_level_case_refines_every_cell_with_the_coarse_blend_zone():
    case = FemCase(fem_surface("G5", 4, 1), Loading(0.155))
    assert blend_zone.coarse_blend_case(case, 0) is case
    level = blend_zone.coarse_blend_case(case, 2)
    assert level.mesh.blend_zone == "coarse" and level.mesh.refinement.level == 2
    assert np.all(level.mesh.refinement.zone) and level.mesh.refinement.zone.shape == (4, 4)


@pytest.mark.fem
def test_a_small_set_runs_and_its_table_compares_it_with_the_uniform_level(tmp_path):
    """A 4 x 4 window of G5 at F* = 0.155: the coarse 2x level's row beside the uniform 2x
    level's (run here by the calibration set), fewer dofs and a mu_s within 1 %."""
    from mpi4py import MPI

    set_of_one = {"windows": (("G5", 1),), "n": 4, "loads": (0.155,)}
    calibration_set.run_set(tmp_path / "calibration_ladders.csv", MPI.COMM_WORLD, levels=(1,),
                            **set_of_one)
    calibration_set.run_set(tmp_path / "blend_zone.csv", MPI.COMM_WORLD, levels=(1,),
                            level_case=blend_zone.coarse_blend_case, **set_of_one)
    (fine,) = calibration_set.read_rows(tmp_path / "calibration_ladders.csv")
    (coarse,) = calibration_set.read_rows(tmp_path / "blend_zone.csv")
    assert int(coarse["reduced_dofs"]) < int(fine["reduced_dofs"])
    assert float(coarse["mu_s"]) == pytest.approx(float(fine["mu_s"]), rel=1e-2)
    table = doc_tables.blend_zone_table(tmp_path)
    change = 100 * (float(coarse["mu_s"]) - float(fine["mu_s"])) / float(fine["mu_s"])
    assert f"| G5 window 2, 4² | 0.155 | {float(fine['mu_s']):.4f} / {float(coarse['mu_s']):.4f}"\
        f" | {change:+.2f} % (" in table
