"""The memory model that gates a run (solver/memory.py): block sizes counted from the layout,
the estimate and the gate."""

import subprocess
import sys
from pathlib import Path

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from mpi4py import MPI  # noqa: E402
from roughfriction.errors import InputError  # noqa: E402
from roughfriction.geometry.adaptive import adaptive_block, adaptive_layout, block_layout, dilate
from roughfriction.geometry.mesh import MeshOptions  # noqa: E402
from roughfriction.solver import memory  # noqa: E402
from roughfriction.solver.memory import block_size, check_memory, layout_memory_gb  # noqa: E402
from test_adaptive import reduced_dofs  # noqa: E402

pytestmark = pytest.mark.fem

LAYERINGS = [MeshOptions(), MeshOptions(blend_layers=3, fine_layers=1),
             MeshOptions(coarsen=False, growth=2.0), MeshOptions(fine_layers=5),
             MeshOptions(blend_zone="coarse"),
             MeshOptions(blend_layers=3, fine_layers=1, blend_zone="coarse")]


@pytest.mark.parametrize("seed", range(18))
def test_the_block_size_counted_from_the_layout_is_the_built_block_s(seed):
    """Cells and reduced dofs of random layouts (own grids 4 to 12, levels 0 to 3, zones from
    none to all), counted without the block, equal those of the block built."""
    rng = np.random.default_rng(seed)
    n, level = int(rng.choice([4, 6, 8, 12])), int(rng.integers(0, 4))
    zone = dilate(rng.random((n, n)) < rng.choice([0.0, 0.05, 0.15, 0.4, 1.0]),
                  int(rng.integers(0, 2)))
    layout = adaptive_layout(n, 1e-6, level, zone, LAYERINGS[seed % len(LAYERINGS)])
    grid, hexahedra = adaptive_block(layout.cells)
    assert block_size(layout) == (len(hexahedra), reduced_dofs(grid, layout.cells))


def test_the_size_of_an_unrefined_block_is_its_layers_cells():
    """Level 0: each cell layer of stride s has (N / s)^2 cells and the node layer above it as
    many free nodes (the dofs the benchmarks' memory fit counts: 131088 at N = 128)."""
    for n in (16, 128, 512):
        layout = block_layout(n, 1e-6, MeshOptions())
        cells = sum((n // stride) ** 2 for stride in layout.cells.layer_stride)
        assert block_size(layout) == (cells, 3 * cells)
    assert block_size(block_layout(128, 1e-6, MeshOptions()))[1] == 131088


MEASURE_PEAK_MEMORY = """
import numpy as np
from mpi4py import MPI
from roughfriction.case import FemCase, Loading
from roughfriction.geometry.surface import Surface
from roughfriction.solver.run import run
heights = np.random.default_rng(3).normal(0.0, 0.1e-6, ({n}, {n}))
run(FemCase(Surface(heights, 1e-6, "rough"), Loading(0.3, normal_only=True)), MPI.COMM_SELF)
print(next(line.split()[1] for line in open("/proc/self/status") if line.startswith("VmHWM")))
"""


def test_the_memory_estimate_bounds_a_measured_run():
    """The estimate lies above the peak memory of a small run, but within 1.5x of it (else it
    refuses runs that would fit). The run has a process of its own, whose peak is read from
    VmHWM: ru_maxrss would report the larger test process it was started from."""
    if not Path("/proc/self/status").is_file():
        pytest.skip("needs Linux's /proc/self/status")
    n = 16
    result = subprocess.run([sys.executable, "-c", MEASURE_PEAK_MEMORY.format(n=n)],
                            capture_output=True, text=True, check=True)
    peak_gb = int(result.stdout.splitlines()[-1]) / 2**20  # VmHWM is in kB
    estimate = layout_memory_gb(block_layout(n, 1e-6, MeshOptions()), 1)
    assert 1.0 < estimate / peak_gb < 1.5, (estimate, peak_gb)


def test_the_gate_sizes_a_huge_surface_without_allocating_its_grid(monkeypatch):
    """An unrefined block is counted, not laid out cell by cell: N = 20000 (a grid of 4e8
    cells, 0.4 GB per byte-sized map of it) is refused with a few MB traced."""
    import tracemalloc

    monkeypatch.setattr(memory, "available_memory_gb", lambda comm: 8.0)
    tracemalloc.start()
    try:
        with pytest.raises(InputError, match="N = 20000: the FEM run needs about"):
            check_memory(20_000, MeshOptions(), MPI.COMM_SELF)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20e6


def test_a_run_too_large_for_the_available_memory_is_refused(monkeypatch):
    monkeypatch.setattr(memory, "available_memory_gb", lambda comm: 8.0)
    check_memory(256, MeshOptions(), MPI.COMM_SELF)  # ~3.2 GB
    with pytest.raises(InputError, match=r"N = 512: the FEM run needs about 1\d\.?\d* GB"):
        check_memory(512, MeshOptions(), MPI.COMM_SELF)
