"""Run time against error (solver/convergence.py): the pure parts on synthetic data, and one
tiny end-to-end benchmark (N = 4 and 8, serial, a temporary run cache)."""

import csv
import math
from pathlib import Path

import numpy as np
import pytest
from roughfriction.case import SolverOptions
from roughfriction.geometry.generate import builtin_surface
from roughfriction.geometry.surface import surface_on_fem_grid
from roughfriction.material import Material
from roughfriction.studies.batch import NOT_IN_CACHE, batch_groups, csv_text
from roughfriction.studies.convergence import (
    CASES,
    SINUSOID_SLOPE,
    ErrorPlan,
    Variant,
    benchmark_runs,
    case_variants,
    check_lines,
    chosen_resolution,
    doubling_changes,
    error_rows,
    fem_case,
    finest_converged,
    mark_defaults,
    mesh_lines,
    mode_amplitude,
    pareto_front,
    plot_error,
    relative_change,
    run_benchmark,
    sinusoid_p_star,
    sinusoid_surface,
)

G5_LOW, G5_HIGH, TWO_L, SINE = CASES


# --- errors ----------------------------------------------------------------------------------

def test_relative_change_is_nan_without_both_values():
    assert relative_change(1.02, 1.0) == pytest.approx(0.02)
    assert math.isnan(relative_change(None, 1.0))
    assert math.isnan(relative_change(1.0, None))
    assert math.isnan(relative_change(1.0, 0.0))


def test_mode_amplitude_recovers_the_cos_cos_mode_under_a_mean_and_other_modes():
    n = 16
    phase = 2 * np.pi * np.arange(n) / n
    values = 3.0 + 0.7 * np.outer(np.cos(phase), np.cos(phase)) + 0.2 * np.outer(
        np.sin(2 * phase), np.ones(n))
    assert mode_amplitude(values) == pytest.approx(0.7, rel=1e-12)


def test_sinusoid_surface_has_the_declared_slope_and_closed_form_p_star():
    surface = sinusoid_surface(32)
    assert mode_amplitude(surface.heights) == pytest.approx(SINUSOID_SLOPE * surface.period)
    material = Material()
    expected = math.sqrt(2) * math.pi * material.E_star * SINUSOID_SLOPE
    assert sinusoid_p_star(material) == pytest.approx(expected)
    # the case is pressed beyond p*: complete contact is expected
    assert SINE.load_star * material.Sy > 1.2 * sinusoid_p_star(material)


# --- the plan --------------------------------------------------------------------------------

def test_variants_are_the_sizes_the_spectral_runs_and_each_knob_alone():
    plan = ErrorPlan(sizes=(16, 32, 64), base_n=16,
                     variants=(("mesh", "blend_layers", (2, 8)),
                               ("solver", "first_slide", (0.01,))))
    rough = case_variants(G5_LOW, plan)
    assert [v.label for v in rough] == ["N=16", "N=32", "N=64", "16^2 on 32", "32^2 on 64",
                                        "blend_layers=2", "blend_layers=8", "first_slide=0.01"]
    assert all(v.n == 16 for v in rough if "." in v.knob)
    analytic = case_variants(SINE, plan)  # no spectral run, no sliding-only knob
    assert [v.label for v in analytic] == ["N=16", "N=32", "N=64", "blend_layers=2",
                                           "blend_layers=8"]


def test_fem_case_changes_one_option_and_keeps_the_others():
    case = fem_case(G5_LOW, Variant("mesh.blend_layers", 2, 8))
    assert case.mesh.blend_layers == 2 and case.mesh.growth == 1.4
    assert case.solver == SolverOptions() and case.loading.load_star == 0.155
    assert case.surface.n == 8
    penalty = fem_case(SINE, Variant("solver.penalty", 100.0, 8))
    assert penalty.solver.penalty == 100.0 and penalty.solver.elastic
    assert penalty.loading.normal_only


def test_spectral_run_is_the_coarse_surface_on_the_finer_grid():
    fine = fem_case(TWO_L, Variant("spectral", 8, 16)).surface
    coarse = surface_on_fem_grid(builtin_surface("2L"), 8)
    assert fine.n == 16 and fine.period == pytest.approx(coarse.period)
    np.testing.assert_allclose(fine.heights[::2, ::2], coarse.heights, atol=1e-15)


def test_groups_share_the_preload_of_cases_differing_only_in_the_load():
    plan = ErrorPlan(cases=(G5_LOW, G5_HIGH), sizes=(8, 4), base_n=4, variants=())
    runs = benchmark_runs(plan)
    groups = batch_groups([fem for _, _, fem in runs])
    sizes = [[runs[k][2].surface.n for k in group] for group in groups]
    assert sizes == [[4, 4], [8, 8], [8, 8]]  # N=4; N=8; the 4^2 surface on 8; smallest first
    assert all({runs[k][0].load_star for k in group} == {0.155, 0.93} for group in groups)


# --- rows, the resolution check, the Pareto front ----------------------------------------------

def synthetic_rows(mu):
    """Rows of one sliding case from mu_s per variant label, and of the sinusoid."""
    plan = ErrorPlan(cases=(G5_LOW, SINE), sizes=(8, 16, 32), base_n=8,
                     variants=(("solver", "penalty", (100.0,)),))
    runs = [(case, variant, None) for case in plan.cases for variant in case_variants(case,
                                                                                      plan)]
    measurements = []
    for case, variant, _ in runs:
        if case.analytic:
            measurements.append({"mu_s": None, "area_ratio_normal": 1.0, "junction_growth": None,
                                 "p_star_Pa": sinusoid_p_star() * (1 - 8 / variant.n**2),
                                 "wall_s": float(variant.n)})
        else:
            measurements.append({"converged": mu[variant.label] is not None,
                                 "mu_s": mu[variant.label], "area_ratio_normal": 0.2,
                                 "junction_growth": 0.1, "p_star_Pa": None,
                                 "wall_s": float(variant.n)})
    return error_rows(runs, measurements, plan)


MU = {"N=8": 0.55, "N=16": 0.51, "N=32": 0.50, "8^2 on 16": 0.54, "16^2 on 32": 0.505,
      "penalty=100": 0.56}


def test_rows_compare_with_the_finest_run_and_with_their_comparator():
    rows = {(row["case"], row["label"]): row for row in synthetic_rows(MU)}
    coarse = rows[G5_LOW.label, "N=8"]
    assert coarse["reference"] == "N=32" and coarse["mu_s_error"] == pytest.approx(0.1)
    assert coarse["compared_with"] == "N=16"
    assert coarse["mu_s_change"] == pytest.approx(0.55 / 0.51 - 1)
    assert rows[G5_LOW.label, "N=32"]["mu_s_error"] == 0.0
    assert rows[G5_LOW.label, "N=32"]["compared_with"] == ""
    assert rows[G5_LOW.label, "16^2 on 32"]["compared_with"] == "N=16"
    penalty = rows[G5_LOW.label, "penalty=100"]
    assert penalty["compared_with"] == "N=8"
    assert penalty["mu_s_change"] == pytest.approx(0.56 / 0.55 - 1)
    assert penalty["growth_error"] == 0.0 and penalty["area_error"] == 0.0
    sine = rows[SINE.label, "N=8"]
    assert sine["reference"] == "closed form"
    assert sine["p_star_error"] == pytest.approx(-8 / 64)
    assert sine["area_error"] == 0.0 and math.isnan(sine["mu_s_error"])


def test_reference_falls_back_to_the_finest_converged_run():
    table = {("a", Variant("n", n, n)): {"converged": n < 32, "mu_s": 0.5} for n in (8, 16, 32)}
    values, name = finest_converged(table, "a", (8, 16, 32))
    assert values is table["a", Variant("n", 16, 16)] and name == "N=16 (no converged N=32)"
    table["a", Variant("n", 32, 32)]["converged"] = True
    assert finest_converged(table, "a", (8, 16, 32))[1] == "N=32"
    assert finest_converged({}, "a", (8, 16, 32)) == ({}, "none converged")


def test_resolution_check_uses_sliding_cases_only():
    changes = doubling_changes(synthetic_rows(MU))
    assert list(changes) == [8, 16]
    assert set(changes[8]) == {G5_LOW.label}
    assert changes[16][G5_LOW.label] == pytest.approx(0.51 / 0.50 - 1)


@pytest.mark.parametrize("changes, chosen", [
    ({16: {"a": 0.05, "b": 0.01}, 32: {"a": 0.015, "b": -0.01}, 64: {"a": 0.004, "b": 0.0}}, 32),
    ({16: {"a": 0.01}, 32: {"a": 0.03}, 64: {"a": 0.01}}, 64),  # a lucky pass at 16 is not enough
    ({16: {"a": 0.01}, 32: {"a": math.nan}}, None),  # a failed run fails the check
    ({16: {"a": 0.05}, 32: {"a": -0.021}}, None),
    ({16: {"a": 0.02}}, 16),  # the tolerance itself passes
])
def test_chosen_resolution(changes, chosen):
    assert chosen_resolution(changes, 0.02) == chosen


def test_check_lines_print_every_doubling_and_the_verdict():
    changes = {16: {"a": 0.05}, 32: {"a": 0.01}}
    lines = check_lines(changes, 32, 0.02)
    assert lines[2].split()[0] == "16" and lines[2].endswith("FAIL") and "+5.00%" in lines[2]
    assert lines[3].endswith("PASS")
    assert lines[-1].startswith("default resolution: N = 32")
    assert "NONE" in check_lines(changes, None, 0.02)[-1]
    failed = check_lines({16: {"a": math.nan}}, None, 0.02)[2]
    assert "no mu_s" in failed and failed.endswith("FAIL")


def test_mesh_lines_compare_the_spectral_run_with_its_coarse_surface():
    lines = mesh_lines(synthetic_rows(MU))
    assert len(lines) == 3  # the heading and the sliding case's two runs (not the sinusoid)
    assert lines[1].split()[:3] == ["8^2", "on", "16"] and G5_LOW.label in lines[1]
    assert f"{100 * (0.54 / 0.55 - 1):+.2f}%" in lines[1]
    assert f"{100 * (0.505 / 0.51 - 1):+.2f}%" in lines[2]
    assert mesh_lines([]) == []


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


def test_csv_quotes_messages_and_leaves_none_empty(tmp_path):
    rows = [{"case": "a", "message": "did not converge, at u_x = 1e-08 m", "mu_s": None,
             "wall_s": 1.23456789012345}]
    text = csv_text(rows, ("case", "message", "mu_s", "wall_s"))
    read = list(csv.DictReader(text.splitlines()))
    assert read == [{"case": "a", "message": "did not converge, at u_x = 1e-08 m", "mu_s": "",
                     "wall_s": "1.23456789"}]


def test_plot_marks_the_chosen_defaults(tmp_path):
    rows = synthetic_rows(MU)
    mark_defaults(rows, 16)
    assert [row["label"] for row in rows if row["chosen_default"]] == ["N=16", "N=16"]
    plot_error(rows, tmp_path / "error.png")
    assert (tmp_path / "error.png").read_bytes()[:4] == b"\x89PNG"


def test_a_case_without_any_finite_error_gets_a_labelled_empty_panel(tmp_path, monkeypatch):
    """The G5 runs all failed (no finite error): their panel says so and draws no front; the
    sinusoid's panel beside it still draws its points and front."""
    import matplotlib.pyplot as plt

    drawn = []
    monkeypatch.setattr(plt, "close", drawn.append)
    plot_error(synthetic_rows({label: None for label in MU}), tmp_path / "error.png")
    panels = {ax.get_title(): ax for ax in drawn[0].axes if ax.get_visible()}
    empty, sine = panels[G5_LOW.label], panels[SINE.label]
    assert [text.get_text() for text in empty.texts] == ["no run with a finite error"]
    assert not empty.lines and not empty.collections
    assert "no run with a finite error" not in [text.get_text() for text in sine.texts]
    assert len(sine.lines) == 1 and sine.collections  # the front, the points
    assert (tmp_path / "error.png").read_bytes()[:4] == b"\x89PNG"
    monkeypatch.undo()
    plt.close(drawn[0])


# --- end to end ------------------------------------------------------------------------------

@pytest.mark.fem
def test_tiny_benchmark_end_to_end(tmp_path, capsys):
    """G5 at F* = 0.155 and the sinusoid at N = 4 and 8, serial: every run converges, the
    reference has no error, the sinusoid's p* error shrinks with N, the outputs are written,
    and a second pass computes nothing (the run cache)."""
    from mpi4py import MPI

    plan = ErrorPlan(cases=(G5_LOW, SINE), sizes=(4, 8), base_n=4,
                     variants=(("solver", "penalty", (100.0,)),))
    lines = []
    rows = run_benchmark(plan, tmp_path / "out", MPI.COMM_SELF, tmp_path / "runs", lines.append)
    assert len(rows) == 7  # G5: N=4, N=8, 4^2 on 8, penalty; sinusoid: N=4, N=8, penalty
    assert all(row["converged"] for row in rows), [row["message"] for row in rows]
    by_label = {(row["case"], row["label"]): row for row in rows}
    finest = by_label[G5_LOW.label, "N=8"]
    assert finest["mu_s_error"] == 0.0 and finest["mu_s"] > 0
    sine4, sine8 = by_label[SINE.label, "N=4"], by_label[SINE.label, "N=8"]
    assert sine8["area_ratio_normal"] == 1.0
    assert abs(sine8["p_star_error"]) < abs(sine4["p_star_error"]) < 1
    for row in rows:
        assert row["wall_s"] > 0 and row["peak_memory_gb"] > 0 and row["ranks"] == 1
    written = list(csv.DictReader((tmp_path / "out" / "error.csv").read_text().splitlines()))
    assert len(written) == 7 and written[0]["case"] == G5_LOW.label
    assert (tmp_path / "out" / "error.png").stat().st_size > 0
    out = capsys.readouterr().out
    assert "mu_s at N against 2N" in out and "default resolution" in out

    entries = sorted(Path(tmp_path / "runs").glob("*.h5"))
    assert len(entries) == 7
    again = []
    second = run_benchmark(plan, tmp_path / "out", MPI.COMM_SELF, tmp_path / "runs", again.append)
    assert sorted(Path(tmp_path / "runs").glob("*.h5")) == entries
    assert not any("converged," in line for line in again)  # no run finished: none computed
    assert [row["wall_s"] for row in second] == [row["wall_s"] for row in rows]

    # --report: from the cache only; a missing run is reported, not computed
    from roughfriction.studies.cache import entry_path, physics_version

    runs = dict(((case.label, variant.label), fem) for case, variant, fem in
                benchmark_runs(plan))
    entry_path(tmp_path / "runs", runs[G5_LOW.label, "N=8"], physics_version()).unlink()
    reported = run_benchmark(plan, tmp_path / "out", MPI.COMM_SELF, tmp_path / "runs",
                             compute=False)
    assert len(list(Path(tmp_path / "runs").glob("*.h5"))) == 6  # nothing computed
    by_label = {(row["case"], row["label"]): row for row in reported}
    missing = by_label[G5_LOW.label, "N=8"]
    assert missing["message"] == NOT_IN_CACHE and not missing["converged"]
    assert by_label[G5_LOW.label, "N=4"]["reference"] == "N=4 (no converged N=8)"
