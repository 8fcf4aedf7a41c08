"""Tests of geometry.readers.instrument: the instrument samples in data/surfaces/instruments
(x3p, sur, opd, al3d, di) read through SurfaceTopography, against their json and npy
conversions."""

import sys

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.readers import (
    SUFFIXES,
    ReaderOptions,
    load_surface,
    read_heights,
    read_surface,
    square_pixels,
)
from roughfriction.geometry.readers.instrument import INSTRUMENT, INSTRUMENT_SUFFIXES
from roughfriction.geometry.statistics import rms_height
from roughfriction.scripts.cli import build_parser, surface_from_args

from tests.test_readers import DATA, needs_data, one_line_error, sample_json, sq_after_detrend


def test_instrument_format_without_the_extra_names_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "SurfaceTopography", None)  # makes the import fail
    path = tmp_path / "scan.x3p"
    path.write_bytes(b"PK")
    with pytest.raises(InputError, match=r"pip install 'roughfriction\[instruments\]'"):
        read_surface(path)


def test_the_instrument_suffixes_cover_those_surface_topography_reads():
    st_io = pytest.importorskip("SurfaceTopography.IO")
    theirs = {f".{extension.lower()}" for reader in st_io.readers
              for extension in (reader._file_extensions or [])}
    others = {suffix for suffix, reader in SUFFIXES.items() if reader is not INSTRUMENT}
    assert theirs - others <= set(INSTRUMENT_SUFFIXES)
    assert set(INSTRUMENT_SUFFIXES) - theirs == {".di"}  # the shipped sample's suffix
    assert not set(INSTRUMENT_SUFFIXES) & others


def test_an_unreadable_instrument_file_says_why_on_one_line(tmp_path):
    path = tmp_path / "scan.x3p"
    path.write_bytes(b"PK\nnot a zip archive\n")
    message = one_line_error(read_surface, path)
    assert message.startswith("scan.x3p: SurfaceTopography cannot read it (")


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"size": "25um"}, "di-3.di: instrument files carry their own lateral size; drop --size"),
        ({"lateral_unit": "mm"}, "di-3.di: --lateral-unit applies to x-y-z point lists only"),
        ({"height_unit": "um"}, "di-3.di: instrument files carry their own height unit"),
    ],
)
def test_an_instrument_file_refuses_the_units_it_carries(values, message):
    error = one_line_error(read_surface, DATA / "instruments" / "di-3.di", ReaderOptions(**values))
    assert error.startswith(message)


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
    options = ReaderOptions(**INSTRUMENT_OPTIONS[name])
    surface = load_surface(str(DATA / "instruments" / name), options)
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
        read_surface(DATA / "instruments" / name, ReaderOptions(**options))


@needs_data
@pytest.mark.parametrize("name", sorted(name for name, options in INSTRUMENT_OPTIONS.items()
                                        if len(options) > 1))
def test_instrument_file_without_options_names_every_one_it_needs_at_once(name):
    message = one_line_error(read_surface, DATA / "instruments" / name)
    for option in INSTRUMENT_OPTIONS[name]:
        assert OPTION_HINTS[option] in message
    assert f"{len(INSTRUMENT_OPTIONS[name])} problems" in message


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


@needs_data
def test_cli_resample_pixels_flag_reaches_the_reader():
    args = build_parser().parse_args(
        ["surface", "stats", str(DATA / "instruments" / "x3p-2.x3p"), "--resample-pixels", "--crop"]
    )
    surface = surface_from_args(args)
    assert surface.n == 650 and surface.spacing == pytest.approx(1.27656509837346e-07, rel=1e-12)
