"""The error estimate of ``fem --tol``: its bookkeeping on a small ladder (files, JSON, post,
exit 3), and the certificate judged on a calibration set (``benchmarks.calibration``)."""

import json

import h5py
import pytest
from roughfriction.scripts.cli import main
from roughfriction.studies.certificate import LADDER_FACTOR, certify

from benchmarks import calibration

#: A 4 x 4 window of G5 (i.i.d.): levels 1x, 2x, 4x take seconds.
WINDOW = ["G5", "--n", "4", "--window", "1"]


@pytest.mark.fem
def test_a_tolerance_out_of_reach_exits_3_with_the_best_estimate_and_the_file(tmp_path,
                                                                             capsys):
    """1x, 2x, 4x of the window, then --max-level 2 stops it: exit 3, one line with the
    estimate and the reason; the 4x results file holds the estimate and every level."""
    output = tmp_path / "ladder.h5"
    code = main(["fem", *WINDOW, "--load", "0.155", "--tol", "0.001", "--max-level", "2",
                 "--output", str(output)])
    assert code == 3
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith("roughfriction: not converged: tolerance 0.1 % not met: mu_s = ")
    assert "at 4x" in last and "--max-level 2" in last and str(output) in last
    with h5py.File(output) as h5:
        summary = json.loads(h5.attrs["summary"])
        assert json.loads(h5.attrs["inputs"])["mesh"]["refinement"]["level"] == 2  # 4x
    levels = summary["levels"]
    assert levels["factor"] == [1, 2, 4] and levels["mu_s"][-1] == summary["mu_s"]
    assert levels["reduced_dofs"][0] < levels["reduced_dofs"][1] < levels["reduced_dofs"][2]
    estimate = certify(levels["mu_s"], levels["contact_nodes"][-1], levels["boundary_nodes"][-1])
    assert summary["mu_s_error"] == pytest.approx(estimate.error)
    assert summary["error_ladder_term"] == pytest.approx(
        LADDER_FACTOR * abs(levels["mu_s"][2] - levels["mu_s"][1]))
    assert not summary["error_tolerance_met"]
    assert "--max-level 2" in summary["error_stopped"]
    assert main(["post", str(output), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["mu_s_error"] == summary["mu_s_error"] and report["levels"] == levels


@pytest.mark.fem
def test_a_tolerance_met_on_two_levels_reports_the_certificate_of_the_2x_value(tmp_path,
                                                                             capsys):
    output = tmp_path / "met.h5"
    assert main(["fem", *WINDOW, "--load", "0.93", "--tol", "0.2", "--json", "--output",
                 str(output)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["levels"]["factor"] == [1, 2] and summary["error_tolerance_met"]
    assert summary["mu_s_error"] <= 0.2 * summary["mu_s"]
    assert summary["mu_s_error"] == pytest.approx(certify(
        summary["levels"]["mu_s"], summary["contact_nodes"], summary["boundary_nodes"]).error)
    with h5py.File(output) as h5:
        assert json.loads(h5.attrs["summary"]) == summary


# --- the certificate on the calibration set (benchmarks.calibration) ----------------------------

LADDER_HEADER = ("surface,window,n,load_star,level,factor,mu_s,converged,contact_nodes,"
                 "boundary_nodes,physics\n")


def _ladder_table(tmp_path, ladders):
    """A ladder table: ladders maps (surface, load) to [(mu_s, contact, boundary), ...]."""
    lines = [LADDER_HEADER]
    for (surface, load), levels in ladders.items():
        for level, (mu, contact, boundary) in enumerate(levels):
            lines.append(f"{surface},3,16,{load},{level},{2**level},{mu},True,{contact},"
                         f"{boundary},abc\n")
    path = tmp_path / "ladders.csv"
    path.write_text("".join(lines))
    return path


def test_a_level_is_judged_only_against_a_reference_two_levels_finer(tmp_path):
    path = _ladder_table(tmp_path, {("G5", 0.155): [(0.3, 10, 10), (0.21, 40, 30),
                                                    (0.205, 160, 90), (0.204, 640, 200)],
                                    ("G1", 0.93): [(0.5, 10, 10), (0.49, 40, 30),
                                                   (0.48, 160, 90)]})
    cases = calibration.read_cases(path)
    assert len(cases) == 1  # G5's 2x against 8x; G1's 2x has only 4x, its own next level
    (g5,) = cases
    assert g5.level == 1 and g5.mu_s == 0.21 and g5.mu_coarse == 0.3
    assert g5.contact_nodes == 40 and g5.boundary_nodes == 30
    assert g5.mu_reference == 0.204 and g5.s_reference == pytest.approx(0.001)
    assert g5.reference_factor == 8 and g5.actual_error == pytest.approx(0.006)


def test_a_variant_s_levels_are_judged_against_the_ladder_s_reference(tmp_path):
    """A variant table (the coarse blend zone's 2x level, say) replaces the judged level's
    value and counts; the reference and its spread stay the uniform ladder's; a case the
    variant lacks is not judged; the provisional look takes the variant's 2x too."""
    ladders = _ladder_table(tmp_path, {("G5", 0.155): [(0.3, 10, 10), (0.21, 40, 30),
                                                       (0.205, 160, 90), (0.204, 640, 200)],
                                       ("G1", 0.155): [(0.5, 10, 10), (0.45, 40, 30),
                                                       (0.44, 160, 90), (0.43, 640, 200)]})
    variant = tmp_path / "variant.csv"
    variant.write_text(LADDER_HEADER + "G5,3,16,0.155,1,2,0.212,True,42,31,def\n")
    (case,) = calibration.read_cases(ladders, variant)
    assert case.label[0] == "G5" and case.mu_s == 0.212 and case.mu_coarse == 0.3
    assert (case.contact_nodes, case.boundary_nodes, case.physics) == (42, 31, "def")
    assert case.mu_reference == 0.204 and case.s_reference == pytest.approx(0.001)
    (first_look,) = calibration.provisional_cases(ladders, variant)
    assert first_look.mu_s == 0.212 and first_look.mu_reference == 0.205
    assert len(calibration.read_cases(ladders)) == 2  # without it, both ladders' own 2x


def test_a_case_is_judged_by_the_three_criteria(tmp_path):
    path = _ladder_table(tmp_path, {("G5", 0.155): [(0.3, 10, 10), (0.21, 40, 30),
                                                    (0.205, 160, 90), (0.204, 640, 200)]})
    (case,) = calibration.read_cases(path)
    # e = hypot(0.1 x 0.09, 0) = 0.009 >= 0.006 - 0.001: covered, sharpness 0.009 / 0.006
    judged = calibration.judge(case, 0.1, 0.0)
    assert judged["mu_s_error"] == pytest.approx(0.009) and judged["covered"]
    assert not judged["overconfident"] and judged["sharpness"] == pytest.approx(1.5)
    # e = 0.0009: 0.006 > 0.0009 + 0.001 and > 3 x 0.0009 + 0.001
    judged = calibration.judge(case, 0.01, 0.0)
    assert not judged["covered"] and judged["overconfident"]
    # the sharpness floor: 0.5 % of mu_s when the actual error is smaller
    tight = calibration.Case(("G5", 3, 16, 0.155), 1, 0.2, 0.3, 40, 30, 8, 0.2, 0.0, "abc")
    assert calibration.judge(tight, 0.1, 0.0)["sharpness"] == pytest.approx(0.01 / 0.001)


def test_the_fit_takes_the_sharpest_factors_that_cover_and_reports_none_when_none_do(tmp_path):
    ladders = {(f"G{k}", 0.155): [(0.3, 10, 10), (0.21 + 0.001 * k, 400, 100),
                                  (0.205, 1600, 200), (0.204, 6400, 400)] for k in range(1, 6)}
    cases = calibration.read_cases(_ladder_table(tmp_path, ladders))
    fitted = calibration.fit(cases)
    assert fitted.covered >= 0.9 * len(cases) and fitted.overconfident == 0
    for case in cases:  # each fitted error no smaller than needed
        assert calibration.judge(case, fitted.ladder_factor,
                                 fitted.boundary_factor)["covered"]
    assert calibration.fit(cases, grid=[1e-6]) is None
    assert 0 <= calibration.leave_one_out(cases) <= len(cases)
