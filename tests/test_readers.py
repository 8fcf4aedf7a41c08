"""Tests of geometry.readers on synthetic files and the measured samples in data/surfaces."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.generate import builtin_surface
from roughfriction.geometry.readers import (
    load_surface,
    parse_length,
    read_heights,
    read_surface,
    square_pixels,
)
from roughfriction.geometry.statistics import rms_height
from roughfriction.geometry.surface import detrend_plane
from roughfriction.scripts.cli import build_parser, surface_from_args

# The measured samples ship with the repository (data/surfaces/README.md).
DATA = Path(__file__).resolve().parents[1] / "data" / "surfaces"


def needs_data(test):
    """A test on the shipped samples (which must be there: a missing file fails it)."""
    return test


def sample_json(relative):
    return json.loads((DATA / relative).with_suffix(".json").read_text())


def sq_after_detrend(heights):
    """RMS height [m] about the least-squares plane, over the measured points (the json's Sq)."""
    return float(np.sqrt(np.nanmean(detrend_plane(heights) ** 2)))


# --- parse_length -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "metres"),
    [
        ("127um", 127e-6),
        ("127 \u00b5m", 127e-6),  # micro sign
        ("127 \u03bcm", 127e-6),  # Greek mu
        ("0.127mm", 0.127e-3),
        ("1.27e-4 m", 1.27e-4),
        ("500nm", 500e-9),
        (" .5 mm ", 0.5e-3),
    ],
)
def test_parse_length(text, metres):
    assert parse_length(text) == pytest.approx(metres, rel=1e-12)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("127", "no unit; add one, e.g. 127um"),
        ("12 furlongs", "unknown length unit"),
        ("um", "cannot read a length"),
    ],
)
def test_parse_length_errors(text, message):
    with pytest.raises(InputError, match=message):
        parse_length(text)


# --- x-y-z point lists (synthetic) --------------------------------------------------------------


def write_xyz(path, heights_um, step_mm=0.005, separator=",", blank_between_rows=True):
    """ST400-style export: x fastest, x and y in mm, z in um, blank line between rows."""
    lines = []
    for j in range(heights_um.shape[1]):
        for i in range(heights_um.shape[0]):
            z = heights_um[i, j]
            lines.append(separator.join([f"{i * step_mm:.4f}", f"{j * step_mm:.4f}", z]))
        if blank_between_rows:
            lines += ["", ""]
    path.write_text("\n".join(lines) + "\n")
    return path


def numeric(values):
    return np.vectorize(lambda v: f"{v:.4f}")(values)


def asymmetric_field(nx=6, ny=6):
    i, j = np.indices((nx, ny), dtype=float)
    return 100.0 + 0.3 * i**2 + 0.05 * j  # um; differs under transposition; RMS slope < 1 at 5 um


def test_xyz_orientation_units_and_no_detrend(tmp_path):
    field = asymmetric_field()
    surface = read_surface(write_xyz(tmp_path / "scan.txt", numeric(field)), detrend=False)
    assert surface.name == "scan" and surface.spacing == pytest.approx(5e-6)
    np.testing.assert_allclose(surface.heights, field * 1e-6, rtol=1e-12)  # [i, j] at x_i, y_j


def test_xyz_accepts_whitespace_shuffled_points_and_unit_overrides(tmp_path):
    field = asymmetric_field()
    path = write_xyz(tmp_path / "scan.dat", numeric(field), separator=" ", step_mm=5.0)
    lines = [line for line in path.read_text().splitlines() if line]
    np.random.default_rng(0).shuffle(lines)
    path.write_text("# x y z\n" + "\n".join(lines))
    surface = read_surface(path, lateral_unit="um", height_unit="nm", detrend=False)
    assert surface.spacing == pytest.approx(5e-6)
    np.testing.assert_allclose(surface.heights, field * 1e-9, rtol=1e-12)


@pytest.mark.parametrize("marker", ["-1.0000", "NM"])
def test_xyz_unmeasured_points_are_missing(tmp_path, marker):
    z = numeric(asymmetric_field())
    z[2, 3] = marker
    path = write_xyz(tmp_path / "holes.txt", z)
    with pytest.raises(InputError, match="1 missing"):
        read_surface(path)
    filled = read_surface(path, fill="plane", detrend=False)
    assert np.all(np.isfinite(filled.heights))


def test_xyz_missing_marker_can_be_disabled(tmp_path):
    z = numeric(asymmetric_field())
    z[2, 3] = "-1.0000"
    path = write_xyz(tmp_path / "s.txt", z)
    surface = read_surface(path, missing_height=None, height_unit="nm", detrend=False)
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
        read_surface(path, size="25um")
    path.write_text(path.read_text() + "0.1,0.1\n")
    with pytest.raises(InputError, match="has 2 values"):
        read_surface(path)


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
    with pytest.raises(InputError, match="'test4': 1 missing"):
        read_surface(path)
    stats = sample_json("nanovea_st400/test4.txt")["stats_after_plane_detrend"]
    for method in ("nearest", "plane"):
        surface = read_surface(path, fill=method)
        assert surface.n == 101
        assert rms_height(surface.heights) == pytest.approx(stats["Sq_rms_height_m"], rel=1e-3)
    raw = read_surface(path, fill="nearest", detrend=False).heights
    neighbours = raw[[49, 51, 50, 50], [79, 79, 78, 80]]
    assert raw[50, 79] in neighbours  # x = 0.25 mm, y = 0.395 mm was written as z = -1


# --- npy and matrix files -----------------------------------------------------------------------


@needs_data
@pytest.mark.parametrize("name", ["di-3", "matrix-2"])
def test_instrument_npy_samples_match_their_sq(name):
    meta = sample_json(f"instruments/{name}.npy")
    n = meta["nb_grid_pts"][0]
    size = (n - 1) * meta["pixel_size_m"][0]
    surface = read_surface(DATA / "instruments" / f"{name}.npy", size=size)
    assert surface.n == n and surface.spacing == pytest.approx(meta["pixel_size_m"][0], rel=1e-12)
    sq = meta["stats_after_plane_detrend"]["Sq_rms_height_m"]
    assert rms_height(surface.heights) == pytest.approx(sq, rel=1e-3)


@needs_data
@pytest.mark.parametrize("name", ["al3d-1", "opd-1", "sur-2"])
def test_detrend_of_non_square_samples_matches_their_sq(name):
    raw = np.load(DATA / "instruments" / f"{name}.npy")
    sq = sample_json(f"instruments/{name}.npy")["stats_after_plane_detrend"]["Sq_rms_height_m"]
    assert sq_after_detrend(raw) == pytest.approx(sq, rel=1e-3)


@needs_data
def test_opd_sample_needs_crop_and_fill():
    path = DATA / "instruments" / "opd-1.npy"
    with pytest.raises(InputError, match="not square.*--crop"):
        read_surface(path, size="125.7um")
    with pytest.raises(InputError, match="missing.*fill="):
        read_surface(path, size="125.7um", square="crop")
    surface = read_surface(path, size="125.7um", square="crop", fill="nearest")
    assert surface.n == 480 and surface.spacing == pytest.approx(125.7e-6 / 639)


def test_npy_needs_size_and_takes_height_unit(tmp_path):
    path = tmp_path / "z.npy"
    np.save(path, asymmetric_field())
    with pytest.raises(InputError, match="--size"):
        read_surface(path)
    surface = read_surface(path, size="0.025mm", height_unit="um", detrend=False)
    assert surface.spacing == pytest.approx(5e-6)
    np.testing.assert_allclose(surface.heights, asymmetric_field() * 1e-6, rtol=1e-12)
    with pytest.raises(InputError, match="lateral-unit"):
        read_surface(path, size="25um", lateral_unit="mm")
    with pytest.raises(InputError, match="> 0"):
        read_surface(path, size=-1.0)


def test_npy_refuses_one_dimensional_data(tmp_path):
    path = tmp_path / "profile.npy"
    np.save(path, np.arange(10.0))
    with pytest.raises(InputError, match="2-D"):
        read_surface(path, size="9um")


@pytest.mark.parametrize("separator", [" ", ",", "\t"])
def test_matrix_text_needs_size_and_height_unit(tmp_path, separator):
    field = asymmetric_field(6, 5)
    path = tmp_path / "m.csv"
    path.write_text("\n".join(separator.join(f"{v:.6f}" for v in row) for row in field))
    with pytest.raises(InputError, match="--size"):
        read_surface(path, height_unit="um")
    with pytest.raises(InputError, match="--height-unit"):
        read_surface(path, size="25um")
    with pytest.raises(InputError, match="6 x 5 is not square"):
        read_surface(path, size="25um", height_unit="um")
    surface = read_surface(path, size="25um", height_unit="um", square="crop", detrend=False)
    np.testing.assert_allclose(surface.heights, field[:5] * 1e-6, rtol=1e-12)


def test_general_reader_errors(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_surface(tmp_path / "absent.npy")
    path = tmp_path / "z.npy"
    np.save(path, np.zeros((4, 4)))
    with pytest.raises(InputError, match="unknown format"):
        read_surface(path, fmt="tiff")
    with pytest.raises(InputError, match="square option"):
        read_surface(path, size="3um", square="pad")
    with pytest.raises(InputError, match="unknown fill method"):
        read_surface(path, size="3um", fill="spline")
    with pytest.raises(InputError, match="unknown pixels option"):
        read_surface(path, size="3um", pixels="nearest")


def test_heights_in_a_wrong_unit_are_refused_by_their_rms_slope(tmp_path):
    path = tmp_path / "microns.npy"
    np.save(path, asymmetric_field())  # um, read as metres: RMS slope ~ 1e5
    with pytest.raises(InputError, match=r"RMS slope \S+ > 1: .*give --height-unit "):
        read_surface(path, size="25um")
    assert read_surface(path, size="25um", height_unit="um").n == 6
    assert read_surface(path, size="25um", height_unit="m").n == 6  # the user says so


# --- instrument formats through SurfaceTopography -----------------------------------------------


def test_instrument_format_without_the_extra_names_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "SurfaceTopography", None)  # makes the import fail
    path = tmp_path / "scan.x3p"
    path.write_bytes(b"PK")
    with pytest.raises(InputError, match=r"pip install 'roughfriction\[instruments\]'"):
        read_surface(path)


# Each raw instrument sample and the reader options it needs: x3p-2 has 0.128 um x 0.315 um
# pixels, resampled to a 650 x 1602 grid; sur-2 and opd-1 have non-square grids with unmeasured
# points (left in the crop), al3d-1 a non-square grid.
INSTRUMENT_OPTIONS = {
    "x3p-2.x3p": {"pixels": "resample", "square": "crop"},
    "sur-2.sur": {"square": "crop", "fill": "nearest"},
    "opd-1.opd": {"square": "crop", "fill": "nearest"},
    "al3d-1.al3d": {"square": "crop"},
    "di-3.di": {},
}
# What the refusal without an option names.
OPTION_HINTS = {"pixels": "--resample-pixels", "square": "--crop", "fill": "fill="}


@needs_data
@pytest.mark.parametrize("name", sorted(INSTRUMENT_OPTIONS))
def test_instrument_file_matches_its_json(name):
    meta = sample_json(f"instruments/{name}")
    heights, dx, dy = read_heights(DATA / "instruments" / name)
    assert list(heights.shape) == meta["nb_grid_pts"]
    assert [dx, dy] == pytest.approx(meta["pixel_size_m"], rel=1e-12)
    assert np.count_nonzero(np.isnan(heights)) == meta["undefined_points_as_nan"]
    sq = meta["stats_after_plane_detrend"]["Sq_rms_height_m"]
    assert sq_after_detrend(heights) == pytest.approx(sq, rel=1e-6)


@needs_data
@pytest.mark.parametrize("name", sorted(INSTRUMENT_OPTIONS))
def test_instrument_file_loads_with_the_options_it_needs(name):
    meta = sample_json(f"instruments/{name}")
    surface = load_surface(str(DATA / "instruments" / name), **INSTRUMENT_OPTIONS[name])
    assert surface.n == min(meta["nb_grid_pts"])
    assert surface.spacing == pytest.approx(min(meta["pixel_size_m"]), rel=1e-12)
    if not INSTRUMENT_OPTIONS[name]:  # the whole grid: the json's Sq
        sq = meta["stats_after_plane_detrend"]["Sq_rms_height_m"]
        assert rms_height(surface.heights) == pytest.approx(sq, rel=1e-6)


@needs_data
@pytest.mark.parametrize(
    ("name", "option"),
    [(name, option) for name, options in INSTRUMENT_OPTIONS.items() for option in options],
)
def test_instrument_file_without_an_option_it_needs_names_it(name, option):
    options = {key: value for key, value in INSTRUMENT_OPTIONS[name].items() if key != option}
    with pytest.raises(InputError, match=OPTION_HINTS[option]):
        read_surface(DATA / "instruments" / name, **options)


@needs_data
@pytest.mark.parametrize("name", ["al3d-1.al3d", "di-3.di", "opd-1.opd", "sur-2.sur"])
def test_instrument_file_matches_its_npy_conversion(name):
    path = DATA / "instruments" / name
    heights, _, _ = read_heights(path)
    np.testing.assert_array_equal(heights, np.load(path.with_suffix(".npy")))  # NaN where NaN


@needs_data
def test_x3p_pixels_resampled_to_the_smaller_side_keep_size_and_sq():
    meta = sample_json("instruments/x3p-2.x3p")
    heights, h = square_pixels(*read_heights(DATA / "instruments" / "x3p-2.x3p"))
    assert h == min(meta["pixel_size_m"]) and heights.shape == (650, 1602)
    np.testing.assert_allclose(np.array(heights.shape) * h, meta["physical_sizes_m"], atol=h)
    sq = meta["stats_after_plane_detrend"]["Sq_rms_height_m"]
    assert sq_after_detrend(heights) == pytest.approx(sq, rel=1e-2)  # measured -0.11 %


def test_square_pixels_interpolate_a_plane_and_keep_the_fine_axis():
    dx, dy = 1e-6, 2.5e-6
    i, j = np.indices((6, 4), dtype=float)
    old = 3e-8 * (i + 0.5) + 5e-8 * (j + 0.5) * dy / dx  # plane through the pixel centres
    old[2, 1] = np.nan
    new, h = square_pixels(old, dx, dy)
    k, m = np.indices((6, 10), dtype=float)
    plane = 3e-8 * (k + 0.5) + 5e-8 * (m + 0.5)
    assert h == dx and new.shape == (6, 10)
    finite = np.isfinite(new)
    assert np.array_equal(np.argwhere(~finite), [[2, col] for col in range(1, 6)])  # NaN's cells
    inner = finite.copy()
    inner[:, [0, -1]] = False  # centres beyond the outer old ones keep the edge value
    np.testing.assert_allclose(new[inner], plane[inner], rtol=1e-12)


@needs_data
def test_cli_resample_pixels_flag_reaches_the_reader():
    args = build_parser().parse_args(
        ["surface", "stats", str(DATA / "instruments" / "x3p-2.x3p"), "--resample-pixels", "--crop"]
    )
    surface = surface_from_args(args)
    assert surface.n == 650 and surface.spacing == pytest.approx(1.27656509837346e-07, rel=1e-12)


# --- load_surface -------------------------------------------------------------------------------


def test_load_surface_builtin_accepts_default_options_only():
    surface = load_surface("G5", size=None, fill=None, square=None, detrend=True)
    np.testing.assert_array_equal(surface.heights, builtin_surface("G5").heights)
    with pytest.raises(InputError, match=r"\(size\) apply to files"):
        load_surface("G5", size="127um")


def test_load_surface_reads_files_and_lists_names_when_unknown(tmp_path):
    path = tmp_path / "mine.npy"
    np.save(path, asymmetric_field())
    assert load_surface(str(path), size="25um", height_unit="um").name == "mine"
    with pytest.raises(InputError, match="neither a file nor a built-in.*G1.*63M"):
        load_surface(str(tmp_path / "missing.npy"))
