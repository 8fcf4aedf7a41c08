"""``python -m benchmarks tol`` (``benchmarks.tolerance``): a ladder to a tolerance timed in
elasticity solves, its row against the run's own results file, the table's other rows kept."""

import pytest

from benchmarks import tolerance

pytestmark = pytest.mark.fem


def test_a_case_s_row_is_its_results_file_s_and_the_table_keeps_other_cases(tmp_path,
                                                                             monkeypatch):
    from roughfriction.studies.post import read_run

    monkeypatch.setattr(tolerance, "BENCH_DIR", tmp_path)
    table = tmp_path / "tolerance.csv"
    other = {column: "" for column in tolerance.COLUMNS} | {
        "surface": "G9", "load_star": "0.155", "n": "128", "ranks": "2"}
    tolerance.write_csv([other], table, tolerance.COLUMNS)
    (row,) = tolerance.benchmark_tolerance(8, 2, 0.5, cases=(("G5", 0.155),), table=table)
    summary = read_run(tmp_path / "tol_G5_F0.155_N8_2ranks.h5").summary
    assert row["exit_status"] == 0 and row["mu_s_relative_error"] <= 0.5
    assert row["mu_s"] == summary["mu_s"] and row["mu_s_error"] == summary["mu_s_error"]
    assert row["levels"] == len(summary["levels"]["factor"]) >= 2
    assert row["elastic_solves"] == pytest.approx(row["wall_s"] / row["elastic_solve_s"])
    assert 0 < row["elastic_solve_s"] < row["wall_s"]
    rows = tolerance.read_table(table)
    assert [(r["surface"], r["n"]) for r in rows] == [("G9", "128"), ("G5", "8")]
    assert float(rows[1]["mu_s"]) == pytest.approx(row["mu_s"], rel=1e-12)

