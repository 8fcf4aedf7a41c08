"""Theory figures: each writes a PNG and the CSV behind it; the CSVs hold the plotted physics."""

import csv

import numpy as np
import pytest

from scripts.figures import FIGURES, make_figure, write_table
from solver.material import Material


def read_columns(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


@pytest.fixture(scope="module")
def figure_dir(tmp_path_factory):
    directory = tmp_path_factory.mktemp("figures")
    for name in FIGURES:
        make_figure(name, directory)
    return directory


@pytest.mark.parametrize("name", FIGURES)
def test_figure_writes_png_and_csv(name, figure_dir):
    png = figure_dir / f"{name}.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(read_columns(figure_dir / f"{name}.csv")) >= 2
    assert not list(figure_dir.glob(".*"))  # no temporary files left behind


def test_fig14_area_grows_with_load_and_shrinks_with_scale(figure_dir):
    data = read_columns(figure_dir / "fig14.csv")
    finest = {load: data["area_ratio"][data["load_star"] == load][-1]
              for load in np.unique(data["load_star"])}
    loads = sorted(finest)
    assert all(finest[a] < finest[b] for a, b in zip(loads, loads[1:], strict=False))
    for load in loads:
        assert np.all(np.diff(data["area_ratio"][data["load_star"] == load]) <= 0)


def test_fig17_sliding_area_not_below_normal(figure_dir):
    data = read_columns(figure_dir / "fig17.csv")
    assert np.all(data["area_ratio_sliding"] >= data["area_ratio_normal"])
    assert data["area_ratio_sliding"][-1] > data["area_ratio_normal"][-1]  # junction growth


def test_fig18_shear_stress_rises_to_tau_c(figure_dir):
    data = read_columns(figure_dir / "fig18.csv")
    assert np.all(np.diff(data["shear_stress_Pa"]) >= 0)  # assumption f'
    on_sliding_area = data["shear_on_sliding_area_Pa"]
    tau_c = Material().tau_c
    assert np.all(on_sliding_area <= tau_c * (1 + 1e-9))
    assert on_sliding_area[-1] == pytest.approx(tau_c, rel=1e-9)


def test_write_table_refuses_ragged_columns(tmp_path):
    with pytest.raises(ValueError, match="equal length"):
        write_table(tmp_path / "t.csv", {"a": np.arange(3), "b": np.arange(4)})
    assert not list(tmp_path.iterdir())
