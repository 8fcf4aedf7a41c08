"""Tests of geometry.readers.npy: NumPy height arrays (synthetic and the shipped conversions of
the instrument samples in data/surfaces/instruments)."""

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.readers import ReaderOptions, read_surface
from roughfriction.geometry.statistics import rms_height

from tests.test_readers import (
    DATA,
    asymmetric_field,
    needs_data,
    one_line_error,
    sample_json,
    sq_after_detrend,
)


@needs_data
@pytest.mark.parametrize("name", ["di-3", "matrix-2"])
def test_instrument_npy_samples_match_their_sq(name):
    meta = sample_json(f"instruments/{name}.npy")
    n = meta["nb_grid_pts"][0]
    size = (n - 1) * meta["pixel_size_m"][0]
    surface = read_surface(DATA / "instruments" / f"{name}.npy", ReaderOptions(size=size))
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
        read_surface(path, ReaderOptions(size="125.7um"))
    with pytest.raises(InputError, match="missing.*fill="):
        read_surface(path, ReaderOptions(size="125.7um", square="crop"))
    surface = read_surface(path, ReaderOptions(size="125.7um", square="crop", fill="nearest"))
    assert surface.n == 480 and surface.spacing == pytest.approx(125.7e-6 / 639)


def test_npy_needs_size_and_takes_height_unit(tmp_path):
    path = tmp_path / "z.npy"
    np.save(path, asymmetric_field())
    with pytest.raises(InputError, match="--size"):
        read_surface(path)
    surface = read_surface(path, ReaderOptions(size="0.025mm", height_unit="um", detrend=False))
    assert surface.spacing == pytest.approx(5e-6)
    np.testing.assert_allclose(surface.heights, asymmetric_field() * 1e-6, rtol=1e-12)
    with pytest.raises(InputError, match="lateral-unit"):
        read_surface(path, ReaderOptions(size="25um", lateral_unit="mm"))
    with pytest.raises(InputError, match="> 0"):
        read_surface(path, ReaderOptions(size=-1.0))


def test_npy_refuses_one_dimensional_data(tmp_path):
    path = tmp_path / "profile.npy"
    np.save(path, np.arange(10.0))
    with pytest.raises(InputError, match="2-D"):
        read_surface(path, ReaderOptions(size="9um"))


def test_npy_refuses_a_pickled_or_broken_file(tmp_path):
    pickled = tmp_path / "objects.npy"
    np.save(pickled, np.array([{"z": 1.0}], dtype=object), allow_pickle=True)
    message = one_line_error(read_surface, pickled, ReaderOptions(size="9um"))
    assert message.startswith("objects.npy: not a plain NumPy array file (")
    broken = tmp_path / "broken.npy"
    broken.write_bytes(b"not an array")
    message = one_line_error(read_surface, broken, ReaderOptions(size="9um"))
    assert message.startswith("broken.npy: not a plain NumPy array file (")


def test_npy_refuses_a_grid_smaller_than_four_points(tmp_path):
    path = tmp_path / "tiny.npy"
    np.save(path, np.zeros((3, 8)))
    message = one_line_error(read_surface, path, ReaderOptions(size="2um"))
    assert message == ("tiny.npy: a 3 x 8 grid is too small for a height map (at least 4 x 4 "
                       "points)")
