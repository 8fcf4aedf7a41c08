"""Stress matrix (benchmarks/stress.py): classification, reliability, tables on synthetic data; the
step-cut count of the load path with a scripted stand-in for the equilibrium; one tiny
end-to-end matrix (N = 8, serial, a temporary run cache) with runs that must fail loudly."""

import csv
import math
import os
import types

import numpy as np
import pytest
from roughfriction.case import FemCase, Loading, SolverOptions
from roughfriction.errors import InputError
from roughfriction.geometry.surface import Surface
from roughfriction.solver.progress import StepCut
from roughfriction.solver.results import FemResult, StepRecord

from benchmarks.stress import (
    ALONE,
    CUT,
    DIRECT,
    FAILED,
    OUTCOMES,
    RANK_TOLERANCE,
    SILENT,
    UNRELIABLE_MARK,
    StressRun,
    add_changes,
    agreement,
    cell_text,
    check_directory,
    check_runs,
    classify,
    compute_rank_run,
    compute_runs,
    default_runs,
    disagreements,
    load_runs,
    material_runs,
    matrix_table,
    measured_surface,
    option_runs,
    outcome_counts,
    provenance_line,
    run_stress,
    stress_markdown,
    stress_row,
    surface_data_directory,
    surface_psi,
)

SPACING = 1e-6


def record(phase, nodes=8, patches=2, slipping=0, cuts=0, fn=1.0, ft=0.0, cells=None):
    """A step on an 8 x 8 grid whose contact area is ``cells`` grid cells (default: one per
    contact node, as in the paper's node-to-surface contact)."""
    area_ratio = (nodes if cells is None else cells) / 64
    return StepRecord(phase, fn, ft, 0.0, 0.0, area_ratio, nodes, patches, slipping, 0.0, 3, 0,
                      0.1, cuts)


#: Sizes of a run on the 8 x 8 grid of :func:`record`.
GRID = {"grid_size": 8}


def test_summary_counts_cut_steps_and_contact_per_patch_at_inception():
    records = [record("normal", cuts=2), record("normal", nodes=9, patches=3),
               record("tangential", nodes=12, patches=4, slipping=5, cuts=1, ft=0.3),
               record("tangential", nodes=12, patches=4, slipping=12, ft=0.4)]
    summary = FemResult(records, True, "", False, {}, GRID).summary()
    assert summary["cut_steps"] == 3
    assert summary["nodes_per_patch"] == 3.0 and summary["cells_per_patch"] == 3.0
    assert summary["reliable"] is False  # 12 cells / 4 patches < 4
    assert summary["mu_s"] == pytest.approx(0.4)


def test_a_patch_of_contact_nodes_with_little_area_is_not_reliable():
    # one touching integration point makes its face's 4 corners contact nodes: 4 nodes per
    # patch by the count, a quarter cell by the area
    records = [record("normal", nodes=8, patches=2, cells=0.5)]
    summary = FemResult(records, True, "", True, {}, GRID).summary()
    assert summary["nodes_per_patch"] == 4.0 and summary["cells_per_patch"] == 0.25
    assert summary["reliable"] is False
    assert FemResult(records, True, "", True, {}, {}).summary()["reliable"] is None  # no grid


def test_normal_only_and_unconverged_runs_report_the_preload_state():
    records = [record("normal", nodes=8, patches=2)]
    assert FemResult(records, True, "", True, {}, GRID).summary()["reliable"] is True  # 4 cells
    failed = FemResult(records + [record("tangential", nodes=20, patches=1)], False,
                       "step limit", False, {}, GRID).summary()
    assert failed["mu_s"] is None and failed["nodes_per_patch"] == 4.0
    empty = FemResult([], False, "preload did not converge", False, {}, GRID).summary()
    assert empty["nodes_per_patch"] is None and empty["reliable"] is None
    assert empty["cut_steps"] == 0
    no_contact = FemResult([record("normal", nodes=0, patches=0)], True, "", True, {}, GRID)
    assert no_contact.summary()["reliable"] is None


# --- the step-cut count of the load path ------------------------------------------------------

class ScriptedEquilibrium:
    """Stands in for solver.equilibrium.Equilibrium: Newton fails on the listed attempts (1, 2,
    ...), converges in 3 iterations otherwise, a held flat carrying the force aimed at; 4
    surface nodes, all in contact, all slipping once the flat has slid beyond ``slip_from`` [m]."""

    def __init__(self, failing, slip_from=0.0):
        self.failing, self.calls, self.slip_from = set(failing), 0, slip_from
        self.extrapolations = []  # ratios passed to extrapolate
        self.predictors = []  # the predictor flag of each sliding attempt
        self.marks_path = []  # and its marks_path flag
        self.exact_tangent = []  # and its exact_tangent flag
        self.slopes, self.path_steps = 0, []  # path_slope calls, follow_path height changes
        self.flat_height = 0.0
        self.solid = types.SimpleNamespace(plastic_volume_fraction=lambda: 0.0)
        self.flat = types.SimpleNamespace(
            node_maps=lambda contact: {"contact": contact.in_contact.reshape(2, 2),
                                       "slip": contact.slipping.reshape(2, 2)},
            area_ratio=lambda flags: float(np.mean(flags)),
            normal_force=lambda contact: contact.fn,
            tangential_force=lambda contact: 0.5 * contact.fn if contact.slide else 0.0,
            stuck_shear_reserve=lambda contact: float(np.count_nonzero(
                contact.in_contact & ~contact.slipping)),
            count=lambda flags: int(np.count_nonzero(flags)))

    def solve(self, step):
        from roughfriction.solver.newton import NewtonReport

        self.calls += 1
        if step.frictional:
            self.predictors.append(step.predictor)
            self.marks_path.append(step.marks_path)
            self.exact_tangent.append(step.exact_tangent)
        contact = types.SimpleNamespace(fn=step.normal_force, slide=step.flat_slide,
                                        in_contact=np.ones(4, bool),
                                        slipping=np.full(4, step.flat_slide > self.slip_from))
        failed = self.calls in self.failing
        return NewtonReport(not failed, 3, 0, 1e-3, contact,
                            f"scripted failure {self.calls}" if failed else "")

    def place_flat(self, normal_force):
        pass

    def extrapolate(self, ratio):
        self.extrapolations.append(ratio)

    def path_slope(self):
        self.slopes += 1
        return -1.0

    def follow_path(self, height_change):
        self.path_steps.append(height_change)

    def restore(self):
        pass

    def commit(self, contact):
        pass

    def committed_state(self):
        return None

    def resume(self, state):
        pass


@pytest.mark.fem
def test_load_path_records_the_cuts_before_each_step_also_across_a_branch():
    from roughfriction.solver.stepping import LoadPath

    case = FemCase(Surface(np.zeros((4, 4)), SPACING, "flat"), Loading(0.5))
    equilibrium = ScriptedEquilibrium(failing={2, 3, 10, 14})
    events = []
    path = LoadPath(equilibrium, case, 4 * SPACING, progress=events.append)
    target = case.normal_force
    assert path.preload(0.5 * target).converged  # calls 2 and 3 cut the second step twice
    cuts = [event for event in events if isinstance(event, StepCut)]
    assert [(cut.phase, cut.reason) for cut in cuts] == [
        ("normal", "scripted failure 2"), ("normal", "scripted failure 3")]
    assert str(cuts[0]).endswith("scripted failure 2 (Newton 3 its, residual 1.00e-03 F_n)")
    assert [type(event) for event in events].count(StepRecord) == len(path.records)
    assert [r.cuts for r in path.records] == [0, 2, 0, 0, 0, 0, 0]
    # every scripted attempt takes 3 Newton iterations: a step carries those of its failed ones
    assert [r.cut_iterations for r in path.records] == [0, 6, 0, 0, 0, 0, 0]
    # steps 2-6 hold the flat and follow the path tangent (a slope per committed state, kept
    # across the cuts of step 2) up to 0.95 x the target (increments 0.2, 0.075 after the cuts,
    # growing by 1.5); the last, force-controlled step extrapolates the last two
    assert equilibrium.slopes == 5 and len(equilibrium.path_steps) == 7
    np.testing.assert_allclose(equilibrium.extrapolations, [(1 - 0.95) / (0.95 - 0.809375)])
    branch = path.branch_point()
    assert path.slide().converged  # call 10 cut, 11 at inception, 12 solves it on, tight
    assert [r.cuts for r in path.records[7:]] == [1]
    summary = FemResult(list(path.records), True, "", False, {}, {}).summary()
    assert (summary["cut_steps"], summary["cut_iterations"]) == (3, 9)
    assert summary["newton_iterations"] == 3 * (path.attempts + 1) == 3 * equilibrium.calls
    path.return_to(branch)
    assert path.preload(target).converged  # call 13 accepted, 14 cut, 15 accepted, ...
    assert [r.cuts for r in path.records[:7]] == [0, 2, 0, 0, 0, 0, 0]
    assert [r.cuts for r in path.records[7:9]] == [0, 1]
    assert sum(r.cuts for r in path.records) == path.attempts - len(path.records) == 3


@pytest.mark.fem
def test_sliding_steps_after_the_first_start_from_the_last_two_extrapolated():
    """The first sliding step starts from the preload's state with the tangential predictor;
    every later attempt, a retry after a cut too, starts from the last two sliding steps
    extrapolated by its increment over the last accepted one, without the predictor. Every
    attempt only marks the path; the one that reaches inception is solved on, tight, from where
    it ended, with the exact tangent from the start."""
    from roughfriction.solver.stepping import LoadPath

    case = FemCase(Surface(np.zeros((4, 4)), SPACING, "flat"), Loading(0.5))
    equilibrium = ScriptedEquilibrium(failing=())
    path = LoadPath(equilibrium, case, 4 * SPACING, progress=lambda event: None)
    assert path.preload(case.normal_force).converged
    first = case.solver.first_slide * path.flat_block_slide
    equilibrium.extrapolations.clear()
    equilibrium.failing = {equilibrium.calls + 2}  # the second sliding attempt is cut
    equilibrium.slip_from = 4.0 * first
    assert path.slide().converged
    # increments f, 1.5 f (cut), 0.75 f, 1.125 f, 1.6875 f: slides f, 1.75 f, 2.875 f, 4.5625 f
    slides = [record.slide / first for record in path.records if record.phase == "tangential"]
    np.testing.assert_allclose(slides, [1.0, 1.75, 2.875, 4.5625])
    np.testing.assert_allclose(equilibrium.extrapolations, [1.5, 0.75, 1.5, 1.5])
    assert equilibrium.predictors == [True, False, False, False, False, False]
    assert equilibrium.marks_path == [True, True, True, True, True, False]
    assert equilibrium.exact_tangent == [False, False, False, False, False, True]


# --- classification --------------------------------------------------------------------------

GOOD = {"converged": True, "message": "", "mu_s": 0.4, "normal_only": False, "cut_steps": 0,
        "inception": True, "force_error": 1e-9, "reliable": True}


@pytest.mark.parametrize("changes, outcome, problem", [
    ({}, DIRECT, None),
    ({"cut_steps": 3}, CUT, None),
    ({"cut_steps": 3, "note": "computed alone: on the shared normal path it failed (...)"},
     ALONE, None),
    ({"converged": False, "mu_s": None, "message": "stalled", "note": "computed alone"}, FAILED,
     None),
    ({"normal_only": True, "mu_s": None, "inception": None}, DIRECT, None),
    ({"converged": False, "mu_s": None, "message": "tangential step did not converge"}, FAILED,
     None),
    ({"converged": False, "mu_s": None, "message": "  "}, SILENT, "no message"),
    ({"converged": False, "message": "step limit"}, SILENT, "unconverged run"),
    ({"mu_s": None}, SILENT, "without mu_s"),
    ({"inception": False}, SILENT, "before every contact node slips"),
    ({"inception": None}, SILENT, "before every contact node slips"),
    ({"force_error": 2e-3}, SILENT, "off its target"),
    ({"mu_s": math.nan}, SILENT, "not a positive number"),
    ({"mu_s": -0.1}, SILENT, "not a positive number"),
])
def test_classify(changes, outcome, problem):
    got, problems = classify({**GOOD, **changes})
    assert got == outcome
    if problem is None:
        assert problems == []
    else:
        assert any(problem in text for text in problems), problems


def test_a_run_that_did_not_start_fails_loudly_only_with_a_message():
    run = StressRun("measured", "ST400 test3", 0.155, error="no such file: test3.txt")
    assert stress_row(run, 32, None)["outcome"] == FAILED
    assert stress_row(StressRun("matrix", "G1", 0.155), 32, None)["outcome"] == SILENT


# --- building the runs -----------------------------------------------------------------------

def flat_case(load=0.155):
    return FemCase(Surface(np.zeros((4, 4)), SPACING, "flat"), Loading(load))


def test_option_runs_multiply_the_default_and_keep_the_rest():
    runs = option_runs("penalty", flat_case(), (0.01, 0.155), (0.01, 100.0))
    assert [(r.factor, r.load_star) for r in runs] == [(0.01, 0.01), (0.01, 0.155),
                                                       (100.0, 0.01), (100.0, 0.155)]
    default = SolverOptions()
    assert runs[0].case.solver.penalty == pytest.approx(0.01 * default.penalty)
    assert runs[-1].case.solver.first_slide == default.first_slide
    assert runs[1].case.loading == Loading(0.155)
    steps = option_runs("step", flat_case(), (0.155,), (4.0,))
    assert steps[0].case.solver.first_slide == pytest.approx(4 * default.first_slide)


def test_default_runs_are_the_declared_matrix_and_variants():
    runs = default_runs(8)
    kinds = [r.kind for r in runs]
    assert kinds.count("matrix") == 45 and kinds.count("measured") == 5
    assert kinds.count("penalty") == kinds.count("step") == 8 and kinds.count("default") == 2
    assert kinds.count("residual") == kinds.count("increment") == kinds.count("penetration") == 4
    assert kinds.count("material") == 8
    assert kinds.count("ranks") == 3 and kinds.count("repeat") == 5
    default = [r.case for r in runs if r.kind == "default"]
    option = [r.case for r in runs if r.kind in ("penalty", "residual", "material", "repeat")]
    assert all(case.surface is option[0].surface for case in default + option)
    assert {r.case.surface.n for r in runs if r.case is not None} == {8}
    loads = {r.load_star for r in runs if r.kind == "matrix"}
    assert min(loads) == 0.01 and max(loads) == 2.5
    g1 = [r for r in runs if r.surface == "G1" and r.load_star == 1.86]
    assert len(g1) == 1  # near-complete contact is in the matrix
    tolerances = [r.case.solver for r in runs if r.kind == "residual"]
    assert sorted(t.residual_tolerance for t in tolerances) == pytest.approx(
        [1e-8, 1e-8, 1e-4, 1e-4])
    assert {t.increment_tolerance for t in tolerances} == {SolverOptions().increment_tolerance}


def test_the_matrix_spans_psi_1_to_26_on_the_32_grid():
    """G1-G9 are meshed as the figures mesh them (windows at their own spacing), not re-gridded
    to 32 points (psi 0.3-5.5)."""
    psi = [surface_psi(r.case) for r in default_runs(32) if r.kind == "matrix"]
    assert min(psi) < 1.5 and max(psi) > 25


def test_material_runs_set_each_extreme_with_its_dependent_constants():
    runs = material_runs(flat_case(), (0.01, 0.155))
    assert len(runs) == 8 and {r.kind for r in runs} == {"material"}
    material = {(r.variant, r.load_star): r.case.material for r in runs}
    assert material["nu = 0.499", 0.155].nu == 0.499
    assert material["no hardening (E_t = 1e-6 E)", 0.01].Et == pytest.approx(1e-6 * 200e9)
    stiff = material["very stiff (E = 2000 GPa)", 0.01]
    soft = material["very soft (E = 20 GPa)", 0.01]
    assert (stiff.E, soft.E) == (2e12, 2e10)
    # E_t follows E (2 %), S_y and tau_c stay the paper's
    assert (stiff.Et, soft.Et) == (pytest.approx(4e10), pytest.approx(4e8))
    assert stiff.Sy == soft.Sy == 1e9 and stiff.tau_c == pytest.approx(1e9 / math.sqrt(3))
    assert runs[1].case.loading == Loading(0.155) and runs[1].case.surface.name == "flat"


def test_check_runs_are_the_same_case_each_in_its_own_run_cache(tmp_path):
    case = flat_case()
    runs = check_runs(case, (1, 2, 4), 5)
    assert [(r.kind, r.ranks, r.variant) for r in runs[:3]] == [
        ("ranks", 1, "1 rank"), ("ranks", 2, "2 ranks"), ("ranks", 4, "4 ranks")]
    assert [r.variant for r in runs[3:]] == [f"repeat {k}" for k in range(1, 6)]
    assert all(r.case is case for r in runs)
    directories = {check_directory(tmp_path, r) for r in runs}
    assert len(directories) == 8
    assert check_directory(tmp_path, runs[2]) == tmp_path / "stress_runs" / "ranks4"
    assert check_directory(tmp_path, runs[-1]) == tmp_path / "stress_runs" / "repeat5"


def test_a_rank_run_not_computed_fails_loudly_with_the_command_that_computes_it(tmp_path):
    run = check_runs(flat_case(), (4,), 0)[0]
    result = compute_runs([run], 32, tmp_path, comm=None)[0]
    assert result.path is None and "mpirun -n 4 --oversubscribe" in result.error
    assert "--rank-run" in result.error
    row = stress_row(run, 32, None, result.error)
    assert row["outcome"] == FAILED and row["expected_ranks"] == 4


def test_a_rank_run_is_refused_on_a_rank_count_not_compared(tmp_path):
    with pytest.raises(InputError, match="1, 2, 4 ranks, not 3"):
        compute_rank_run(8, tmp_path, types.SimpleNamespace(size=3))


def test_measured_surface_is_resampled_or_its_absence_explained(tmp_path, monkeypatch):
    if (surface_data_directory() / "nanovea_st400" / "test3.txt").is_file():
        surface, error = measured_surface(8)
        assert error == "" and surface.n == 8 and surface.name == "test3"
    monkeypatch.setenv("ROUGHFRICTION_SURFACE_DATA", str(tmp_path))
    surface, error = measured_surface(8)
    assert surface is None and "not available" in error and "test3.txt" in error
    runs = load_runs("measured", "ST400 test3", surface, (0.01, 0.155), error)
    assert [r.case for r in runs] == [None, None] and runs[0].error == error


# --- tables ----------------------------------------------------------------------------------

def row(surface, load, outcome=DIRECT, mu_s=0.5, kind="matrix", factor=1.0, reliable=True,
        cut_steps=0, message=""):
    facts = {"converged": outcome in (DIRECT, CUT), "message": message, "mu_s": mu_s,
             "reliable": reliable, "cut_steps": cut_steps, "ranks": 2}
    option = {"penalty": "penalty", "step": "first_slide"}.get(kind, "")
    return {"kind": kind, "surface": surface, "n": 32, "load_star": load, "option": option,
            "factor": factor, **facts, "outcome": outcome, "problems": ""}


def synthetic_table():
    rows = [row("G1", 0.01, reliable=False, mu_s=0.9),
            row("G1", 0.155, CUT, cut_steps=2),
            row("G5", 0.01, FAILED, mu_s=None, message="preload did not converge beyond 0.5"),
            row("G5", 0.155, mu_s=0.8),
            row("G5", 0.155, kind="penalty", factor=100.0, mu_s=0.41),
            row("G5", 0.01, kind="penalty", factor=100.0, mu_s=0.3),
            # the option runs' own surface (the figures' window, not the matrix's re-gridded G5)
            row("G5", 0.01, FAILED, kind="default", mu_s=None, message="preload stalled"),
            row("G5", 0.155, kind="default", mu_s=0.4)]
    add_changes(rows)
    return rows


def test_changes_are_against_the_default_run_of_the_option_surface_and_load():
    rows = synthetic_table()
    assert rows[4]["mu_s_change"] == pytest.approx(0.41 / 0.4 - 1)
    assert rows[5]["mu_s_change"] is None  # its baseline failed
    assert rows[3]["mu_s_change"] is None  # a matrix run has no change
    assert rows[7]["mu_s_change"] is None  # nor the default run


def test_cells_show_mu_s_cuts_failures_and_unreliability():
    rows = synthetic_table()
    assert cell_text(rows[0]) == f"0.900 {UNRELIABLE_MARK}"
    assert cell_text(rows[1]) == "0.500 (2 cuts)"
    assert cell_text({**rows[1], "cut_steps": 1}) == "0.500 (1 cut)"
    assert cell_text(rows[2]) == "FAILED"
    assert cell_text({**rows[1], "outcome": ALONE}) == "0.500 (alone)"
    assert cell_text(rows[4]) == "0.410 (+2.5 %)"
    assert cell_text({**rows[3], "outcome": SILENT}) == "**SILENT**"


def test_matrix_table_has_a_row_per_surface_and_a_column_per_load():
    rows = synthetic_table()
    rows[0]["psi"] = rows[1]["psi"] = 1.3202
    lines = matrix_table(rows, (0.01, 0.155, 0.62))
    assert lines[0] == "| surface | psi | F* = 0.01 | F* = 0.155 | F* = 0.62 |"
    assert lines[1] == "|---|---|---|---|---|"
    assert lines[2] == f"| G1 | 1.32 | 0.900 {UNRELIABLE_MARK} | 0.500 (2 cuts) | – |"
    assert lines[3] == "| G5 | – | FAILED | 0.800 | – |"
    assert len(lines) == 4


def test_markdown_counts_outcomes_lists_failures_and_the_reliable_region():
    rows = synthetic_table()
    counts = outcome_counts(rows)
    assert [counts[o] for o in OUTCOMES] == [5, 1, 0, 2, 0]
    text = stress_markdown(rows, 32, (0.01, 0.155))
    assert "Outcomes of all 8 runs: 5 converged directly, 1 converged after step cutting, " \
           "0 converged alone, 2 failed loudly, 0 SILENT FAILURE." in text
    assert "- G5 F*=0.01: failed loudly: preload did not converge beyond 0.5" in text
    assert "| defaults | x1 | FAILED | 0.400 |" in text
    assert "| penalty | x100 | 0.300 | 0.410 (+2.5 %) |" in text
    assert "- F* = 0.01: 0 of 2 reliable" in text
    assert "- F* = 0.155: 2 of 2 reliable (G1, G5)" in text
    assert "2 rank(s)" in text


def check_row(kind, variant, mu_s, ranks=2, expected=None):
    return {**row("G5", 0.155, mu_s=mu_s, kind=kind), "variant": variant, "ranks": ranks,
            "expected_ranks": expected}


def test_repeats_agree_only_when_identical_to_round_off():
    same = [check_row("repeat", f"repeat {k}", 0.2146123456789) for k in range(1, 6)]
    found = agreement(same, "repeat")
    assert found.agrees and found.spread == 0.0 and len(found.values) == 5
    apart = same[:4] + [check_row("repeat", "repeat 5", 0.2146123456789 * (1 + 1e-9))]
    found = agreement(apart, "repeat")
    assert not found.agrees and "differs by 1e-09" in found.problems[0]
    assert disagreements(apart) == [f"repeat: {found.problems[0]}"]
    assert agreement(same, "ranks") is None and disagreements(same) == []


def test_rank_counts_agree_within_their_tolerance_on_the_ranks_asked():
    ranks = [check_row("ranks", f"{k} ranks", 0.2146 * (1 + 0.5 * RANK_TOLERANCE * (k > 1)),
                       ranks=k, expected=k) for k in (1, 2, 4)]
    assert agreement(ranks, "ranks").agrees
    far = ranks[:2] + [check_row("ranks", "4 ranks", 0.2146 * 1.001, ranks=4, expected=4)]
    assert "differs by 0.001" in agreement(far, "ranks").problems[0]
    wrong = ranks[:2] + [check_row("ranks", "4 ranks", 0.2146, ranks=2, expected=4)]
    assert agreement(wrong, "ranks").problems == ("4 ranks: ran on 2 rank(s)",)
    missing = ranks[:2] + [check_row("ranks", "4 ranks", None, ranks=None, expected=4)]
    found = agreement(missing, "ranks")
    assert found.spread is None and found.problems == ("no mu_s to compare: 4 ranks",)


def test_markdown_shows_materials_ranks_repeats_and_their_agreement():
    rows = synthetic_table()
    rows.append({**row("G5", 0.155, CUT, mu_s=0.5, kind="material", cut_steps=1),
                 "variant": "nu = 0.499"})
    rows += [check_row("ranks", f"{k} rank" + "s" * (k > 1), 0.4, ranks=k, expected=k)
             for k in (1, 2, 4)]
    rows += [check_row("repeat", "repeat 1", 0.4), check_row("repeat", "repeat 2", 0.41)]
    add_changes(rows)
    text = stress_markdown(rows, 32, (0.01, 0.155), "roughfriction 9.9, run today")
    assert text.startswith("roughfriction 9.9, run today\n\n")
    assert "| material | nu = 0.499 | 0.500 (+25.0 %) (1 cut) |" in text
    assert "| ranks | 4 ranks | 4 | 0.4 | converged directly |" in text
    assert "- rank counts: mu_s 1 rank: 0.4, 2 ranks: 0.4, 4 ranks: 0.4; largest relative " \
           "difference 0 (tolerance 1e-06): agree." in text
    assert "- repeats on the same ranks: mu_s repeat 1: 0.4, repeat 2: 0.41; largest " \
           "relative difference 0.025 (tolerance 1e-12): **DO NOT AGREE**: mu_s differs" in text
    assert "(2 rank(s))" in text  # the rank runs do not count as this command's ranks


def test_provenance_states_the_version_the_date_and_the_machine():
    from roughfriction import __version__

    line = provenance_line()
    assert line.startswith(f"roughfriction {__version__}, run 20") and " UTC on " in line
    assert f"{os.cpu_count()} cores" in line and "no timings are claimed" in line


# --- end to end ------------------------------------------------------------------------------

def rough_surface(name, seed=7):
    return Surface(np.random.default_rng(seed).normal(0.0, 0.1 * SPACING, (8, 8)), SPACING, name)


@pytest.mark.fem
def test_tiny_stress_matrix_end_to_end(tmp_path):
    """A rough 8 x 8 surface at two loads (one group), penalty x10, a run stopped by its
    step limit, a spiky surface (meshed with the blend layers its valley needs), a measured
    surface that is missing, two repeats and a 4-rank run not computed: the runs converge, the
    rest fail loudly with their reasons, nothing fails silently."""
    from dataclasses import replace

    from mpi4py import MPI

    surface = rough_surface("R")
    base = FemCase(surface, Loading(0.155))
    limited = replace(base, solver=SolverOptions(max_steps=3))
    spiky = surface.heights.copy()
    spiky[3, 3], spiky[3, 4] = 20 * SPACING, -20 * SPACING
    runs = (load_runs("matrix", "R", surface, (0.155, 0.62))
            + [StressRun("default", "R", 0.155, 1.0, base)]
            + option_runs("penalty", base, (0.155,), (10.0,))
            + [StressRun("matrix", "limited", 0.155, case=limited),
               StressRun("matrix", "spiky", 0.155,
                         case=FemCase(Surface(spiky, SPACING, "spiky"), Loading(0.155))),
               StressRun("measured", "missing", 0.155, error="measured surface not available")]
            + check_runs(base, (4,), 2))
    rows = run_stress(runs, 8, (0.155, 0.62), tmp_path / "out", MPI.COMM_SELF,
                      tmp_path / "runs", progress=lambda record: None)
    outcome = {(r["surface"], r["load_star"], r["factor"]): r for r in rows}
    for key in (("R", 0.155, 1.0), ("R", 0.62, 1.0), ("R", 0.155, 10.0)):
        assert outcome[key]["outcome"] in (DIRECT, CUT), outcome[key]
        assert outcome[key]["mu_s"] > 0 and outcome[key]["nodes_per_patch"] > 0
        assert outcome[key]["inception"] and abs(outcome[key]["force_error"]) < 1e-4
        assert (outcome[key]["outcome"] == CUT) == (outcome[key]["cut_steps"] > 0)
        assert outcome[key]["nodes_per_patch"] == pytest.approx(
            outcome[key]["contact_nodes"] / outcome[key]["contact_patches"])
    # penalty x10 changes mu_s by < 1 % (test_solver_verification, the same surface)
    assert outcome["R", 0.155, 10.0]["mu_s_change"] == pytest.approx(0.0, abs=0.01)
    assert outcome["R", 0.155, 10.0]["mu_s_change"] == pytest.approx(
        outcome["R", 0.155, 10.0]["mu_s"] / outcome["R", 0.155, 1.0]["mu_s"] - 1)
    limit = outcome["limited", 0.155, 1.0]
    assert limit["outcome"] == FAILED and "step limit" in limit["message"]
    assert limit["mu_s"] is None and limit["converged"] is False
    assert outcome["spiky", 0.155, 1.0]["outcome"] in (DIRECT, CUT)
    assert outcome["missing", 0.155, 1.0]["message"] == "measured surface not available"
    assert outcome_counts(rows)[SILENT] == 0
    # the repeats are computed, each in its own cache, to the same mu_s as the default run;
    # the 4-rank run was not computed by its own mpirun: a loud failure and a disagreement
    repeats = [r for r in rows if r["kind"] == "repeat"]
    assert repeats[0]["mu_s"] == repeats[1]["mu_s"] == pytest.approx(
        outcome["R", 0.155, 1.0]["mu_s"], rel=1e-6)
    for k in (1, 2):
        assert len(list((tmp_path / "out" / "stress_runs" / f"repeat{k}").glob("*.h5"))) == 1
    assert agreement(rows, "repeat").spread == 0.0
    ranks = [r for r in rows if r["kind"] == "ranks"]
    assert ranks[0]["outcome"] == FAILED and "--rank-run" in ranks[0]["message"]
    assert disagreements(rows) == ["ranks: no mu_s to compare: 4 ranks"]

    written = list(csv.DictReader((tmp_path / "out" / "stress.csv").read_text().splitlines()))
    assert len(written) == len(runs) == 10
    assert written[4]["message"] == limit["message"]  # commas survive the CSV
    assert [float(row["mu_s"]) if row["mu_s"] else None for row in written] == [
        None if row["mu_s"] is None else pytest.approx(row["mu_s"], rel=1e-9) for row in rows]
    markdown = (tmp_path / "out" / "stress.md").read_text()
    assert "| R | " in markdown and "0 SILENT FAILURE" in markdown
    assert "- limited F*=0.155: failed loudly: step limit" in markdown
