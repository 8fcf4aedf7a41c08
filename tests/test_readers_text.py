"""Tests of geometry.readers.text: x-y-z point lists (synthetic and the NANOVEA ST400 samples),
height matrices, and the "text" reader telling one from the other."""

import re

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.readers import ReaderOptions, read_surface
from roughfriction.geometry.statistics import rms_height

from tests.test_readers import (
    DATA,
    asymmetric_field,
    needs_data,
    numeric,
    one_line_error,
    sample_json,
    write_xyz,
)

# --- x-y-z point lists (synthetic) --------------------------------------------------------------


def test_xyz_orientation_units_and_no_detrend(tmp_path):
    field = asymmetric_field()
    path = write_xyz(tmp_path / "scan.txt", numeric(field))
    surface = read_surface(path, ReaderOptions(detrend=False))
    assert surface.name == "scan" and surface.spacing == pytest.approx(5e-6)
    np.testing.assert_allclose(surface.heights, field * 1e-6, rtol=1e-12)  # [i, j] at x_i, y_j


def test_xyz_accepts_whitespace_shuffled_points_and_unit_overrides(tmp_path):
    field = asymmetric_field()
    path = write_xyz(tmp_path / "scan.dat", numeric(field), separator=" ", step_mm=5.0)
    lines = [line for line in path.read_text().splitlines() if line]
    np.random.default_rng(0).shuffle(lines)
    path.write_text("# x y z\n" + "\n".join(lines))
    surface = read_surface(path, ReaderOptions(lateral_unit="um", height_unit="nm",
                                               detrend=False))
    assert surface.spacing == pytest.approx(5e-6)
    np.testing.assert_allclose(surface.heights, field * 1e-9, rtol=1e-12)


@pytest.mark.parametrize("marker", ["-1.0000", "NM"])
def test_xyz_unmeasured_points_are_missing(tmp_path, marker):
    z = numeric(asymmetric_field())
    z[2, 3] = marker
    path = write_xyz(tmp_path / "holes.txt", z)
    with pytest.raises(InputError, match="1 missing"):
        read_surface(path)
    filled = read_surface(path, ReaderOptions(fill="plane", detrend=False))
    assert np.all(np.isfinite(filled.heights))


def test_xyz_missing_marker_can_be_disabled(tmp_path):
    z = numeric(asymmetric_field())
    z[2, 3] = "-1.0000"
    path = write_xyz(tmp_path / "s.txt", z)
    options = ReaderOptions(missing_height=None, height_unit="nm", detrend=False)
    surface = read_surface(path, options)
    assert surface.heights[2, 3] == pytest.approx(-1e-9)  # in um, the -1 spike is too steep


def test_xyz_refuses_non_uniform_grid(tmp_path):
    path = tmp_path / "bad.txt"
    xs = [0.0, 0.005, 0.010, 0.020]
    path.write_text("\n".join(f"{x},{y},1.0" for y in xs for x in xs))
    with pytest.raises(InputError, match="not uniformly spaced"):
        read_surface(path)


def test_xyz_refuses_unequal_spacings_and_duplicates(tmp_path):
    path = tmp_path / "rect.txt"
    path.write_text("\n".join(f"{0.005 * i},{0.010 * j},1.0" for j in range(4) for i in range(4)))
    with pytest.raises(InputError, match="pixels are not square.*--resample-pixels"):
        read_surface(path)
    path.write_text("\n".join(f"{0.005 * i},{0.005 * j},1.0" for j in range(4) for i in range(4)))
    path.write_text(path.read_text() + "\n0.0,0.0,2.0\n")
    with pytest.raises(InputError, match="more than once"):
        read_surface(path)


def test_xyz_refuses_size_and_ragged_rows(tmp_path):
    path = write_xyz(tmp_path / "s.txt", numeric(asymmetric_field()))
    with pytest.raises(InputError, match="drop --size"):
        read_surface(path, ReaderOptions(size="25um"))
    path.write_text(path.read_text() + "0.1,0.1\n")
    with pytest.raises(InputError, match="has 2 values"):
        read_surface(path)


def test_a_forced_xyz_list_needs_three_columns(tmp_path):
    path = tmp_path / "m.txt"
    path.write_text("\n".join(" ".join(f"{v:.6f}" for v in row) for row in asymmetric_field()))
    message = one_line_error(read_surface, path, ReaderOptions(fmt="xyz"))
    assert message == "m.txt: an x-y-z list needs 3 columns, not 6"


# --- NANOVEA ST400 samples ----------------------------------------------------------------------


@needs_data
@pytest.mark.parametrize("name", ["test1", "test2", "test3"])
def test_st400_samples(name):
    surface = read_surface(DATA / "nanovea_st400" / f"{name}.txt")
    stats = sample_json(f"nanovea_st400/{name}.txt")["stats_after_plane_detrend"]
    assert surface.n == 101 and surface.spacing == pytest.approx(5e-6, rel=1e-9)
    assert rms_height(surface.heights) == pytest.approx(stats["Sq_rms_height_m"], rel=1e-3)
    z = surface.heights / surface.spacing
    rms_slope = np.sqrt(np.mean(np.diff(z, axis=0) ** 2) + np.mean(np.diff(z, axis=1) ** 2))
    assert rms_slope == pytest.approx(stats["Sdq_rms_slope_forward_diff"], rel=1e-3)


@needs_data
def test_st400_unmeasured_point_is_refused_then_filled():
    path = DATA / "nanovea_st400" / "test4.txt"
    with pytest.raises(InputError, match="test4.txt: 1 missing"):
        read_surface(path)
    stats = sample_json("nanovea_st400/test4.txt")["stats_after_plane_detrend"]
    for method in ("nearest", "plane"):
        surface = read_surface(path, ReaderOptions(fill=method))
        assert surface.n == 101
        assert rms_height(surface.heights) == pytest.approx(stats["Sq_rms_height_m"], rel=1e-3)
    raw = read_surface(path, ReaderOptions(fill="nearest", detrend=False)).heights
    neighbours = raw[[49, 51, 50, 50], [79, 79, 78, 80]]
    assert raw[50, 79] in neighbours  # x = 0.25 mm, y = 0.395 mm was written as z = -1


# --- height matrices ----------------------------------------------------------------------------


@pytest.mark.parametrize("separator", [" ", ",", "\t"])
def test_matrix_text_needs_size_and_height_unit(tmp_path, separator):
    field = asymmetric_field(6, 5)
    path = tmp_path / "m.csv"
    path.write_text("\n".join(separator.join(f"{v:.6f}" for v in row) for row in field))
    with pytest.raises(InputError, match="--size"):
        read_surface(path, ReaderOptions(height_unit="um"))
    with pytest.raises(InputError, match="--height-unit"):
        read_surface(path, ReaderOptions(size="25um"))
    with pytest.raises(InputError, match="6 x 5 is not square"):
        read_surface(path, ReaderOptions(size="25um", height_unit="um"))
    options = ReaderOptions(size="25um", height_unit="um", square="crop", detrend=False)
    surface = read_surface(path, options)
    np.testing.assert_allclose(surface.heights, field[:5] * 1e-6, rtol=1e-12)


@pytest.mark.parametrize("rows", [3, 8])
def test_a_three_column_matrix_is_not_read_as_points(tmp_path, rows):
    path = tmp_path / "m.txt"
    path.write_text("\n".join(" ".join(f"{v:.6f}" for v in row)
                              for row in asymmetric_field(rows, 3)))
    message = one_line_error(read_surface, path, ReaderOptions(size="10um", height_unit="um"))
    assert re.search(r"3 columns but not an x-y-z list .*height matrix", message)
    assert "fmt='xyz'" in message


def test_a_three_point_list_on_a_diagonal_is_not_a_grid(tmp_path):
    path = tmp_path / "diagonal.txt"
    path.write_text("\n".join(f"{k * 0.005},{k * 0.005},{k}" for k in range(3)))
    message = one_line_error(read_surface, path)
    assert re.search(r"3 points cover 3 of the 3 x 3 grid", message)
    forced = one_line_error(read_surface, path, ReaderOptions(fmt="xyz"))  # points, as asked
    assert "6 missing" in forced


def test_a_matrix_refuses_a_lateral_unit(tmp_path):
    path = tmp_path / "m.csv"
    path.write_text("\n".join(",".join(f"{v:.6f}" for v in row) for row in asymmetric_field()))
    message = one_line_error(read_surface, path, ReaderOptions(size="25um", height_unit="um",
                                                               lateral_unit="mm"))
    assert message.startswith("m.csv: --lateral-unit applies to x-y-z point lists only")
