"""Two ranks reproduce the serial run (run under ``mpirun -n 2 python -m pytest -m mpi``)."""

import json
import subprocess
import sys
from pathlib import Path

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import numpy as np
import pytest
from commands import command_environment, command_outcome
from mpi4py import MPI  # noqa: E402

pytestmark = [pytest.mark.mpi, pytest.mark.fem]

ROOT = Path(__file__).resolve().parent.parent

# A small rough case: 8 x 8 Gaussian heights (rms 0.1 um at 1 um spacing), F* = 0.3.
CASE = """
import numpy as np
from roughfriction.geometry.surface import Surface
from roughfriction.case import FemCase, Loading, SolverOptions

heights = np.random.default_rng(7).normal(0.0, 0.1e-6, (8, 8))
case = FemCase(Surface(heights, 1e-6, "mpi"), Loading(0.3),
               solver=SolverOptions(linear_solver="direct", residual_tolerance=1e-10))
"""

SERIAL = CASE + """
import json
from mpi4py import MPI
from roughfriction.solver.run import run
records = run(case, MPI.COMM_SELF, progress=lambda record: None).result.records
print(json.dumps([[r.phase, r.slide, r.tangential_force, r.normal_force, r.contact_nodes]
                  for r in records]))
"""


def curve(records):
    return [[r.phase, r.slide, r.tangential_force, r.normal_force, r.contact_nodes]
            for r in records]


def test_two_ranks_equal_serial():
    comm = MPI.COMM_WORLD
    assert comm.size == 2, "run under mpirun -n 2"
    namespace = {}
    exec(CASE, namespace)
    from roughfriction.solver.run import run

    parallel = curve(run(namespace["case"], comm, progress=lambda record: None).result.records)
    serial = None
    if comm.rank == 0:
        output = subprocess.run([sys.executable, "-c", SERIAL], cwd=ROOT, capture_output=True,
                                text=True, check=True, env=command_environment()).stdout
        serial = json.loads(output.strip().splitlines()[-1])
    serial = comm.bcast(serial, root=0)

    assert len(parallel) == len(serial), (len(parallel), len(serial))
    assert [r[0] for r in parallel] == [r[0] for r in serial]
    assert [r[4] for r in parallel] == [r[4] for r in serial]
    values = np.array([r[1:4] for r in parallel])
    expected = np.array([r[1:4] for r in serial])
    np.testing.assert_allclose(values[:, 0], expected[:, 0], rtol=1e-12)  # same u_x steps
    scale = np.abs(expected[:, 1]).max()
    np.testing.assert_allclose(values[:, 1], expected[:, 1], rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(values[:, 2], expected[:, 2], rtol=1e-6)
    assert serial[-1][0] == "tangential"


def test_a_converged_two_rank_run_converges_again():
    """G2 at F* = 0.155, the low-load case where patches are smallest (a 16 x 16 window at its
    own spacing, iterative solver): three repeats on 2 ranks all converge to the same mu_s."""
    from roughfriction.solver.run import run
    from roughfriction.studies.paper import fem_case

    case = fem_case("G2", 0.155, 16)
    mu = []
    for _ in range(3):
        result = run(case, MPI.COMM_WORLD, progress=lambda record: None).result
        assert result.converged, result.message
        mu.append(result.mu_s)
    np.testing.assert_allclose(mu, mu[0], rtol=1e-6)


def test_the_factors_memory_bound_is_shared_by_the_ranks_of_a_node(monkeypatch):
    """MUMPS's bound per rank: the share of the least memory any rank of the node sees, divided
    among the node's ranks (both ranks of ``mpirun -n 2`` on one node), the same on each."""
    from roughfriction.solver import linear

    comm = MPI.COMM_WORLD
    monkeypatch.setattr(linear, "node_memory_available_gb", lambda: 10.0 + comm.rank)
    bound = linear.factor_memory_mb(comm)
    assert bound == int(linear.FACTOR_MEMORY_SHARE * 10.0 / 2 * 1024)
    assert comm.allgather(bound) == [bound, bound]


#: Seconds a two-rank ``fem`` command may take to refuse a bad path (a hang fails here).
REFUSAL_TIMEOUT_S = 240


@pytest.mark.parametrize("arguments, message", [
    (["G5", "--output", "a_file/run.h5"], "a_file is not a directory"),
    (["G5", "--xdmf", "a_file/fields"], "a_file is not a directory"),
    (["G5", "--config", "missing.toml"], "cannot read case file missing.toml"),
    (["missing.npy", "--size", "7um"], "missing.npy"),
])
def test_a_bad_path_stops_every_rank_with_one_line(arguments, message, tmp_path):
    """``mpirun -n 2 roughfriction fem`` with an input or output path it cannot use: exit 2 and
    one error line, before any solve, with no rank left waiting for another."""
    comm = MPI.COMM_WORLD
    outcome = None
    if comm.rank == 0:
        (tmp_path / "a_file").write_text("")
        command = ["mpirun", "-n", "2", "--oversubscribe", sys.executable, "-m",
                   "roughfriction.scripts.cli", "fem", *arguments, "--n", "8", "--load", "0.3",
                   "--elastic", "--normal-only"]
        outcome = command_outcome(command, tmp_path, REFUSAL_TIMEOUT_S)
    outcome = comm.bcast(outcome, root=0)
    assert outcome is not None, f"no exit within {REFUSAL_TIMEOUT_S} s: a rank hangs"
    status, stderr = outcome
    errors = [line for line in stderr.splitlines() if line.startswith("roughfriction:")]
    assert status == 2, stderr
    assert len(errors) == 1 and message in errors[0], stderr
    assert "Traceback" not in stderr and "Fn=" not in stderr  # no load step was solved
