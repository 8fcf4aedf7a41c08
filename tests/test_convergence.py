"""Run time against error (benchmarks/convergence.py): the pure parts on synthetic data, and one
tiny end-to-end benchmark (8^2 window, levels 1x and 2x, serial, a temporary run cache)."""

import csv
import math
from pathlib import Path

import numpy as np
import pytest
from roughfriction import __version__
from roughfriction.case import SolverOptions
from roughfriction.studies.paper import fem_case as paper_case
from roughfriction.studies.refinement import level_case
from roughfriction.studies.tables import csv_text

from benchmarks.batch import NOT_IN_CACHE, batch_groups
from benchmarks.convergence import (
    CASES,
    DEFAULTS,
    ErrorPlan,
    Variant,
    benchmark_runs,
    case_reference,
    case_variants,
    error_rows,
    fem_case,
    frontier_lines,
    pareto_front,
    plot_error,
    relative_change,
    run_benchmark,
)

G5_LOW, G5_HIGH, TWO_L, G1_HIGH = CASES


def test_relative_change_is_nan_without_both_values():
    assert relative_change(1.02, 1.0) == pytest.approx(0.02)
    assert math.isnan(relative_change(None, 1.0))
    assert math.isnan(relative_change(1.0, None))
    assert math.isnan(relative_change(1.0, 0.0))


# --- the plan --------------------------------------------------------------------------------

def test_variants_are_the_levels_then_each_knob_alone():
    plan = ErrorPlan(levels=(1, 0), knobs=(("mesh", "fine_layers", (1, 4)),
                                           ("solver", "first_slide", (0.08,))))
    variants = case_variants(G5_LOW, plan)
    assert [v.label for v in variants] == ["1x", "2x", "fine_layers=1", "fine_layers=4",
                                           "first_slide=0.08"]
    assert [v.level for v in variants] == [0, 1, 0, 0, 0]
    assert variants[0] == DEFAULTS
    assert [v.label for v in case_variants(TWO_L, plan)] == ["1x", "2x"]  # not a knob case


def test_fem_case_is_the_figures_case_with_one_option_changed_on_its_level():
    knob = fem_case(G5_LOW, Variant("solver.first_slide", 0.08), 16)
    assert knob.solver == SolverOptions(first_slide=0.08)
    np.testing.assert_array_equal(knob.surface.heights,  # the figures' window
                                  paper_case("G5", 0.155, 16).surface.heights)
    fine, expected = fem_case(TWO_L, Variant("level", 1), 16), level_case(paper_case("2L", 0.5,
                                                                                     16), 1)
    np.testing.assert_array_equal(fine.surface.heights, expected.surface.heights)
    assert fine.mesh == expected.mesh and fine.solver == expected.solver
    assert fine.surface.n == 32 and fine.loading.load_star == 0.5


def test_cases_differing_only_in_the_load_share_a_group():
    plan = ErrorPlan(cases=(G5_LOW, G5_HIGH), n=8, levels=(0, 1), knobs=())
    runs = benchmark_runs(plan)
    groups = batch_groups([fem for _, _, fem in runs])
    assert len(groups) == 2
    assert all({runs[k][0].load_star for k in group} == {0.155, 0.93} for group in groups)


# --- references and rows ---------------------------------------------------------------------

def synthetic_table(mu: dict, converged=lambda label: True):
    """Runs and measurements of the G5 low-load case from mu_s per variant label."""
    plan = ErrorPlan(cases=(G5_LOW,), levels=(0, 1, 2),
                     knobs=(("solver", "first_slide", (0.08,)),))
    runs = [(G5_LOW, variant, None) for variant in case_variants(G5_LOW, plan)]
    measurements = [{"converged": converged(variant.label), "mu_s": mu[variant.label],
                     "area_ratio_normal": 0.2, "junction_growth": 0.1,
                     "wall_s": 2.0**variant.level} for _, variant, _ in runs]
    return runs, measurements, plan


MU = {"1x": 0.30, "2x": 0.26, "4x": 0.25, "first_slide=0.08": 0.303}


def test_rows_compare_with_the_finest_level_and_with_their_comparator():
    rows = {row["label"]: row for row in error_rows(*synthetic_table(MU))}
    coarse = rows["1x"]
    assert coarse["reference"] == "4x" and coarse["mu_s_error"] == pytest.approx(0.2)
    assert coarse["is_default"] and coarse["compared_with"] == ""
    assert rows["2x"]["compared_with"] == "1x"
    assert rows["2x"]["mu_s_change"] == pytest.approx(0.26 / 0.30 - 1)
    assert rows["4x"]["mu_s_error"] == 0.0
    knob = rows["first_slide=0.08"]
    assert knob["compared_with"] == "1x" and not knob["is_default"]
    assert knob["mu_s_change"] == pytest.approx(0.303 / 0.30 - 1)
    assert knob["growth_error"] == 0.0 and knob["area_error"] == 0.0
    # the reference's own error: three levels, observed order log2(0.04 / 0.01) = 2
    assert coarse["reference_order"] == pytest.approx(2.0)
    assert coarse["reference_error"] == pytest.approx((0.01 / 3) / 0.25)


def test_reference_falls_back_to_the_finest_converged_level():
    runs, measurements, plan = synthetic_table(MU, converged=lambda label: label != "4x")
    table = {(case.label, variant): values
             for (case, variant, _), values in zip(runs, measurements, strict=True)}
    reference = case_reference(table, G5_LOW.label, plan.levels)
    assert reference.name == "2x (no converged 4x)" and reference.values["mu_s"] == 0.26
    assert reference.order == 1.0  # two levels: the assumed order
    assert reference.error == pytest.approx(0.04 / 0.26)
    one = case_reference(table, G5_LOW.label, (0,))
    assert one.name == "1x" and math.isnan(one.error)
    assert case_reference({}, G5_LOW.label, plan.levels).name == "none converged"


def test_a_level_above_a_failed_one_is_not_a_reference():
    runs, measurements, plan = synthetic_table(MU, converged=lambda label: label != "2x")
    table = {(case.label, variant): values
             for (case, variant, _), values in zip(runs, measurements, strict=True)}
    assert case_reference(table, G5_LOW.label, plan.levels).name == "1x (no converged 4x)"


@pytest.mark.parametrize("times, errors, front", [
    ([1, 2, 3, 4], [0.4, 0.3, 0.5, 0.1], [0, 1, 3]),
    ([3, 1, 2], [0.1, 0.1, 0.1], [1]),  # equal errors: only the fastest
    ([1, 1, 2], [0.3, 0.2, 0.25], [1]),  # equal times: the more accurate one
    ([1, 2, math.nan], [0.3, 0.2, 0.0], [0, 1]),  # NaN left out
    ([1, 2], [math.nan, 0.2], [1]),
])
def test_pareto_front(times, errors, front):
    assert pareto_front(times, errors) == front


def test_no_point_off_the_front_beats_a_front_point():
    rng = np.random.default_rng(1)
    times, errors = rng.uniform(1, 100, 60), rng.uniform(0.001, 0.1, 60)
    front = pareto_front(times, errors)
    for k in set(range(60)) - set(front):
        assert any(times[j] <= times[k] and errors[j] <= errors[k] for j in front)
    for k in front:
        assert not any(times[j] < times[k] and errors[j] < errors[k] for j in range(60))


def test_frontier_lines_name_the_reference_and_the_front():
    lines = frontier_lines(error_rows(*synthetic_table(MU)))
    assert lines[0].startswith("G5 F*=0.155: reference 4x mu_s = 0.2500")
    front = [line.split()[0] for line in lines[1:]]
    assert front == ["1x", "2x", "4x"]  # the knob is slower than nothing and less accurate
    assert lines[1].endswith("(defaults)")


def test_csv_quotes_messages_and_leaves_none_empty():
    rows = [{"case": "a", "message": "did not converge, at u_x = 1e-08 m", "mu_s": None,
             "wall_s": 1.23456789012345}]
    text = csv_text(rows, ("case", "message", "mu_s", "wall_s"))
    read = list(csv.DictReader(text.splitlines()))
    assert read == [{"case": "a", "message": "did not converge, at u_x = 1e-08 m", "mu_s": "",
                     "wall_s": "1.23456789"}]


def test_a_case_without_any_finite_error_gets_a_labelled_empty_panel(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    drawn = []
    monkeypatch.setattr(plt, "close", drawn.append)
    plot_error(error_rows(*synthetic_table(dict.fromkeys(MU))), tmp_path / "error.png")
    figure = next(item for item in drawn if hasattr(item, "axes"))
    (panel,) = [ax for ax in figure.axes if ax.get_visible()]
    assert [text.get_text() for text in panel.texts] == ["no run with a finite error"]
    assert not panel.lines and not panel.collections
    assert (tmp_path / "error.png").read_bytes()[:4] == b"\x89PNG"
    monkeypatch.undo()
    plt.close(figure)


# --- end to end ------------------------------------------------------------------------------

@pytest.mark.fem
def test_tiny_benchmark_end_to_end(tmp_path, capsys):
    """G5 at F* = 0.155 on an 8^2 window, 1x and 2x and one knob, serial: every run converges,
    the reference has no error and states its own, every row records the version that computed
    it, the outputs are written, a second pass computes nothing (the run cache), and --report
    marks a run missing from the cache."""
    from mpi4py import MPI

    plan = ErrorPlan(cases=(G5_LOW,), n=8, levels=(0, 1),
                     knobs=(("solver", "max_slide_increment", (0.5,)),))
    lines = []
    rows = run_benchmark(plan, tmp_path / "out", MPI.COMM_SELF, tmp_path / "runs", lines.append)
    assert len(rows) == 3
    assert all(row["converged"] for row in rows), [row["message"] for row in rows]
    by_label = {row["label"]: row for row in rows}
    assert by_label["2x"]["mu_s_error"] == 0.0 and by_label["2x"]["mu_s"] > 0
    assert by_label["1x"]["reference_error"] == pytest.approx(
        abs(by_label["1x"]["mu_s"] / by_label["2x"]["mu_s"] - 1))  # order 1 assumed
    for row in rows:
        assert row["wall_s"] > 0 and row["peak_memory_gb"] > 0 and row["ranks"] == 1
        assert row["version"].startswith(f"roughfriction {__version__} (")
    knob = by_label["max_slide_increment=0.5"]  # one knob changed on 1x: against 1x
    assert knob["compared_with"] == "1x"
    assert knob["mu_s_change"] == pytest.approx(knob["mu_s"] / by_label["1x"]["mu_s"] - 1)
    assert by_label["1x"]["mu_s_error"] == pytest.approx(
        by_label["1x"]["mu_s"] / by_label["2x"]["mu_s"] - 1)
    written = list(csv.DictReader((tmp_path / "out" / "error.csv").read_text().splitlines()))
    assert [row["label"] for row in written] == ["1x", "2x", "max_slide_increment=0.5"]
    assert [float(row["mu_s"]) for row in written] == pytest.approx(
        [by_label[row["label"]]["mu_s"] for row in written], rel=1e-9)
    assert (tmp_path / "out" / "error.png").read_bytes()[:4] == b"\x89PNG"
    assert "reference 2x" in capsys.readouterr().out

    entries = sorted(Path(tmp_path / "runs").glob("*.h5"))
    assert len(entries) == 3
    second = run_benchmark(plan, tmp_path / "out", MPI.COMM_SELF, tmp_path / "runs", lines.append)
    assert sorted(Path(tmp_path / "runs").glob("*.h5")) == entries
    assert [row["wall_s"] for row in second] == [row["wall_s"] for row in rows]

    from roughfriction.studies.cache import entry_path, physics_version

    fine = next(fem for _, variant, fem in benchmark_runs(plan) if variant.label == "2x")
    entry_path(tmp_path / "runs", fine, physics_version()).unlink()
    reported = {row["label"]: row for row in run_benchmark(
        plan, tmp_path / "out", MPI.COMM_SELF, tmp_path / "runs", compute=False)}
    assert len(list(Path(tmp_path / "runs").glob("*.h5"))) == 2  # nothing computed
    assert reported["2x"]["message"] == NOT_IN_CACHE and not reported["2x"]["converged"]
    assert reported["1x"]["reference"] == "1x (no converged 2x)"
