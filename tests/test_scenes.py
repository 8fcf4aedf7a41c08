"""What each FEM figure runs (scripts/scenes.py), from the runs the figures declare."""

import csv
from pathlib import Path

from roughfriction.scripts.figures import FEM_FIGURES
from roughfriction.scripts.scenes import COLUMNS, meshes_text, scene_rows, shows
from roughfriction.studies.paper import ERROR_BAR_LOADS, fem_case
from roughfriction.studies.refinement import next_mesh

COMMITTED = Path(__file__).resolve().parents[1] / "docs" / "bench" / "figure_scenes.csv"


def test_meshes_name_the_loads_also_run_on_a_finer_mesh():
    coarse = [fem_case("G5", load, 8) for load in (0.155, 0.93, 0.06)]
    assert meshes_text(coarse, 8) == "1x"
    assert meshes_text(coarse + [next_mesh(coarse[2]), next_mesh(coarse[0])], 8) == (
        "1x; 2x at F* = 0.06, 0.155")


def test_shows_reads_the_first_docstring_line_without_an_unclosed_parenthesis():
    class Module:
        __doc__ = "Fig. 10: contact nodes per patch, 8L (the paper\nreads fewer than 4)."
    assert shows(Module) == "contact nodes per patch, 8L"


def test_normal_only_figures_stop_at_the_preload_and_share_their_runs():
    rows = {row["figure"]: row for row in scene_rows(8)}
    assert list(rows) == list(FEM_FIGURES)
    for name in ("fig8", "fig9", "fig10", "fig14", "fig20"):
        assert rows[name]["loading"] == "normal only: stops at the preload"
    assert rows["fig10"]["new_runs"] == 0  # Fig. 9's runs
    assert rows["fig29"]["new_runs"] == 0  # Fig. 21's runs
    low = ", ".join(f"{load:g}" for load in ERROR_BAR_LOADS)
    assert rows["fig28"]["meshes"] == f"1x; 2x at F* = {low}"
    assert rows["fig25"]["meshes"] == "1x; 2x at F* = 1.86"  # every point certified


def test_the_committed_table_is_current():
    with open(COMMITTED, newline="") as stream:
        committed = list(csv.DictReader(stream))
    current = [{key: str(row[key]) for key in COLUMNS} for row in scene_rows()]
    assert committed == current, "run `make docs` to regenerate docs/bench/figure_scenes.csv"
