"""Tests of multiscale.theory: the guards it shares with the FEM case."""

import pytest
from roughfriction.errors import InputError
from roughfriction.geometry.generate import builtin_surface
from roughfriction.geometry.surface import Surface
from roughfriction.material import Material
from roughfriction.multiscale.theory import evaluate_theory
from roughfriction.scripts.cli import EXIT_INPUT_ERROR, main


def test_an_implausible_load_is_refused():
    with pytest.raises(InputError, match=r"normal load F\* = 1e\+09 > 100"):
        evaluate_theory(builtin_surface("G5"), 1e9, Material())


def test_the_multiscale_command_exits_2_on_an_implausible_load(capsys):
    assert main(["multiscale", "G5", "--load", "1e9"]) == EXIT_INPUT_ERROR
    err = capsys.readouterr().err.strip()
    assert "F* = 1e+09 > 100" in err and "\n" not in err


def test_heights_in_micrometres_taken_as_metres_are_refused():
    surface = builtin_surface("G5")
    with pytest.raises(InputError, match="RMS slope"):
        evaluate_theory(Surface(surface.heights * 1e6, surface.spacing, "um"), 0.155, Material())


def test_a_plausible_case_still_evaluates():
    result = evaluate_theory(builtin_surface("G5"), 0.155, Material())
    assert result.converged and 0 < result.mu_s < 1
