"""Tests of solver.run: the blend layers a run takes from its surface."""

from dataclasses import replace

import numpy as np
import pytest
from roughfriction.case import FemCase, Loading
from roughfriction.geometry.surface import Surface

SPACING = 0.125e-6  # [m]


def fine_surface_with_a_deep_valley() -> Surface:
    """8 x 8 heights at 0.125 um spacing with one valley 0.28 um deep (2.2 spacings): two
    blend layers of thickness h would invert the cells under it, three do not."""
    heights = np.random.default_rng(5).normal(0.0, 0.01e-6, (8, 8))
    heights[3, 4] = -0.28e-6
    return Surface(heights, SPACING, "fine")


@pytest.mark.fem
def test_a_run_takes_the_blend_layers_its_surface_needs_and_says_so():
    from mpi4py import MPI
    from roughfriction.solver.run import run

    case = FemCase(fine_surface_with_a_deep_valley(), Loading(0.1, normal_only=True))
    assert case.mesh.blend_layers == 2
    lines = []
    fem = run(case, MPI.COMM_SELF, progress=lambda record: lines.append(str(record)))
    assert fem.result.converged
    assert fem.result.sizes["blend_layers"] == 3
    notes = [line for line in lines if "blend layers" in line]
    assert len(notes) == 1 and notes[0].startswith("note: 3 blend layers instead of 2")
    # the gap map: nodes in contact close (to the penalty's penetration), the others open
    gap, contact = fem.maps["gap_normal"], fem.maps["contact_normal"]
    assert contact.any() and not contact.all()
    assert np.all(np.abs(gap[contact]) < 1e-3 * SPACING) and np.all(gap[~contact] > 0.0)


def test_more_blend_layers_than_needed_are_kept():
    pytest.importorskip("dolfinx")
    from roughfriction.solver.run import with_blend_layers_needed

    case = FemCase(fine_surface_with_a_deep_valley(), Loading(0.1))
    deeper = replace(case, mesh=replace(case.mesh, blend_layers=5))
    lines = []
    assert with_blend_layers_needed(deeper, lines.append) is deeper
    assert with_blend_layers_needed(case, lines.append).mesh.blend_layers == 3
    assert len(lines) == 1


def test_peak_memory_is_this_process_not_its_parent():
    """A child started by a process that used 1.5 GB reports its own peak memory."""
    import subprocess
    import sys

    ballast = np.ones(int(1.5 * 2**30 / 8))  # touched: resident in this (parent) process
    code = "from roughfriction.solver.run import peak_memory_gb; print(peak_memory_gb())"
    child = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           check=True)
    assert ballast[-1] == 1.0
    assert float(child.stdout) < 1.0
