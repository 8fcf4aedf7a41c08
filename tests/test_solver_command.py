"""The ``fem`` command: JSON keys, HDF5 contents, case files, bad inputs, output files."""

import json
import signal
import subprocess
import sys
from pathlib import Path

import dolfinx  # noqa: E402, F401  (an install without the FEM fails here)
import h5py  # noqa: E402
import numpy as np
import pytest
from commands import command_environment, wait_for_line
from roughfriction.case import Loading, SolverOptions  # noqa: E402
from roughfriction.errors import InputError  # noqa: E402
from roughfriction.geometry.generate import builtin_surface  # noqa: E402
from roughfriction.geometry.statistics import surface_statistics
from roughfriction.geometry.surface import surface_on_fem_grid
from roughfriction.material import Material
from roughfriction.scripts.cli import main as cli_main
from roughfriction.scripts.fem import default_output  # noqa: E402
from roughfriction.solver.results import count_patches  # noqa: E402
from roughfriction.studies.certificate import LADDER_FACTOR, certify
from roughfriction.studies.fem_request import unresolved_warning  # noqa: E402

JSON_KEYS = {"mu_s", "Ft_max", "Fn", "area_ratio_normal", "area_ratio_sliding",
             "junction_growth", "contact_nodes", "contact_patches", "cells_per_patch", "reliable",
             "steps", "newton_iterations", "wall_s", "converged", "ranks"}


def main(argv):
    """``roughfriction fem ARGV``."""
    return cli_main(["fem", *argv])


@pytest.fixture
def rough_file(tmp_path):
    path = tmp_path / "rough.npy"
    np.save(path, np.random.default_rng(3).normal(0.0, 0.1e-6, (8, 8)))
    return path


@pytest.mark.fem
def test_normal_only_json_and_hdf5(rough_file, tmp_path, capsys):
    output, fields = tmp_path / "run.h5", tmp_path / "fields"
    code = main([str(rough_file), "--size", "7um", "--load", "0.3", "--normal-only", "--json",
                 "--output", str(output), "--elastic", "--xdmf", str(fields)])
    assert code == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert JSON_KEYS <= summary.keys()
    assert summary["mu_s"] is None and summary["converged"] is True
    assert ("warning: the contact patches" in captured.err) == (summary["reliable"] is False)
    assert summary["Fn"] == pytest.approx(0.3 * 1e9 * (8e-6) ** 2, rel=1e-6)
    assert 0 < summary["area_ratio_normal"] < 1
    with h5py.File(output) as h5:
        assert json.loads(h5.attrs["summary"]) == summary
        inputs = json.loads(h5.attrs["inputs"])
        assert inputs["loading"]["load_star"] == 0.3 and inputs["solver"]["elastic"] is True
        assert "dolfinx" in json.loads(h5.attrs["versions"])
        assert len(h5["steps/normal_force"]) == summary["steps"]
        assert h5["maps/contact_normal"].shape == (8, 8)
    xdmf = (fields / "fields.xdmf").read_text()
    for name in ("displacement", "von_mises", "equivalent_plastic_strain", "contact_pressure",
                 "shear_traction_x", "contact_state"):
        assert f'Name="{name}"' in xdmf


@pytest.mark.fem
def test_case_file_and_unconverged_run(rough_file, tmp_path, capsys):
    config = tmp_path / "case.toml"
    config.write_text("load = 0.3\n[solver]\nmax_steps = 2\n")
    output = tmp_path / "partial.h5"
    code = main([str(rough_file), "--size", "7um", "--config", str(config), "--output",
                 str(output)])
    assert code == 3  # not converged: its own exit status, apart from input errors (2)
    assert "did not converge" in capsys.readouterr().err
    with h5py.File(output) as h5:  # partial results kept, labelled unconverged
        assert not h5.attrs["converged"]
        assert json.loads(h5.attrs["summary"])["mu_s"] is None


@pytest.mark.parametrize("argv, message", [
    (["--load", "-1"], "load"),
    ([], "normal load is required"),
    (["--load", "0.3", "--n", "100000"], "GB are available"),  # refused before allocating
    (["--load", "0.3", "--max-time", "5"], "--max-time limits --tol: give a tolerance"),
    (["--load", "0.3", "--refine", "--tol", "0.1"], "give --tol (with its limits) or --refine"),
])
def test_bad_command_lines(rough_file, argv, message, capsys):
    assert main([str(rough_file), "--size", "7um", *argv]) != 0
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("argv, message", [
    (["--n", "2"], "surface cells per side must be >= 4"),
    (["--tol", "1.5"], "a relative error below 1"),
    (["--tol", "0.1", "--max-level", "0"], "an estimate needs two levels"),
    (["--tol", "0.1", "--max-memory", "-2"], "must be a finite number > 0"),
])
def test_bad_tolerances_and_limits_are_command_line_errors(rough_file, argv, message, capsys):
    with pytest.raises(SystemExit) as stop:
        main([str(rough_file), "--size", "7um", "--load", "0.3", *argv])
    assert stop.value.code == 2 and message in capsys.readouterr().err


def test_unknown_case_file_keys(rough_file, tmp_path, capsys):
    config = tmp_path / "case.toml"
    config.write_text("load = 0.3\n[solver]\npenalti = 3\n")
    assert main([str(rough_file), "--size", "7um", "--config", str(config)]) != 0
    assert "solver.penalti" in capsys.readouterr().err


@pytest.mark.parametrize("options", [{"integration": "reduced"}, {"linear_solver": "lu"},
                                     {"penalty": 0.0}, {"max_iterations": 0},
                                     {"friction_ramp": -0.01}, {"friction_ramp": 1.0},
                                     {"tangential_penalty": 0.0},
                                     {"tangential_penalty": float("nan")},
                                     {"max_preload_increment": 0.0},
                                     {"max_preload_increment": 1.5},
                                     {"max_slide_increment": 0.0}])
def test_bad_solver_options(options):
    with pytest.raises(InputError):
        SolverOptions(**options)


def test_bad_loads():
    for load in (0.0, -0.1, float("nan")):
        with pytest.raises(InputError):
            Loading(load)


def test_an_implausible_load_is_refused_before_re_gridding(monkeypatch, capsys):
    from roughfriction.studies import fem_input

    monkeypatch.setattr(fem_input, "surface_as_meshed",
                        lambda *args: pytest.fail("re-gridded first"))
    assert main(["G5", "--load", "1e9", "--n", "16"]) == 2
    assert "F*" in capsys.readouterr().err


def test_fem_grid_coarsens_keeps_and_refines():
    surface = builtin_surface("G5")
    assert surface_on_fem_grid(surface, None) is surface
    coarse = surface_on_fem_grid(surface, 32)
    assert coarse.n == 32 and coarse.scan_length == pytest.approx(surface.scan_length)
    fine = surface_on_fem_grid(surface, 256)
    assert fine.n == 256 and fine.period == pytest.approx(surface.period)


def test_patches_join_across_the_periodic_boundary():
    grid = np.zeros((6, 6), bool)
    grid[0, 2] = grid[5, 2] = True  # neighbours through x = L <-> 0
    grid[3, 0] = grid[3, 5] = True  # neighbours through y = L <-> 0
    grid[2, 3] = True  # isolated
    grid[4, 4] = True  # diagonal to nothing: isolated
    assert count_patches(grid) == 4
    assert count_patches(np.ones((5, 5), bool)) == 1
    assert count_patches(np.zeros((5, 5), bool)) == 0


@pytest.mark.fem
def test_refine_reports_the_finer_mesh_with_an_error_estimate(tmp_path, capsys):
    output = tmp_path / "run.h5"
    code = main(["G5", "--n", "8", "--load", "0.155", "--refine", "--ladder", "uniform", "--json",
                 "--output", str(output)])
    assert code == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert summary["converged"]
    # certified: the patches' resolution is in the certificate, not in a warning
    assert "warning: the contact patches" not in captured.err
    assert not any(line.startswith("the contact patches") for line in summary["warnings"])
    certificate = certify((summary["mu_s_coarse"], summary["mu_s"]), summary["contact_nodes"],
                          summary["boundary_nodes"])
    assert summary["mu_s_error"] == pytest.approx(certificate.error)
    assert summary["error_ladder_term"] == pytest.approx(
        LADDER_FACTOR * abs(summary["mu_s"] - summary["mu_s_coarse"]))
    assert summary["levels"]["contact_nodes"][-1] == summary["contact_nodes"] > 0
    with h5py.File(output) as h5:
        assert json.loads(h5.attrs["summary"]) == summary
        assert json.loads(h5.attrs["inputs"])["surface"]["n"] == 16
    with h5py.File(tmp_path / "run_coarse.h5") as h5:
        assert json.loads(h5.attrs["summary"])["mu_s"] == summary["mu_s_coarse"]


@pytest.mark.fem
def test_a_normal_only_tolerance_applies_to_the_contact_area(rough_file, tmp_path):
    """The ladder's quantity is A_r/A_n (1x and 2x; met or not, the file says)."""
    output = tmp_path / "area.h5"
    code = main([str(rough_file), "--size", "7um", "--load", "0.3", "--elastic", "--normal-only",
                 "--tol", "0.1", "--max-level", "1", "--output", str(output)])
    with h5py.File(output) as h5:
        summary = json.loads(h5.attrs["summary"])
    assert code == (0 if summary["error_tolerance_met"] else 3)
    levels = summary["levels"]
    assert summary["mu_s"] is None and levels["factor"] == [1, 2]
    assert levels["area_ratio_normal"][-1] == summary["area_ratio_normal"]
    assert summary["area_ratio_normal_error"] == pytest.approx(certify(
        levels["area_ratio_normal"], levels["contact_nodes"][-1],
        levels["boundary_nodes"][-1]).error)


@pytest.mark.fem
def test_window_meshes_the_surface_at_its_own_spacing(tmp_path, capsys):
    """G5 (i.i.d., psi 13.2) on 8 x 8 cells: a window keeps its psi, a re-grid is smoother and
    says so on stderr."""
    whole = surface_statistics(builtin_surface("G5"), Material()).psi
    common = ["G5", "--n", "8", "--load", "0.3", "--elastic", "--normal-only", "--json"]
    assert main([*common, "--window", "best", "--output", str(tmp_path / "w.h5")]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["psi_meshed"] == pytest.approx(whole, rel=0.03)
    assert "re-gridded" not in captured.err
    assert main([*common, "--output", str(tmp_path / "r.h5")]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["psi_meshed"] < 0.5 * whole
    assert f"psi {whole:.3g} -> " in captured.err and "--window best" in captured.err


@pytest.mark.parametrize("window, message", [
    (["--window", "0"], "counts from 1"),
    (["--window", "x"], "'best' or a window number"),
    (["--window", "257"], "not 257"),
    (["--n", "128", "--window", "1"], "needs --n below"),
])
def test_bad_windows(window, message, capsys):
    argv = ["G5", "--load", "0.3", *(["--n", "8"] if "--n" not in window else []), *window]
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_unresolved_patches_are_warned_about_in_one_line():
    warning = unresolved_warning({"reliable": False, "cells_per_patch": 0.55})
    assert warning.startswith("the contact patches hold 0.55 grid cells")
    assert "\n" not in warning and "< 4" in warning and "--tol 0.03 refines" in warning
    for summary in ({"reliable": True, "cells_per_patch": 6.0}, {"reliable": None}):
        assert unresolved_warning(summary) is None
    # a certified result (--tol, --refine) states its error: no warning; without a certificate
    # (a single level: NaN) the warning stays
    certified = {"reliable": False, "cells_per_patch": 2.8, "mu_s_error": 0.003}
    assert unresolved_warning(certified) is None
    assert unresolved_warning(certified | {"mu_s_error": float("nan")}).startswith(
        "the contact patches hold 2.8 grid cells")
    assert unresolved_warning({"reliable": False, "cells_per_patch": 2.8,
                               "area_ratio_normal_error": 0.001}) is None


@pytest.mark.parametrize("flags, message", [
    (["--output", "a_file/run.h5"], "a_file is not a directory"),
    (["--xdmf", "a_file/fields"], "a_file is not a directory"),
    (["--output", "/proc/nope.h5"], "cannot write /proc/nope.h5: "),
    (["--output", "missing/dir/x.h5"], "missing/dir does not exist (create it first"),
    (["--output", "res.csv"], "an HDF5 file is written, name it res.h5"),
])
def test_an_unwritable_output_is_refused_before_the_run(flags, message, tmp_path, monkeypatch,
                                                        capsys):
    """An output under a file, in a folder that takes no file, in a missing folder or not
    named .h5: one line and exit 2 before anything is solved, nothing created."""
    from roughfriction.solver import run as solver_run

    monkeypatch.chdir(tmp_path)
    (tmp_path / "a_file").write_text("")
    monkeypatch.setattr(solver_run, "run", lambda *args, **kwargs: pytest.fail("solved"))
    assert main(["G5", "--n", "8", "--window", "1", "--load", "0.3", *flags]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and error[0].startswith("roughfriction: error: ")
    assert message in error[0]
    assert not (tmp_path / "missing").exists()


def test_default_names_tell_apart_what_defines_a_run():
    """A window, a re-gridding, a case-file option and --refine each give another name; the
    same run, the same name."""
    from dataclasses import replace

    from roughfriction.case import FemCase
    from roughfriction.studies.paper import surface_window

    surface = builtin_surface("G5")
    plain = FemCase(surface_on_fem_grid(surface, 8), Loading(0.3))
    variants = [plain, FemCase(surface_window(surface, 8, 0), Loading(0.3)),
                FemCase(surface_window(surface, 8, 1), Loading(0.3)),
                replace(plain, solver=SolverOptions(penalty=20.0))]
    names = [default_output(case) for case in variants]
    names.append(default_output(plain, ("refined",)))
    names.append(default_output(plain, ("tol0.03_L3",)))
    assert len(set(names)) == len(names)
    assert all(name.name.startswith("G5_F0.3_N8_") for name in names)
    same = FemCase(surface_on_fem_grid(builtin_surface("G5"), 8), Loading(0.3))
    assert default_output(same) == names[0]


@pytest.mark.fem
def test_a_re_run_reuses_its_result_and_overwrite_recomputes(tmp_path, monkeypatch, capsys):
    """A re-grid and a window of the same N are two files; running the window again prints
    the stored result (exit 0, the file untouched, no solve); --overwrite recomputes it."""
    from roughfriction.solver import run as solver_run

    monkeypatch.chdir(tmp_path)
    common = ["G5", "--n", "8", "--load", "0.3", "--elastic", "--normal-only", "--json"]
    window = [*common, "--window", "best"]
    assert main(common) == 0
    assert main(window) == 0
    first = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    files = sorted((tmp_path / "results" / "fem").glob("*.h5"))
    assert len(files) == 2
    stamps = {path: path.stat().st_mtime_ns for path in files}
    solve = solver_run.run
    monkeypatch.setattr(solver_run, "run", lambda *args, **kwargs: pytest.fail("solved"))
    assert main(window) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out) == first
    assert captured.err.startswith("reused: results/fem/G5_F0.3_N8_elastic_normal_windowbest_")
    assert {path: path.stat().st_mtime_ns for path in files} == stamps
    monkeypatch.setattr(solver_run, "run", solve)
    assert main([*window, "--overwrite"]) == 0
    assert sorted((tmp_path / "results" / "fem").glob("*.h5")) == files
    assert sum(path.stat().st_mtime_ns != stamps[path] for path in files) == 1


@pytest.mark.fem
def test_a_results_file_of_other_physics_or_another_case_is_named_not_reused(
        tmp_path, monkeypatch, capsys):
    """Another physics version: the file is named stale; another case in a named --output:
    refused; both in one line (exit 2) with the file untouched."""
    from roughfriction.solver import run as solver_run

    monkeypatch.chdir(tmp_path)
    command = ["G5", "--n", "8", "--window", "1", "--load", "0.3", "--elastic",
               "--normal-only", "--output", "run.h5"]
    assert main(command) == 0
    with h5py.File("run.h5", "a") as h5:
        h5.attrs["physics"] = "0123456789abcdef"
    stamp = (tmp_path / "run.h5").stat().st_mtime_ns
    capsys.readouterr()
    monkeypatch.setattr(solver_run, "run", lambda *args, **kwargs: pytest.fail("solved"))
    assert main(command) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1
    assert "run.h5 is stale: computed by other physics (0123456789ab, this code " in error[0]
    assert main([*command[:6], "0.5", *command[7:]]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert error == ["roughfriction: error: run.h5 holds another case: pass --overwrite to "
                     "recompute, or name another --output"]
    assert (tmp_path / "run.h5").stat().st_mtime_ns == stamp


@pytest.mark.fem
def test_a_killed_xdmf_run_leaves_the_previous_fields_as_they_were(tmp_path):
    """The fields are written under a temporary name: a run killed mid-way neither truncates
    the fields files of the run before it nor leaves a half-written one in their place."""
    fields = tmp_path / "fields"
    command = [sys.executable, "-m", "roughfriction.scripts.cli", "fem", "G5", "--n", "8",
               "--load", "0.3", "--xdmf", str(fields), "--output", str(tmp_path / "run.h5"),
               "--overwrite"]
    first = subprocess.run([*command, "--elastic", "--normal-only"], cwd=tmp_path,
                           env=command_environment(), capture_output=True, text=True,
                           timeout=300)
    assert first.returncode == 0, first.stderr
    xdmf = (fields / "fields.xdmf").read_text()
    assert "fields.h5:/" in xdmf and ".fields." not in xdmf  # names its data where it is
    with h5py.File(fields / "fields.h5") as h5:
        assert len(h5["Function/contact_pressure"]) == 1  # the end of the preload
    before = {path.name: path.read_bytes() for path in fields.iterdir()}

    process = subprocess.Popen(command, cwd=tmp_path, env=command_environment(), text=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        wait_for_line(process, "Fn=", 120)  # a load step is done: the run is writing fields
        process.send_signal(signal.SIGKILL)
        assert process.wait(30) == -signal.SIGKILL
    finally:
        if process.poll() is None:
            process.kill()
        process.stderr.close()
    visible = {path.name: path.read_bytes() for path in fields.iterdir()
               if not path.name.startswith(".")}
    assert visible == before


DATA = Path(__file__).resolve().parents[1] / "data" / "surfaces"


def test_a_measured_window_is_detrended_and_its_seam_warned(capsys):
    """al3d-1's 32 x 32 window 1: the FEM closes it periodically across a jump many times its
    neighbour steps; warned, and the window meshed without its plane."""
    from roughfriction.geometry.readers import load_surface
    from roughfriction.studies.api import meshed_surface

    scan = load_surface(str(DATA / "instruments" / "al3d-1.al3d"), square="crop")
    capsys.readouterr()
    with pytest.warns(UserWarning, match="window 1 of al3d-1: .*seam"):
        window = meshed_surface(scan, 32, "1", Material(), measured=True)
    heights = window.heights
    x = np.arange(32.0)[:, None] * np.ones(32)
    assert abs(np.sum((heights - heights.mean()) * x)) < 1e-9 * np.abs(heights).sum() * 32
    as_cut = meshed_surface(scan, 32, "1", Material())
    assert not np.allclose(as_cut.heights - as_cut.heights.mean(), heights)


def test_a_steep_scan_is_warned_about_before_the_small_strain_run(capsys):
    from types import SimpleNamespace

    from roughfriction.geometry.readers import load_surface
    from roughfriction.scripts.fem import case_from_args

    path = str(DATA / "nanovea_st400" / "test3.txt")
    scan = load_surface(path)
    command = SimpleNamespace(surface=path, config=None, load=0.3, n=None, window=None,
                              elastic=None, normal_only=None)
    case_from_args(command, scan)  # the fem command's case, as it builds it before the run
    warning, = [line for line in capsys.readouterr().err.splitlines()
                if line.startswith("warning: ")]
    assert "RMS slope 0.47 > 0.3, beyond the small-strain FEM" in warning
