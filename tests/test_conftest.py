"""The test suite's own hook: under mpirun, a test failing on one rank stops every rank."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from commands import command_environment

ONE_RANK_FAILS = """
from mpi4py import MPI


def test_fails_on_rank_one_while_rank_zero_waits():
    comm = MPI.COMM_WORLD
    assert comm.rank == 0
    comm.barrier()
"""


@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_a_test_failing_on_one_rank_ends_the_mpi_run_instead_of_hanging(tmp_path):
    """Rank 1 fails before a barrier that rank 0 enters: without the hook rank 0 waits for
    ever (the run would time out here)."""
    shutil.copy(Path(__file__).with_name("conftest.py"), tmp_path / "conftest.py")
    (tmp_path / "test_one_rank_fails.py").write_text(ONE_RANK_FAILS)
    env = command_environment()
    command = ["mpirun", "-n", "2", "--oversubscribe", sys.executable, "-m", "pytest", "-q",
               "-p", "no:cacheprovider", str(tmp_path / "test_one_rank_fails.py")]
    done = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode != 0
    assert "test_one_rank_fails.py::test_fails_on_rank_one_while_rank_zero_waits failed" in (
        done.stderr + done.stdout)
