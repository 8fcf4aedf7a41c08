"""benchmarks.profile: time per phase and Krylov iterations of one FEM run."""

import dolfinx  # noqa: F401  (an install without the FEM fails here)
import numpy as np
import pytest
import roughfriction
from mpi4py import MPI
from roughfriction.case import FemCase, Loading
from roughfriction.geometry.surface import Surface
from roughfriction.solver import stages
from roughfriction.solver.equilibrium import Equilibrium
from roughfriction.solver.linear import LinearSolver
from roughfriction.studies.physics import physics_stamp, physics_version

from benchmarks.profile import MARKS, PHASES, RISE_SHARE, profile_run

pytestmark = pytest.mark.fem


def test_profile_counts_every_newton_solve_and_leaves_the_solver_as_it_was():
    """A random 8 x 8 surface preloaded and slid: every Newton iteration is one tangent and a
    linear solve x1 (and x2 where the flat's height is solved for), the nested phases fit
    inside the residual assembly, the phases fit inside the wall time, every set-up stage's
    memory is noted in run order, and the solver's methods and stage listeners are the same
    afterwards."""
    originals = (Equilibrium.assemble, Equilibrium.assemble_tangent, LinearSolver.solve)
    heights = np.random.default_rng(3).normal(0.0, 1e-7, (8, 8))
    case = FemCase(Surface(heights, 1e-6, "test"), Loading(0.3))
    fem, profile = profile_run(case, MPI.COMM_WORLD, progress=lambda record: None)
    result = fem.result
    fem.equilibrium.destroy()
    assert result.converged, result.message

    phases, solves = profile["phases"], profile["linear_solves"]
    assert {phase.strip() for phase, *_ in PHASES} == set(phases)
    newton = sum(record.newton_iterations for record in result.records)
    assert phases["reduced tangent"]["calls"] >= newton
    x1 = sum(row["solves"] for kind, row in solves.items() if kind.startswith("x1"))
    x2 = sum(row["solves"] for kind, row in solves.items() if kind.startswith("x2"))
    assert x1 >= newton
    # the other tangents are the path slopes before held preload steps, each with an x2 solve
    slopes = phases["reduced tangent"]["calls"] - x1
    assert 0 < slopes < sum(record.phase == "normal" for record in result.records)
    assert slopes <= x2 < x1 + slopes
    assert phases["linear solves"]["calls"] == x1 + x2
    krylov = sum(row["krylov_iterations"] for row in solves.values())
    assert krylov >= sum(record.krylov_iterations for record in result.records)
    residual = phases["residual assembly"]
    assert residual["calls"] == phases["stress update"]["calls"] == phases["contact law"]["calls"]
    nested = phases["stress update"]["seconds"] + phases["contact law"]["seconds"]
    assert nested <= residual["seconds"]
    top = sum(phases[name]["seconds"] for name in ("residual assembly", "reduced tangent",
                                                      "linear solves"))
    assert top <= profile["wall_s"]
    marks = profile["memory"]["phases"]
    assert list(marks) == [phase for phase, _ in MARKS]
    peaks = [row["peak_gb"] for row in marks.values()]
    assert all(row["rss_gb"] > 0.0 for row in marks.values())
    assert peaks == sorted(peaks) and peaks[-1] <= profile["memory"]["peak_gb"]
    # the peak's rises: per rank, each past the last by RISE_SHARE, the last near the final peak
    rises = profile["memory"]["peak_rises_by_rank"]
    assert len(rises) == MPI.COMM_WORLD.size
    stage_names = {name for name in vars(stages).values() if isinstance(name, str)}
    for rank_rises in rises:
        assert rank_rises and all(rise["stage"] in stage_names for rise in rank_rises)
        assert all(later["peak_gb"] > (1 + RISE_SHARE) * earlier["peak_gb"]
                   for earlier, later in zip(rank_rises, rank_rises[1:], strict=False))
    assert sum(rank[-1]["peak_gb"] for rank in rises) <= profile["memory"]["peak_gb"] + 1e-9
    assert (Equilibrium.assemble, Equilibrium.assemble_tangent, LinearSolver.solve) == originals
    assert stages._listeners == []


def test_bench_profile_command_writes_its_json(tmp_path, monkeypatch, capsys):
    """``python -m benchmarks profile G5 --load 0.155 --n 8 --json``: one figure case profiled,
    the same numbers on stdout and in results/bench/profile_G5_F0.155_N8_1ranks.json."""
    import json

    from benchmarks import cli as bench
    from benchmarks.cli import main
    from benchmarks.doc_tables import memory_table

    monkeypatch.setattr(bench, "BENCH_DIR", tmp_path)
    assert main(["profile", "G5", "--load", "0.155", "--n", "8", "--json",
                 "--memory-csv", str(tmp_path / "memory.csv")]) == 0
    record = json.loads(capsys.readouterr().out)
    written = json.loads((tmp_path / "profile_G5_F0.155_N8_1ranks.json").read_text())
    version = ".".join(roughfriction.__version__.split(".")[:2])
    table = memory_table(tmp_path)  # this version's column, from the profile just run
    assert f"| kB per dof ({version}) |" in table
    assert f"| peak (VmHWM, both ranks) | {written['memory']['peak_kb_per_dof']:.3f} |" in table
    assert written["case"] == {"surface": "G5", "load_star": 0.155, "n": 8, "ranks": 1,
                               "level": 0}
    assert written["physics"] == physics_stamp(physics_version())
    assert written["converged"] and written["mu_s"] == pytest.approx(record["mu_s"])
    assert record["linear solves [s]"] == pytest.approx(
        written["phases"]["linear solves"]["seconds"])
    memory = written["memory"]
    assert record["peak memory [GB] / [kB per dof]"] == (
        f"{memory['peak_gb']:.3f} / {memory['peak_kb_per_dof']:.2f}")
    last = memory["peak_rises_by_rank"][0][-1]
    assert record["peak rose after (rank 0: stage call, GB)"].endswith(
        f"{last['stage']} {last['call']}: {last['peak_gb']:.3f}")


def test_bench_profile_runs_a_finer_level_of_the_case(tmp_path, monkeypatch, capsys):
    """``--level 1``: the same case on a mesh twice as fine, in a file named by its factor."""
    import json

    from benchmarks import cli as bench
    from benchmarks.cli import main

    monkeypatch.setattr(bench, "BENCH_DIR", tmp_path)
    for level in (0, 1):
        assert main(["profile", "G5", "--load", "0.155", "--n", "6", "--level", str(level),
                     "--json"]) == 0
    coarse, fine = (json.loads((tmp_path / f"profile_G5_F0.155_N6{part}_1ranks.json")
                               .read_text()) for part in ("", "_2x"))
    assert (coarse["case"]["level"], fine["case"]["level"]) == (0, 1)
    assert fine["memory"]["reduced_dofs"] > 4 * coarse["memory"]["reduced_dofs"]
    assert main(["profile", "G5", "--load", "0.155", "--n", "6", "--level", "-1"]) == 2
    assert "--level must be 0 or more" in capsys.readouterr().err


@pytest.mark.mpi
def test_a_matrix_counts_the_bytes_of_this_ranks_rows():
    """Summed over the ranks, the bytes of a distributed matrix are its nonzeros' and row
    pointers' once (petsc4py's getInfo() sums the ranks by default)."""
    from petsc4py import PETSc

    from benchmarks.profile import NONZERO_BYTES, matrix_bytes

    comm = MPI.COMM_WORLD
    rows = 10
    matrix = PETSc.Mat().createAIJ(((rows, None), (rows, None)), nnz=(1, 0), comm=comm)
    start, end = matrix.getOwnershipRange()
    for row in range(start, end):
        matrix.setValue(row, row, 1.0)
    matrix.assemble()
    expected = NONZERO_BYTES * rows * comm.size + 8 * (rows + 1) * comm.size  # 1 per row
    try:
        assert comm.allreduce(matrix_bytes(matrix)) == expected
    finally:
        matrix.destroy()
