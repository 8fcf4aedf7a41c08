"""Tests of scripts.surface_args: the reader flags of the command line reach the reader."""

import numpy as np
import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.generate import builtin_surface
from roughfriction.scripts.cli import build_parser
from roughfriction.scripts.surface_args import surface_from_args


def stats_args(*argv):
    return build_parser().parse_args(["surface", "stats", *argv])


def flat_file(tmp_path):
    """A G1 window (RMS slope 0.02) saved with its heights in metres, 16 points."""
    path = tmp_path / "g1.npy"
    np.save(path, builtin_surface("G1").heights[:16, :16])
    return path


def test_allow_flat_reaches_the_reader(tmp_path):
    args = stats_args(str(flat_file(tmp_path)), "--size", "15mm")  # 15 um written as mm
    with pytest.raises(InputError, match="--allow-flat"):
        surface_from_args(args)
    args.allow_flat = True  # what --allow-flat sets
    assert surface_from_args(args).spacing == pytest.approx(1e-3)


def test_allow_flat_with_a_builtin_surface_is_refused_by_its_flag():
    args = stats_args("G5")
    args.allow_flat = True
    with pytest.raises(InputError, match="--allow-flat apply to surface files"):
        surface_from_args(args)
