"""Reading results files (studies.post) and ``roughfriction post``, on a synthetic run with known
numbers written by the real writer."""

import json

import numpy as np
import pytest
from roughfriction.case import FemCase, Loading
from roughfriction.errors import InputError
from roughfriction.geometry.surface import Surface
from roughfriction.scripts.cli import EXIT_INPUT_ERROR, main
from roughfriction.solver.results import FemResult, StepRecord
from roughfriction.studies.post import (
    interference,
    junction_growth,
    map_summary,
    preload_state,
    read_run,
    run_report,
    step_table,
    tangential_curve,
    write_map_csvs,
)

N, SPACING, LOAD = 6, 1e-6, 0.3
HEIGHTS = np.random.default_rng(1).normal(0.0, 0.1e-6, (N, N))
CASE = FemCase(Surface(HEIGHTS, SPACING, "synthetic"), Loading(LOAD))
FN = CASE.normal_force
FLAT_HEIGHT = 0.05e-6

#: Two preload steps (half, then full F_n), three tangential steps, the last at inception:
#: (phase, F_n, F_t, u_x, contact nodes, patches, slipping nodes).
STEPS = [("normal", 0.5 * FN, 0.0, 0.0, 3, 3, 0),
         ("normal", FN, 0.0, 0.0, 8, 2, 0),
         ("tangential", FN, 0.2 * FN, 1e-8, 8, 2, 0),
         ("tangential", FN, 0.5 * FN, 2e-8, 9, 2, 4),
         ("tangential", FN, 0.6 * FN, 3e-8, 10, 2, 10)]


def records(steps):
    return [StepRecord(phase, fn, ft, ux, FLAT_HEIGHT, nodes / N**2, nodes, patches, slip, 0.1,
                       4, 0, 0.5 * k) for k, (phase, fn, ft, ux, nodes, patches, slip)
            in enumerate(steps)]


def contact_map():
    grid = np.zeros((N, N), bool)
    grid[0, 0] = grid[N - 1, 0] = True  # one patch across the periodic boundary
    grid[2:4, 2:4] = True  # a second patch of 4 nodes
    return grid


def fraction_map():
    """Per cell, the fraction of its area in contact [-]: half of each contact node's cell."""
    return np.where(contact_map(), 0.5, 0.0)


def normal_maps():
    """The maps of the end of the preload, with the heights."""
    return {"surface_heights": HEIGHTS, "contact_normal": contact_map(),
            "pressure_normal": np.where(contact_map(), 2e9, 0.0),
            "contact_fraction_normal": fraction_map()}


def write_run(path, steps=STEPS, converged=True, message="", maps=None):
    from roughfriction.studies.results_file import write_hdf5

    result = FemResult(records(steps), converged, message, False, {"total_s": 3.0},
                       {"ranks": 2, "linear_solver": "direct"})
    write_hdf5(path, CASE.inputs(), result, normal_maps() if maps is None else maps)
    return path


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    return write_run(tmp_path_factory.mktemp("post") / "run.h5")


def test_read_back_what_was_written(run_file):
    run = read_run(run_file)
    assert run.surface_name == "synthetic" and run.n == N and run.load_star == LOAD
    assert run.inputs == CASE.inputs()
    assert run.converged and run.summary["mu_s"] == pytest.approx(0.6)
    assert list(run.steps["phase"]) == [step[0] for step in STEPS]
    np.testing.assert_array_equal(run.maps["contact_normal"], contact_map())
    assert run.sizes["ranks"] == 2


def test_step_table(run_file):
    table = step_table(read_run(run_file))
    assert set(map(len, table.values())) == {len(STEPS)}
    np.testing.assert_allclose(table["nodes_per_patch"], [1.0, 4.0, 4.0, 4.5, 5.0])
    np.testing.assert_allclose(table["Ft_over_Fn"], [0, 0, 0.2, 0.5, 0.6])
    np.testing.assert_allclose(table["area_ratio"], np.array([3, 8, 8, 9, 10]) / N**2)


def test_preload_interference_and_junction_growth(run_file):
    run = read_run(run_file)
    state = preload_state(run)
    assert state["phase"] == "normal" and state["Fn_N"] == pytest.approx(FN)
    assert state["contact_nodes"] == 8
    assert interference(run) == pytest.approx(np.max(HEIGHTS - HEIGHTS.mean()) - FLAT_HEIGHT)
    growth = junction_growth(run)
    assert growth["growth"] == pytest.approx(10 / 8 - 1)
    assert growth["inception"] is True
    curve = tangential_curve(run)
    np.testing.assert_allclose(curve["ux_m"], [0, 1e-8, 2e-8, 3e-8])
    np.testing.assert_allclose(curve["Ft_over_Fn"], [0, 0.2, 0.5, 0.6])


def test_an_unfinished_preload_has_no_preload_state(tmp_path):
    run = read_run(write_run(tmp_path / "partial.h5", STEPS[:1], converged=False,
                             message="preload did not converge beyond 0.5 x F_n"))
    assert preload_state(run) is None and interference(run) is None
    assert junction_growth(run)["growth"] is None
    assert tangential_curve(run)["ux_m"].size == 0
    assert step_table(run)["nodes_per_patch"][0] == 1.0


def test_map_summaries_and_csv(run_file, tmp_path):
    run = read_run(run_file)
    assert map_summary("contact_normal", run.maps["contact_normal"]) == {
        "nodes": 6, "fraction": 6 / N**2, "patches": 2, "nodes_per_patch": 3.0}
    assert map_summary("pressure_normal", run.maps["pressure_normal"])["max_Pa"] == 2e9
    written = write_map_csvs(run, tmp_path / "maps")
    assert {path.name for path in written} == {"surface_heights.csv", "contact_normal.csv",
                                               "pressure_normal.csv",
                                               "contact_fraction_normal.csv"}
    np.testing.assert_array_equal(map_values(tmp_path / "maps" / "contact_normal.csv"),
                                  contact_map().astype(int))
    np.testing.assert_allclose(map_values(tmp_path / "maps" / "surface_heights.csv"), HEIGHTS,
                               rtol=1e-9)
    assert not list((tmp_path / "maps").glob(".*"))


def map_values(path):
    """The N x N values of a map CSV (third column, rows in x-major order)."""
    return np.loadtxt(path, delimiter=",", skiprows=1)[:, 2].reshape(N, N)


@pytest.mark.parametrize(("name", "column"), [("pressure_normal", "pressure_normal_Pa"),
                                              ("surface_heights", "surface_heights_m"),
                                              ("contact_fraction_normal",
                                               "contact_fraction_normal"),
                                              ("contact_normal", "contact_normal")])
def test_map_csvs_name_quantity_unit_and_coordinates(run_file, tmp_path, name, column):
    """Each map CSV is a table with a header, x and y in m, and the map in its unit: a reader
    needs nothing else to place every value (pandas or np.loadtxt reads it)."""
    import csv

    run = read_run(run_file)
    write_map_csvs(run, tmp_path)
    with open(tmp_path / f"{name}.csv", newline="") as file:
        rows = list(csv.reader(file))
    assert rows[0] == ["x_m", "y_m", column]
    table = np.array(rows[1:], dtype=float)
    i, j = np.indices((N, N))
    np.testing.assert_allclose(table[:, 0], (i * SPACING).ravel(), rtol=1e-12)
    np.testing.assert_allclose(table[:, 1], (j * SPACING).ravel(), rtol=1e-12)
    np.testing.assert_allclose(table[:, 2], np.asarray(run.maps[name], float).ravel(),
                               rtol=1e-9)


def test_each_map_summary_states_its_own_unit(run_file):
    """Contact fractions are dimensionless, not Pa: their summary is the area ratio they add up
    to (A_r/A_n, the mean over the cells) and the largest cell fraction."""
    run = read_run(run_file)
    fraction = map_summary("contact_fraction_normal", run.maps["contact_fraction_normal"])
    assert fraction == {"area_ratio": pytest.approx(6 * 0.5 / N**2), "max_cell_fraction": 0.5,
                        "cells_in_contact": 6}
    assert map_summary("pressure_normal", run.maps["pressure_normal"]) == {
        "max_Pa": 2e9, "mean_nonzero_Pa": 2e9}
    assert set(map_summary("surface_heights", HEIGHTS)) == {"min_m", "max_m"}
    assert map_summary("surface_heights", HEIGHTS) == {"min_m": HEIGHTS.min(),
                                                       "max_m": HEIGHTS.max()}
    shear = map_summary("shear_x_sliding", -np.ones((N, N)))
    assert set(shear) == {"max_Pa", "mean_nonzero_Pa"}
    assert shear["max_Pa"] == abs(shear["mean_nonzero_Pa"]) == 1.0  # 1 Pa against the slide
    gap = np.full((N, N), 2e-9)
    gap[0, 0], gap[1, 1] = -1e-9, np.nan  # a penetrating node; a grid point without a node
    assert map_summary("gap_sliding", gap) == {"min_m": -1e-9, "max_m": 2e-9}
    with pytest.raises(ValueError, match="unit"):  # a new map must say its unit first
        map_summary("temperature_normal", np.ones((N, N)))


def test_report_is_json(run_file):
    report = json.loads(json.dumps(run_report(read_run(run_file))))
    assert report["steps"] == len(STEPS)  # the summary's step count, not overwritten
    assert report["per_step"]["contact_patches"] == [3, 2, 2, 2, 2]
    assert report["maps"]["contact_normal"]["patches"] == 2


def test_post_command_json_and_maps(run_file, tmp_path, capsys):
    assert main(["post", str(run_file), "--json", "--maps", str(tmp_path / "maps")]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["mu_s"] == pytest.approx(0.6)
    assert record["omega_0_m"] > 0
    assert record["omega_0_m"] == pytest.approx(np.max(HEIGHTS - HEIGHTS.mean()) - FLAT_HEIGHT,
                                                rel=1e-12)
    assert record["junction"]["growth"] == pytest.approx(0.25)
    assert (tmp_path / "maps" / "contact_normal.csv").exists()
    np.testing.assert_array_equal(map_values(tmp_path / "maps" / "contact_normal.csv"),
                                  contact_map().astype(int))
    np.testing.assert_allclose(map_values(tmp_path / "maps" / "pressure_normal.csv"),
                               np.where(contact_map(), 2e9, 0.0), rtol=1e-9)
    np.testing.assert_allclose(record["per_step"]["Fn_N"], [step[1] for step in STEPS],
                               rtol=1e-12)
    np.testing.assert_allclose(record["tangential_curve"]["Ft_over_Fn"], [0, 0.2, 0.5, 0.6])
    assert record["Fn"] == pytest.approx(LOAD * (N * SPACING) ** 2 * CASE.material.Sy)


def test_post_command_text(run_file, capsys):
    assert main(["post", str(run_file)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("file ")
    for section in ("\nper_step\n", "\njunction\n", "\ntangential_curve\n", "\nmaps\n"):
        assert section in out
    table = out.split("\nper_step\n")[1].splitlines()
    assert table[0].split()[:3] == ["phase", "Fn_N", "Ft_N"]
    assert table[5].split()[0] == "tangential"
    for line, (phase, fn, ft, ux, nodes, patches, slipping) in zip(table[1:6], STEPS,
                                                                     strict=True):
        cells = line.split()
        assert cells[0] == phase and [int(cells[k]) for k in (6, 7, 9)] == [nodes, patches,
                                                                             slipping]
        assert [float(cell) for cell in cells[1:5]] == pytest.approx(
            [fn, ft, ft / fn, ux], rel=5e-6)
    scalars = {line.split()[0]: line.split()[1:] for line in out.split("\nper_step\n")[0]
               .splitlines() if line.strip()}
    assert float(scalars["mu_s"][0]) == pytest.approx(0.6)
    assert float(scalars["omega_0_m"][0]) == pytest.approx(
        np.max(HEIGHTS - HEIGHTS.mean()) - FLAT_HEIGHT, rel=5e-6)
    (line,) = [line for line in out.splitlines() if line.split()[:1] == ["contact_normal"]]
    assert line.split()[1:] == ["nodes=6", "fraction=0.166667", "patches=2", "nodes_per_patch=3"]


def truncated(run_file, tmp_path):
    path = tmp_path / "truncated.h5"
    path.write_bytes(run_file.read_bytes()[: run_file.stat().st_size // 2])
    return path


def foreign(tmp_path):
    import h5py

    path = tmp_path / "foreign.h5"
    with h5py.File(path, "w") as h5:
        h5.create_dataset("x", data=np.arange(3))
    return path


def temporary(run_file, tmp_path):
    path = tmp_path / ".abc.h5.123.tmp"
    path.write_bytes(run_file.read_bytes())
    return path


BAD_FILES = {
    "missing": (lambda run_file, tmp_path: tmp_path / "nope.h5", "no results file"),
    "truncated": (truncated, "cannot read"),
    "foreign": (lambda run_file, tmp_path: foreign(tmp_path), "not a roughfriction"),
    "temporary": (temporary, "unfinished write"),
}


@pytest.mark.parametrize("kind", sorted(BAD_FILES))
def test_bad_files_are_one_line_errors(kind, run_file, tmp_path, capsys):
    make, message = BAD_FILES[kind]
    path = make(run_file, tmp_path)
    with pytest.raises(InputError, match=message):
        read_run(path)
    assert main(["post", str(path)]) == EXIT_INPUT_ERROR
    err = capsys.readouterr().err.strip()
    assert err.startswith("roughfriction: error:") and "\n" not in err
