"""Committed run summaries (``studies.run_summary``): a figure redraws from them alone."""

import json
import sys
import types

import numpy as np
import pytest
from roughfriction.scripts.figures import export_summaries, make_figure, read_table
from roughfriction.studies.post import interference, read_run, read_summary
from roughfriction.studies.run_summary import stale_summaries

pytestmark = pytest.mark.fem


def test_a_figure_redraws_from_its_summaries_alone_and_other_physics_are_stale(
        tmp_path, monkeypatch):
    """Fig. 15 (A_r/A_n along the slide, 2L at F* = 0.5) on an 8 x 8 grid: drawn from the run
    cache, its rows the run's steps; its summary exported, the cache deleted, drawn again
    without a run: the same table; a summary of another physics version answers nothing and is
    counted stale."""
    runs, summaries = tmp_path / "runs", tmp_path / "summaries"
    monkeypatch.setenv("ROUGHFRICTION_SUMMARIES", str(summaries))
    make_figure("fig15", tmp_path / "a", n=8, runs_directory=runs)
    counts = export_summaries(n=8, runs_directory=runs)
    assert counts["summaries_written"] == 1 and counts["runs_missing"] > 0  # other figures
    h5 = sorted(runs.glob("*.h5"))[0]
    summary = read_summary(summaries / f"{h5.stem}.json")
    full = read_run(h5)
    assert summary.summary == full.summary and not summary.maps
    np.testing.assert_array_equal(summary.steps["tangential_force"],
                                  full.steps["tangential_force"])
    assert interference(summary) == pytest.approx(interference(full), rel=1e-12)
    assert read_run(summaries / f"{h5.stem}.json").summary == full.summary
    # the figure's rows are the run's steps: the end of the preload, then every sliding step
    drawn = read_table(tmp_path / "a" / "fig15.csv")
    phase = full.steps["phase"]
    rows = [np.flatnonzero(phase == "normal")[-1], *np.flatnonzero(phase == "tangential")]
    assert len(drawn["ux_m"]) == len(rows) > 1
    np.testing.assert_allclose(drawn["ux_m"], full.steps["slide"][rows], rtol=1e-9, atol=0)
    np.testing.assert_allclose(drawn["area_ratio"], full.steps["area_ratio"][rows], rtol=1e-9)
    heights = full.maps["surface_heights"]
    omega_0 = np.max(heights - heights.mean()) - full.steps["flat_height"][rows[0]]
    np.testing.assert_allclose(drawn["ux_over_omega0"], full.steps["slide"][rows] / omega_0,
                               rtol=1e-9)
    assert drawn["area_ratio"][0] == pytest.approx(full.summary["area_ratio_normal"], rel=1e-9)
    assert full.summary["mu_s"] is not None  # the last row is sliding inception
    assert drawn["area_ratio"][-1] == pytest.approx(full.summary["area_ratio_sliding"], rel=1e-9)

    for path in runs.glob("*.h5"):
        path.unlink()
    module = types.ModuleType("roughfriction.solver.run")
    module.run_loads = lambda *args, **kwargs: pytest.fail("a summarised run was recomputed")
    monkeypatch.setitem(sys.modules, "roughfriction.solver.run", module)
    make_figure("fig15", tmp_path / "b", n=8, runs_directory=runs)
    first, second = (read_table(tmp_path / name / "fig15.csv") for name in ("a", "b"))
    assert first.keys() == second.keys()
    for key in first:
        np.testing.assert_array_equal(first[key], second[key])

    from roughfriction.scripts import fig15
    from roughfriction.studies.cache import physics_version

    record = json.loads((summaries / f"{h5.stem}.json").read_text())
    cases = fig15.fem_cases(8)
    assert stale_summaries(cases, physics_version()) == 0
    assert stale_summaries(cases, "another physics") == 1
    assert record["physics"] == physics_version()
