"""The error estimate of ``fem --tol``: its bookkeeping on a small ladder (files, JSON, post,
exit 3) and the calibration table's checks (``studies.calibration``)."""

import json

import h5py
import pytest
from roughfriction.scripts.cli import main
from roughfriction.studies import calibration
from roughfriction.studies.calibration import calibration_rows, check_estimate
from roughfriction.studies.refinement import richardson

#: A 4 x 4 window of G5 (i.i.d.): levels 1x, 2x, 4x take seconds.
WINDOW = ["G5", "--n", "4", "--window", "1"]


def test_an_estimate_is_checked_for_cover_and_sharpness():
    assert check_estimate(0.20, 0.01, 0.205).covered  # error 0.005 <= 0.01
    assert not check_estimate(0.20, 0.004, 0.205).covered
    assert check_estimate(0.20, 0.0155, 0.205).sharp  # <= 3 x 0.005 + 0.5 % of 0.2
    assert not check_estimate(0.20, 0.0165, 0.205).sharp
    assert check_estimate(0.20, 0.001, 0.20).sharp  # the 0.5 % floor


@pytest.mark.parametrize("argv, n", [(["out.csv"], calibration.CALIBRATION_N),
                                     (["out.csv", "8"], 8)])
def test_the_calibration_runs_on_the_window_size_given(monkeypatch, argv, n):
    called = {}
    monkeypatch.setattr(calibration, "run_calibration",
                        lambda path, comm, n: called.update(path=str(path), n=n) or [])
    assert calibration.main(argv) == 0
    assert called == {"path": "out.csv", "n": n}


def test_calibration_rows_check_each_estimate_against_the_finest_level():
    values = [0.4, 0.24, 0.215, 0.21]
    rows = calibration_rows("G5", 0, 6, 0.155, values, {"dofs_reference": 1})
    assert [row["levels_used"] for row in rows] == [2, 3]
    two, three = rows
    # two levels: 0.24 +- 0.16 against 0.21: covered, but more than 3x the actual 0.03
    assert two["mu_s"] == 0.24 and two["mu_s_error"] == pytest.approx(0.16)
    assert not two["order_observed"] and two["covered"] and not two["sharp"]
    # three levels: order log2(0.16 / 0.025), 0.215 +- 0.0046 against 0.21: not covered
    assert three["mu_s"] == 0.215 and three["order_observed"]
    assert three["mu_s_error"] == pytest.approx(richardson(values[:3]).error)
    assert three["mu_s_error"] == pytest.approx(0.025 / (0.16 / 0.025 - 1))
    assert three["actual_error"] == pytest.approx(0.005) and three["reference_factor"] == 8
    assert not three["covered"] and three["sharp"]
    assert two["window"] == 1 and two["mu_reference"] == 0.21


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
    estimate = richardson(levels["mu_s"])
    assert summary["mu_s_error"] == pytest.approx(estimate.error)
    assert summary["error_order_observed"] == estimate.observed
    assert summary["error_levels_used"] == 3 and not summary["error_tolerance_met"]
    assert "--max-level 2" in summary["error_stopped"]
    assert main(["post", str(output), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["mu_s_error"] == summary["mu_s_error"] and report["levels"] == levels


@pytest.mark.fem
def test_a_tolerance_met_on_two_levels_uses_the_assumed_order(tmp_path, capsys):
    output = tmp_path / "met.h5"
    assert main(["fem", *WINDOW, "--load", "0.93", "--tol", "0.2", "--json", "--output",
                 str(output)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["levels"]["factor"] == [1, 2] and summary["error_tolerance_met"]
    assert not summary["error_order_observed"] and summary["error_order"] == 1.0
    assert summary["mu_s_error"] <= 0.2 * summary["mu_s"]
    with h5py.File(output) as h5:
        assert json.loads(h5.attrs["summary"]) == summary
