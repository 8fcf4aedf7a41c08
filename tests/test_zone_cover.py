"""benchmarks.zone_cover: how well a zone built from a run's contact holds a 2x run's contact."""

import csv
from types import SimpleNamespace

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.surface import bilinear_refine

from benchmarks.cli import main
from benchmarks.zone_cover import coverage_rows, write_rows


def _runs(far_contact: bool, overlap_there: bool, near_there: bool = False):
    """A coarse 8 x 8 run touching at node (2, 2) and its 2x run, which touches the same
    point and, with ``far_contact``, node (12, 12) (coarse node (6, 6), whose cells 5..6 are
    three cells from the contact's cells 1..2 across the periodic boundary); with
    ``overlap_there`` the coarse surface peaks at (6, 6) above the flat's lowest position, with
    ``near_there`` the coarse run's deformed gap there is zero (else 1 m, far)."""
    heights = np.zeros((8, 8))
    heights[2, 2] = 2e-7
    heights[6, 6] = 2e-7 if overlap_there else 0.0
    contact = np.zeros((8, 8), bool)
    contact[2, 2] = True
    fine_contact = np.zeros((16, 16), bool)
    fine_contact[4, 4] = True
    fine_contact[12, 12] = far_contact
    inputs = {"surface": {"name": "test"}, "loading": {"load_star": 0.155}}
    gap = np.ones((8, 8))
    gap[2, 2], gap[6, 6] = -1e-9, 0.0 if near_there else 1.0
    coarse = SimpleNamespace(maps={"contact_normal": contact, "surface_heights": heights,
                                   "gap_normal": gap},
                             steps={"flat_height": np.array([2e-7, 1e-7])}, inputs=inputs)
    fine = SimpleNamespace(maps={"contact_normal": fine_contact,
                                 "surface_heights": bilinear_refine(heights, 2)},
                           steps={}, inputs=inputs)
    return coarse, fine


def _uncovered(rows, rule, margin):
    return next(row["uncovered"] for row in rows if row["rule"] == rule
                and row["margin"] == margin)


def test_a_contact_far_from_the_coarse_contact_is_uncovered_until_the_margin_reaches_it():
    rows = coverage_rows(*_runs(far_contact=True, overlap_there=False))
    assert [_uncovered(rows, "contact", margin) for margin in range(6)] == [1, 1, 1, 0, 0, 0]
    assert all(row["fine_contact_nodes"] == 2 for row in rows)
    share = {row["margin"]: row["zone_share"] for row in rows if row["rule"] == "contact"}
    assert share[0] == 4 / 64 and share[1] == 16 / 64


def test_the_flats_overlap_covers_a_contact_the_coarse_mesh_did_not_make():
    rows = coverage_rows(*_runs(far_contact=True, overlap_there=True))
    assert _uncovered(rows, "contact", 0) == 1
    assert _uncovered(rows, "contact + overlap", 0) == 0
    assert {(row["lowest_flat_m"], row["overlap_share"]) for row in rows} == {(1e-7, 2 / 64)}


@pytest.mark.parametrize("overlap_there, near_there, uncovered", [
    (True, True, 0), (True, False, 1), (False, True, 1)])
def test_the_ladder_s_near_nodes_are_the_overlapped_nodes_near_the_flat(overlap_there,
                                                                         near_there, uncovered):
    rows = coverage_rows(*_runs(True, overlap_there, near_there))
    assert _uncovered(rows, "contact + near the flat", 0) == uncovered


def test_runs_of_different_grids_or_surfaces_are_refused():
    coarse, fine = _runs(far_contact=False, overlap_there=False)
    with pytest.raises(InputError, match="twice"):
        coverage_rows(coarse, coarse)
    other = SimpleNamespace(**{**vars(fine), "maps": {**fine.maps,
                                                       "surface_heights": -fine.maps[
                                                           "surface_heights"]}})
    with pytest.raises(InputError, match="same surface"):
        coverage_rows(coarse, other)
    gapless = SimpleNamespace(**{**vars(coarse), "maps": {
        key: value for key, value in coarse.maps.items() if key != "gap_normal"}})
    with pytest.raises(InputError, match="gap maps"):
        coverage_rows(gapless, fine)
    bare = SimpleNamespace(**{**vars(fine),
                              "maps": {"contact_normal": fine.maps["contact_normal"]}})
    with pytest.raises(InputError, match="surface_heights"):
        coverage_rows(coarse, bare)


def test_the_table_is_written_whole(tmp_path):
    rows = coverage_rows(*_runs(far_contact=True, overlap_there=False), margins=(0, 4))
    path = write_rows(rows, tmp_path / "zone_cover.csv")
    with open(path) as stream:
        written = list(csv.DictReader(stream))
    assert [int(row["uncovered"]) for row in written] == [1, 0, 1, 0, 1, 0]
    assert [p.name for p in tmp_path.iterdir()] == ["zone_cover.csv"]


def test_bench_zone_takes_pairs_of_runs(tmp_path, capsys):
    assert main(["zone", str(tmp_path / "one.h5")]) == 2
    assert "pairs of runs" in capsys.readouterr().err


def test_bench_zone_takes_one_label_per_pair(tmp_path, capsys):
    runs = [str(tmp_path / name) for name in ("a.h5", "b.h5")]
    assert main(["zone", *runs, "--labels", "one", "two"]) == 2
    assert "one name per pair" in capsys.readouterr().err


def test_rows_carry_the_label_given():
    rows = coverage_rows(*_runs(far_contact=False, overlap_there=False), margins=(0,),
                         label="window 1")
    assert {row["case"] for row in rows} == {"window 1"}


def test_bench_zone_refuses_a_pair_of_runs_of_different_physics(tmp_path, capsys):
    """A row's physics stamp is its pair's: two runs of different physics make none."""
    import h5py

    runs = []
    for name, physics in (("coarse.h5", "a" * 64), ("fine.h5", "b" * 64)):
        with h5py.File(tmp_path / name, "w") as h5:
            h5.attrs["physics"] = physics
        runs.append(str(tmp_path / name))
    assert main(["zone", *runs]) == 2
    assert f"different physics ({'a' * 12} and {'b' * 12})" in capsys.readouterr().err
