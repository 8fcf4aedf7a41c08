"""The HDF5 results file (studies/results_file.py): readable as soon as it is written."""

import subprocess
import sys

from commands import command_environment

# A fresh process, FEM stack not imported yet: the writer imports it for the versions.
WRITE_THEN_READ = """
import numpy as np
from roughfriction.solver.results import FemResult, StepRecord
from roughfriction.studies.post import read_run
from roughfriction.studies.results_file import write_hdf5

step = StepRecord("normal", 1.0, 0.0, 0.0, 1e-7, 0.25, 4, 1, 0, 0.0, 2, 0, 0.1)
result = FemResult([step], True, "", True, {"total_s": 0.1}, {"ranks": 1})
write_hdf5("run.h5", {"case": 1}, result, {"contact_normal": np.eye(4, dtype=bool)})
run = read_run("run.h5")
print(run.summary["Fn"], run.converged)
"""


def test_a_file_written_by_a_fresh_process_reads_back_in_it(tmp_path):
    done = subprocess.run([sys.executable, "-c", WRITE_THEN_READ], cwd=tmp_path, text=True,
                          capture_output=True, env=command_environment(), timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[:2] == ["1.0", "True"]
