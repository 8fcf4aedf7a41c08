"""Tests of geometry.readers as a whole: the options, the registry of readers, the lengths with
units, the shared pipeline (unit slips, square pixels and grids, crop and fill notes) and
``load_surface``; each reader has its own file (tests/test_readers_<module>.py). The helpers
here are shared with those files."""

import dataclasses
import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.generate import builtin_names, builtin_surface
from roughfriction.geometry.readers import (
    FORMATS,
    MAX_RMS_HEIGHT,
    MIN_RMS_HEIGHT,
    MIN_RMS_SLOPE,
    READERS,
    SUFFIXES,
    ReaderOptions,
    load_surface,
    parse_length,
    read_heights,
    read_surface,
    reader_for,
    square_pixels,
)
from roughfriction.geometry.readers.npy import NPY
from roughfriction.geometry.statistics import MAX_SEAM_RATIO, periodic_seam_ratio
from roughfriction.geometry.surface import crop_square, detrend_plane, windows
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


def one_line_error(call, *args):
    """The message of the InputError that ``call(*args)`` raises (it must be one line)."""
    with pytest.raises(InputError) as error:
        call(*args)
    message = str(error.value)
    assert "\n" not in message
    return message


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


def npy_size(name, unit="um"):
    """Scan length of an instrument .npy sample along x: its number of um, followed by ``unit``
    (another unit makes a unit slip)."""
    meta = sample_json(f"instruments/{name}.npy")
    return f"{(meta['nb_grid_pts'][0] - 1) * meta['pixel_size_m'][0] / 1e-6:.6g}{unit}"


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


# --- ReaderOptions ------------------------------------------------------------------------------


def test_general_reader_errors(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_surface(tmp_path / "absent.npy")
    path = tmp_path / "z.npy"
    np.save(path, np.zeros((4, 4)))
    message = one_line_error(read_surface, path, ReaderOptions(fmt="tiff"))
    assert message == "unknown format 'tiff'; known: npy, text, matrix, xyz, instrument"
    with pytest.raises(InputError, match="square option"):
        ReaderOptions(size="3um", square="pad")
    with pytest.raises(InputError, match="unknown fill method"):
        ReaderOptions(size="3um", fill="spline")
    with pytest.raises(InputError, match="unknown pixels option"):
        ReaderOptions(size="3um", pixels="nearest")


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"size": -1.0}, "scan size must be > 0, got -1.0"),
        ({"size": "25"}, "length '25' has no unit; add one, e.g. 25um or 25mm"),
        ({"height_unit": "furlong"}, "unknown length unit 'furlong'"),
        ({"lateral_unit": "inch"}, "unknown length unit 'inch'"),
        ({"fill": "spline"}, "unknown fill method 'spline': use 'nearest' or 'plane'"),
    ],
)
def test_reader_options_are_checked_when_made(values, message):
    with pytest.raises(InputError) as error:
        ReaderOptions(**values)
    assert str(error.value).startswith(message) and "\n" not in str(error.value)


def test_reader_options_are_frozen_and_default_to_the_st400_marker():
    options = ReaderOptions()
    assert (options.missing_height, options.detrend, options.fmt) == (-1.0, True, None)
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.size = "1um"


# --- the registry -------------------------------------------------------------------------------


def test_every_registered_suffix_has_one_reader():
    claimed = [suffix for reader in READERS for suffix in reader.suffixes]
    assert len(claimed) == len(set(claimed)) == len(SUFFIXES)  # no suffix claimed twice
    assert all(re.fullmatch(r"\.[a-z0-9]+", suffix) for suffix in claimed)
    for reader in READERS:
        for suffix in reader.suffixes:
            assert reader_for(Path(f"scan{suffix.upper()}")) is reader  # case-insensitive
    assert {".npy", ".txt", ".x3p", ".sur", ".opd", ".al3d", ".di"} <= set(SUFFIXES)


def test_every_reader_is_a_format_the_options_accept():
    assert FORMATS == tuple(reader.name for reader in READERS)
    assert len(set(FORMATS)) == len(FORMATS)
    for reader in READERS:
        assert reader_for(Path("any.npy"), ReaderOptions(fmt=reader.name).fmt) is reader


@pytest.mark.parametrize("name", ["scan.foo", "scan"])
def test_an_unknown_suffix_is_refused_with_the_known_ones(tmp_path, name):
    path = tmp_path / name
    np.save(tmp_path / "z.npy", asymmetric_field())
    path.write_bytes((tmp_path / "z.npy").read_bytes())
    message = one_line_error(read_surface, path, ReaderOptions(size="25um"))
    what = "suffix '.foo'" if path.suffix else "no suffix"
    assert message.startswith(f"{name}: no reader for files with {what}; known suffixes: ")
    assert message.endswith(", ".join(sorted(SUFFIXES)))
    forced = read_surface(path, ReaderOptions(size="25um", height_unit="um", fmt="npy"))
    assert reader_for(path, "npy") is NPY and forced.n == 6  # a format given reads it anyway


# --- unit slips: implausible RMS heights and slopes ---------------------------------------------


def test_heights_in_a_wrong_unit_are_refused_by_their_rms_slope(tmp_path):
    path = tmp_path / "microns.npy"
    np.save(path, asymmetric_field())  # um, read as metres: RMS slope ~ 1e5
    with pytest.raises(InputError, match=r"RMS slope \S+ > 1 .*--height-unit.*--size"):
        read_surface(path, ReaderOptions(size="25um"))
    assert read_surface(path, ReaderOptions(size="25um", height_unit="um")).n == 6
    steep = tmp_path / "steep.npy"
    np.save(steep, asymmetric_field() * 1e-4)  # metres: RMS height < 1 mm, slope > 1
    with pytest.raises(InputError, match=r"RMS slope \S+ > 1 "):
        read_surface(steep, ReaderOptions(size="25um"))
    assert read_surface(steep, ReaderOptions(size="25um", height_unit="m")).n == 6  # as told


@needs_data
def test_heights_in_a_too_small_unit_are_refused_by_their_rms_height():
    path = DATA / "instruments" / "di-3.npy"  # heights in metres, read as nm
    message = one_line_error(read_surface, path,
                             ReaderOptions(size=npy_size("di-3"), height_unit="nm"))
    assert re.search(rf"RMS height \S+ m < {MIN_RMS_HEIGHT:g} m .*nm.*--height-unit", message)


@needs_data
def test_heights_in_a_too_large_unit_are_refused_by_their_rms_height():
    path = DATA / "nanovea_st400" / "test1.txt"  # heights in um, read as mm
    message = one_line_error(read_surface, path, ReaderOptions(height_unit="mm"))
    assert re.search(rf"RMS height \S+ m > {MAX_RMS_HEIGHT:g} m .*mm.*--height-unit", message)


@needs_data
def test_a_scan_size_in_a_wrong_unit_is_refused_by_its_flat_rms_slope():
    path = DATA / "instruments" / "al3d-1.npy"
    size = npy_size("al3d-1", "mm")  # the length in um, written as mm
    message = one_line_error(read_surface, path, ReaderOptions(size=size, square="crop"))
    assert re.search(rf"RMS slope \S+ < {MIN_RMS_SLOPE:g} .*--size {size}.*--height-unit", message)
    assert "--allow-flat" in message
    right = read_surface(path, ReaderOptions(size=npy_size("al3d-1"), square="crop"))
    flat = read_surface(path, ReaderOptions(size=size, square="crop", allow_flat=True))
    assert flat.rms_slope == pytest.approx(right.rms_slope / 1000, rel=1e-2)


@needs_data
def test_a_flat_slope_with_the_height_unit_given_names_the_lateral_flag_only():
    path = DATA / "instruments" / "al3d-1.npy"
    options = ReaderOptions(size=npy_size("al3d-1", "mm"), height_unit="m", square="crop")
    message = one_line_error(read_surface, path, options)
    assert "--size" in message and "--height-unit" not in message


def write_xyz_of(path, surface):
    """``surface`` as an ST400-style x-y-z list (x, y in mm, z in um)."""
    return write_xyz(path, numeric(surface.heights * 1e6), step_mm=surface.spacing * 1e3)


@needs_data
def test_a_lateral_unit_slip_on_a_steep_scan_names_the_lateral_unit():
    path = DATA / "nanovea_st400" / "test3.txt"  # x, y in mm, read as um: slopes 1000 x steeper
    message = one_line_error(read_surface, path, ReaderOptions(lateral_unit="um"))
    assert re.search(r"RMS slope \S+ > 1 .*x-y in um.*--lateral-unit", message)
    assert "--height-unit" in message  # too steep: heights too large is as likely


def test_a_lateral_unit_slip_on_a_flat_scan_names_the_lateral_unit(tmp_path):
    path = write_xyz_of(tmp_path / "g1.txt", windows(builtin_surface("G1"), 16)[0])
    message = one_line_error(read_surface, path,
                             ReaderOptions(lateral_unit="m", height_unit="um"))
    assert re.search(rf"RMS slope \S+ < {MIN_RMS_SLOPE:g} .*x-y in m .*--lateral-unit", message)
    assert "--height-unit" not in message  # the user gave the heights' unit
    message = one_line_error(read_surface, path, ReaderOptions(lateral_unit="m"))
    assert "--lateral-unit" in message and "--height-unit" in message


@pytest.mark.parametrize("name", builtin_names())
def test_builtin_surfaces_written_to_files_pass_the_unit_checks(name, tmp_path):
    surface = builtin_surface(name)
    path = tmp_path / f"{name}.npy"
    np.save(path, surface.heights)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read = read_surface(path, ReaderOptions(size=surface.scan_length,
                                                height_unit="m"))  # 63M: slope 1.2
    assert read.rms_slope == pytest.approx(surface.rms_slope, rel=0.05)


# --- square grids, missing points, and the notes of crop and fill -------------------------------


def test_missing_points_outside_the_crop_are_not_a_problem(tmp_path):
    z = np.random.default_rng(4).normal(0.0, 0.1e-6, (6, 9))
    z[0, 0] = np.nan  # in the columns the crop drops
    path = tmp_path / "z.npy"
    np.save(path, z)
    message = one_line_error(read_surface, path, ReaderOptions(size="5um"))
    assert "--crop" in message and "fill" not in message
    cropped = read_surface(path, ReaderOptions(size="5um", square="crop", detrend=False))
    np.testing.assert_array_equal(cropped.heights, crop_square(z))


@needs_data
def test_crop_says_how_much_of_the_grid_it_dropped():
    path = DATA / "instruments" / "x3p-2.x3p"
    resampled, _ = square_pixels(*read_heights(path))
    kept = min(resampled.shape) ** 2 / resampled.size
    with pytest.warns(UserWarning) as notes:
        read_surface(path, ReaderOptions(pixels="resample", square="crop"))
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
        read_surface(path, ReaderOptions(size="7um", fill=method))


def test_a_complete_square_grid_reads_without_notes(tmp_path):
    path = tmp_path / "z.npy"
    np.save(path, np.random.default_rng(6).normal(0.0, 0.1e-6, (8, 8)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_surface(path, ReaderOptions(size="7um", square="crop", fill="nearest"))


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


# --- windows of measured scans ------------------------------------------------------------------


@needs_data
def test_a_measured_window_is_detrended_and_its_seam_is_measured():
    surface = read_surface(DATA / "instruments" / "al3d-1.al3d", ReaderOptions(square="crop"))
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
    assert load_surface("G5", ReaderOptions()).name == "G5"
    with pytest.raises(InputError, match=r"\(size\) apply to files"):
        load_surface("G5", size="127um")
    with pytest.raises(InputError, match=r"\(allow_flat, fill\) apply to files, not to built-in"):
        load_surface("G5", ReaderOptions(fill="plane", allow_flat=True))


def test_load_surface_reads_files_and_lists_names_when_unknown(tmp_path):
    path = tmp_path / "mine.npy"
    np.save(path, asymmetric_field())
    assert load_surface(str(path), size="25um", height_unit="um").name == "mine"
    with pytest.raises(InputError, match="neither a file nor a built-in.*G1.*63M"):
        load_surface(str(tmp_path / "missing.npy"))


def test_load_surface_keywords_replace_fields_of_the_options(tmp_path):
    path = tmp_path / "mine.npy"
    np.save(path, asymmetric_field())
    options = ReaderOptions(size="25um", height_unit="um", detrend=False)
    kept = load_surface(str(path), options)
    np.testing.assert_allclose(kept.heights, asymmetric_field() * 1e-6, rtol=1e-12)
    scaled = load_surface(str(path), options, height_unit="nm")  # only the unit replaced
    np.testing.assert_allclose(scaled.heights, asymmetric_field() * 1e-9, rtol=1e-12)
    with pytest.raises(TypeError, match="unexpected keyword"):
        load_surface(str(path), options, pixel="resample")
