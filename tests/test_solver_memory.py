"""The memory model that gates a run (solver/memory.py)."""

import subprocess
import sys
from pathlib import Path

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import pytest
from mpi4py import MPI  # noqa: E402
from roughfriction.errors import InputError  # noqa: E402
from roughfriction.geometry.mesh import MeshOptions  # noqa: E402
from roughfriction.solver import memory  # noqa: E402
from roughfriction.solver.memory import check_memory, structured_memory_gb  # noqa: E402

pytestmark = pytest.mark.fem


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
    estimate = structured_memory_gb(n, MeshOptions(), 1)
    assert 1.0 < estimate / peak_gb < 1.5, (estimate, peak_gb)


def test_a_run_too_large_for_the_available_memory_is_refused(monkeypatch):
    monkeypatch.setattr(memory, "available_memory_gb", lambda comm: 8.0)
    check_memory(256, MeshOptions(), MPI.COMM_SELF)  # ~3.2 GB
    with pytest.raises(InputError, match=r"N = 512: the FEM run needs about 1\d\.?\d* GB"):
        check_memory(512, MeshOptions(), MPI.COMM_SELF)
