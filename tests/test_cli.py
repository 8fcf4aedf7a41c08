"""The CLI contract: JSON keys, units, and one-line errors with a non-zero exit."""

import json
import subprocess
import sys

import numpy as np
import pytest
from roughfriction.geometry.generate import builtin_surface
from roughfriction.material import Material
from roughfriction.scripts.cli import EXIT_INPUT_ERROR, main

STATS_KEYS = {"rq", "m0", "m2", "m4", "alpha", "sigma_s", "R", "psi"}
THEORY_KEYS = {"psi", "mu_s", "Ft_max", "area_ratio_normal", "area_ratio_sliding", "mu_cke",
               "mu_let", "cke_valid", "let_valid", "converged"}


def run_json(capsys, *argv):
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_surface_stats_json_keys_and_values(capsys):
    record = run_json(capsys, "surface", "stats", "G5")
    assert STATS_KEYS <= record.keys()
    assert record["rq"] == pytest.approx(0.1e-6, rel=0.02)  # Table 1, SI units
    assert record["psi"] == pytest.approx(13.20, rel=0.02)


def test_multiscale_json_keys(capsys):
    record = run_json(capsys, "multiscale", "G5", "--load", "0.155")
    assert THEORY_KEYS <= record.keys()
    assert record["converged"] is True
    assert 0 < record["area_ratio_normal"] <= record["area_ratio_sliding"] <= 1
    normal_load = 0.155 * Material().Sy * builtin_surface("G5").scan_length ** 2
    assert record["mu_s"] == pytest.approx(record["Ft_max"] / normal_load)
    assert record["cke_valid"] is False  # psi = 13.2 > 8
    assert record["let_valid"] is True


def test_npy_file_with_size(tmp_path, capsys):
    z = np.random.default_rng(1).normal(0.0, 0.1e-6, (64, 64))
    path = tmp_path / "rough.npy"
    np.save(path, z)
    record = run_json(capsys, "surface", "stats", str(path), "--size", "63um")
    assert record["n"] == 64
    assert record["spacing"] == pytest.approx(1e-6)


def write_npy(tmp_path, array):
    path = tmp_path / "bad.npy"
    np.save(path, array)
    return [str(path), "--size", "63um"]


BAD_INPUTS = {
    "nan heights": lambda p: ["surface", "stats",
                              *write_npy(p, np.where(np.eye(16) > 0, np.nan, 1e-7))],
    "non-square": lambda p: ["surface", "stats", *write_npy(p, np.ones((16, 20)) * 1e-7)],
    "1-D": lambda p: ["surface", "stats", *write_npy(p, np.ones(16) * 1e-7)],
    "zero roughness": lambda p: ["multiscale", *write_npy(p, np.zeros((16, 16))),
                                 "--load", "0.1"],
    "unknown name": lambda p: ["surface", "stats", "G10"],
    "missing file": lambda p: ["surface", "stats", str(p / "nope.npy"), "--size", "1um"],
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_input_is_one_line_and_nonzero(case, tmp_path, capsys):
    assert main(BAD_INPUTS[case](tmp_path)) == EXIT_INPUT_ERROR
    err = capsys.readouterr().err.strip()
    assert err.startswith("roughfriction: error:")
    assert "\n" not in err and "Traceback" not in err


@pytest.mark.parametrize("load", ["-0.1", "0", "nan"])
def test_bad_load_is_refused(load, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["multiscale", "G5", "--load", load])
    assert exit_info.value.code != 0
    assert "must be a finite number > 0" in capsys.readouterr().err


def test_console_script_exit_code_without_traceback():
    done = subprocess.run(
        [sys.executable, "-m", "roughfriction.scripts.cli", "multiscale", "G10", "--load", "0.1"],
        capture_output=True, text=True, check=False,
    )
    assert done.returncode == EXIT_INPUT_ERROR
    assert "Traceback" not in done.stderr
    assert done.stderr.count("\n") == 1


def test_theory_commands_import_no_fem_stack():
    """multiscale/ and the surface half of geometry/ work without dolfinx, gmsh or MPI."""
    code = (
        "import sys; from roughfriction.scripts.cli import main; "
        "main(['multiscale', 'G1', '--load', '0.1']); "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in "
        "('dolfinx', 'gmsh', 'petsc4py', 'mpi4py', 'ufl')))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip().splitlines()[-1] == "[]"
