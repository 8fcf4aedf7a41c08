"""Tests of geometry.readers on synthetic files and the measured samples in data/surfaces."""

import json
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.generate import builtin_names, builtin_surface
from roughfriction.geometry.readers import (
    MAX_RMS_HEIGHT,
    MIN_RMS_HEIGHT,
    MIN_RMS_SLOPE,
    load_surface,
    parse_length,
    read_heights,
    read_surface,
    square_pixels,
)
from roughfriction.geometry.statistics import MAX_SEAM_RATIO, periodic_seam_ratio, rms_height
from roughfriction.geometry.surface import crop_square, detrend_plane, windows
from roughfriction.scripts.cli import build_parser, surface_from_args
from roughfriction.studies.paper import surface_window

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
    with pytest.raises(InputError, match="test4.txt: 1 missing"):
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


@pytest.mark.parametrize("rows", [3, 8])
def test_a_three_column_matrix_is_not_read_as_points(tmp_path, rows):
    path = tmp_path / "m.txt"
    path.write_text("\n".join(" ".join(f"{v:.6f}" for v in row)
                              for row in asymmetric_field(rows, 3)))
    message = one_line_error(read_surface, path=path, size="10um", height_unit="um")
    assert re.search(r"3 columns but not an x-y-z list .*height matrix", message)
    assert "fmt='xyz'" in message


def test_a_three_point_list_on_a_diagonal_is_not_a_grid(tmp_path):
    path = tmp_path / "diagonal.txt"
    path.write_text("\n".join(f"{k * 0.005},{k * 0.005},{k}" for k in range(3)))
    message = one_line_error(read_surface, path=path)
    assert re.search(r"3 points cover 3 of the 3 x 3 grid", message)
    forced = one_line_error(read_surface, path=path, fmt="xyz")  # read as points, as asked
    assert "6 missing" in forced


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
    with pytest.raises(InputError, match=r"RMS slope \S+ > 1 .*--height-unit.*--size"):
        read_surface(path, size="25um")
    assert read_surface(path, size="25um", height_unit="um").n == 6
    steep = tmp_path / "steep.npy"
    np.save(steep, asymmetric_field() * 1e-4)  # metres: RMS height < 1 mm, slope > 1
    with pytest.raises(InputError, match=r"RMS slope \S+ > 1 "):
        read_surface(steep, size="25um")
    assert read_surface(steep, size="25um", height_unit="m").n == 6  # the user says so


# --- unit slips: implausible RMS heights and slopes ---------------------------------------------


def one_line_error(call, **options):
    """The message of the InputError that ``call(**options)`` raises (it must be one line)."""
    with pytest.raises(InputError) as error:
        call(**options)
    message = str(error.value)
    assert "\n" not in message
    return message


def npy_size(name, unit="um"):
    """Scan length of an instrument .npy sample along x: its number of um, followed by ``unit``
    (another unit makes a unit slip)."""
    meta = sample_json(f"instruments/{name}.npy")
    return f"{(meta['nb_grid_pts'][0] - 1) * meta['pixel_size_m'][0] / 1e-6:.6g}{unit}"


@needs_data
def test_heights_in_a_too_small_unit_are_refused_by_their_rms_height():
    path = DATA / "instruments" / "di-3.npy"  # heights in metres, read as nm
    message = one_line_error(read_surface, path=path, size=npy_size("di-3"), height_unit="nm")
    assert re.search(rf"RMS height \S+ m < {MIN_RMS_HEIGHT:g} m .*nm.*--height-unit", message)


@needs_data
def test_heights_in_a_too_large_unit_are_refused_by_their_rms_height():
    path = DATA / "nanovea_st400" / "test1.txt"  # heights in um, read as mm
    message = one_line_error(read_surface, path=path, height_unit="mm")
    assert re.search(rf"RMS height \S+ m > {MAX_RMS_HEIGHT:g} m .*mm.*--height-unit", message)


@needs_data
def test_a_scan_size_in_a_wrong_unit_is_refused_by_its_flat_rms_slope():
    path = DATA / "instruments" / "al3d-1.npy"
    size = npy_size("al3d-1", "mm")  # the length in um, written as mm
    message = one_line_error(read_surface, path=path, size=size, square="crop")
    assert re.search(rf"RMS slope \S+ < {MIN_RMS_SLOPE:g} .*--size {size}.*--height-unit", message)
    assert "--allow-flat" in message
    right = read_surface(path, size=npy_size("al3d-1"), square="crop")
    flat = read_surface(path, size=size, square="crop", allow_flat=True)  # the user says so
    assert flat.rms_slope == pytest.approx(right.rms_slope / 1000, rel=1e-2)


@needs_data
def test_a_flat_slope_with_the_height_unit_given_names_the_lateral_flag_only():
    path = DATA / "instruments" / "al3d-1.npy"
    message = one_line_error(read_surface, path=path, size=npy_size("al3d-1", "mm"),
                             height_unit="m", square="crop")
    assert "--size" in message and "--height-unit" not in message


def write_xyz_of(path, surface):
    """``surface`` as an ST400-style x-y-z list (x, y in mm, z in um)."""
    return write_xyz(path, numeric(surface.heights * 1e6), step_mm=surface.spacing * 1e3)


@needs_data
def test_a_lateral_unit_slip_on_a_steep_scan_names_the_lateral_unit():
    path = DATA / "nanovea_st400" / "test3.txt"  # x, y in mm, read as um: slopes 1000 x steeper
    message = one_line_error(read_surface, path=path, lateral_unit="um")
    assert re.search(r"RMS slope \S+ > 1 .*x-y in um.*--lateral-unit", message)
    assert "--height-unit" in message  # too steep: heights too large is as likely


def test_a_lateral_unit_slip_on_a_flat_scan_names_the_lateral_unit(tmp_path):
    path = write_xyz_of(tmp_path / "g1.txt", windows(builtin_surface("G1"), 16)[0])
    message = one_line_error(read_surface, path=path, lateral_unit="m", height_unit="um")
    assert re.search(rf"RMS slope \S+ < {MIN_RMS_SLOPE:g} .*x-y in m .*--lateral-unit", message)
    assert "--height-unit" not in message  # the user gave the heights' unit
    message = one_line_error(read_surface, path=path, lateral_unit="m")
    assert "--lateral-unit" in message and "--height-unit" in message


@pytest.mark.parametrize("name", builtin_names())
def test_builtin_surfaces_written_to_files_pass_the_unit_checks(name, tmp_path):
    surface = builtin_surface(name)
    path = tmp_path / f"{name}.npy"
    np.save(path, surface.heights)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read = read_surface(path, size=surface.scan_length, height_unit="m")  # 63M: slope 1.2
    assert read.rms_slope == pytest.approx(surface.rms_slope, rel=0.05)


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
@pytest.mark.parametrize("name", sorted(name for name, options in INSTRUMENT_OPTIONS.items()
                                        if len(options) > 1))
def test_instrument_file_without_options_names_every_one_it_needs_at_once(name):
    message = one_line_error(read_surface, path=DATA / "instruments" / name)
    for option in INSTRUMENT_OPTIONS[name]:
        assert OPTION_HINTS[option] in message
    assert f"{len(INSTRUMENT_OPTIONS[name])} problems" in message


def test_missing_points_outside_the_crop_are_not_a_problem(tmp_path):
    z = np.random.default_rng(4).normal(0.0, 0.1e-6, (6, 9))
    z[0, 0] = np.nan  # in the columns the crop drops
    path = tmp_path / "z.npy"
    np.save(path, z)
    message = one_line_error(read_surface, path=path, size="5um")
    assert "--crop" in message and "fill" not in message
    cropped = read_surface(path, size="5um", square="crop", detrend=False)
    np.testing.assert_array_equal(cropped.heights, crop_square(z))


@needs_data
def test_crop_says_how_much_of_the_grid_it_dropped():
    path = DATA / "instruments" / "x3p-2.x3p"
    resampled, _ = square_pixels(*read_heights(path))
    kept = min(resampled.shape) ** 2 / resampled.size
    with pytest.warns(UserWarning) as notes:
        read_surface(path, pixels="resample", square="crop")
    crop_notes = [str(note.message) for note in notes if "--crop" in str(note.message)]
    assert len(crop_notes) == 1
    shape = f"{resampled.shape[0]} x {resampled.shape[1]}"
    assert f"of {shape} points" in crop_notes[0]
    assert f"dropped {1 - kept:.0%}" in crop_notes[0]


@pytest.mark.parametrize("method", ["nearest", "plane"])
def test_fill_says_how_many_heights_it_filled(tmp_path, method):
    z = np.random.default_rng(5).normal(0.0, 0.1e-6, (8, 8))
    z[[1, 4, 6], [2, 2, 7]] = np.nan
    path = tmp_path / "holes.npy"
    np.save(path, z)
    with pytest.warns(UserWarning, match=rf"--fill={method} filled the missing heights: 3 of 64 "):
        read_surface(path, size="7um", fill=method)


def test_a_complete_square_grid_reads_without_notes(tmp_path):
    path = tmp_path / "z.npy"
    np.save(path, np.random.default_rng(6).normal(0.0, 0.1e-6, (8, 8)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_surface(path, size="7um", square="crop", fill="nearest")


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


# --- windows of measured scans ------------------------------------------------------------------


@needs_data
def test_a_measured_window_is_detrended_and_its_seam_is_measured():
    surface = read_surface(DATA / "instruments" / "al3d-1.al3d", square="crop")
    with pytest.warns(UserWarning, match="periodic seam") as notes:
        window = surface_window(surface, 32, 0, measured=True)
    raw = windows(surface, 32)[0].heights
    np.testing.assert_allclose(window.heights, detrend_plane(raw), rtol=0, atol=1e-15)
    ratio = periodic_seam_ratio(window.heights)
    assert ratio > MAX_SEAM_RATIO and f"{ratio:.2g}" in str(notes[0].message)


def test_builtin_windows_stay_as_cut():
    surface = builtin_surface("G5")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        window = surface_window(surface, 32, 5)
    np.testing.assert_array_equal(window.heights, windows(surface, 32)[5].heights)


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
