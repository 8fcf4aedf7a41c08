"""The FEM benchmark's table (solver/benchmark.py), with a stand-in for the mpirun runs."""

from roughfriction.scripts import bench_fem as benchmark


def test_rows_of_other_sizes_and_rank_counts_are_kept(tmp_path, monkeypatch):
    monkeypatch.setattr(benchmark, "BENCH_DIR", tmp_path)
    monkeypatch.setattr(benchmark, "run_size", lambda n, ranks: {
        "n": n, "ranks": ranks, "wall_s": 10.0 * n / ranks, "converged": True})
    benchmark.benchmark_sizes([32, 64], ranks=2)
    benchmark.benchmark_sizes([64], ranks=1)
    rows = benchmark.read_rows(tmp_path / "fem.csv")
    assert sorted(rows) == [(32, 2), (64, 1), (64, 2)]
    assert float(rows[64, 1]["wall_s"]) == 640.0
    assert float(rows[64, 2]["wall_s"]) == 320.0
    benchmark.benchmark_sizes([64], ranks=2)  # a rerun replaces its own row only
    assert len(benchmark.read_rows(tmp_path / "fem.csv")) == 3
