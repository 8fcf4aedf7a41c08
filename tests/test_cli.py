"""The CLI contract: JSON keys, units, and one-line errors with a non-zero exit."""

import json
import subprocess
import sys

import numpy as np
import pytest
from roughfriction.case import FemCase, Loading
from roughfriction.geometry.generate import builtin_surface
from roughfriction.geometry.surface import Surface, surface_on_fem_grid
from roughfriction.material import Material
from roughfriction.scripts.cli import EXIT_INPUT_ERROR, EXIT_INTERRUPTED, main

STATS_KEYS = {"rq", "m0", "m2", "m4", "alpha", "sigma_s", "R", "psi"}
THEORY_KEYS = {"psi", "mu_s", "Ft_max", "area_ratio_normal", "area_ratio_sliding", "mu_cke",
               "mu_let", "cke_valid", "let_valid", "converged"}


def run_json(capsys, *argv):
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def assert_moments_agree(record, heights):
    """The stats record against the paper's closed forms: R_q of ``heights`` (Eq. 21), m0 =
    R_q^2, alpha = m0 m4 / m2^2 (Eq. 14), R = 0.375 (pi / m4)^(1/2) (Eq. 18)."""
    assert record["rq"] == pytest.approx(np.std(heights), rel=1e-12)
    assert record["m0"] == pytest.approx(record["rq"] ** 2, rel=1e-9)
    assert record["alpha"] == pytest.approx(record["m0"] * record["m4"] / record["m2"] ** 2,
                                            rel=1e-12)
    assert record["R"] == pytest.approx(0.375 * np.sqrt(np.pi / record["m4"]), rel=1e-12)


def test_surface_stats_json_keys_and_values(capsys):
    record = run_json(capsys, "surface", "stats", "G5")
    assert STATS_KEYS <= record.keys()
    assert record["rq"] == pytest.approx(0.1e-6, rel=0.02)  # Table 1, SI units
    assert record["psi"] == pytest.approx(13.20, rel=0.02)
    g5 = builtin_surface("G5")
    assert (record["n"], record["spacing"]) == (g5.n, g5.spacing) == (128, 1e-6)
    assert_moments_agree(record, g5.heights)


def test_multiscale_json_keys(capsys):
    """The command's numbers are the library's, computed here step by step: the scales of G5,
    the multi-scale model at F* = 0.155, CKE and LET at the psi of ``surface stats``."""
    from roughfriction.multiscale.friction import static_friction
    from roughfriction.multiscale.scales import scale_decomposition
    from roughfriction.multiscale.statistical import cke_friction, let_friction

    record = run_json(capsys, "multiscale", "G5", "--load", "0.155")
    assert THEORY_KEYS <= record.keys()
    assert record["converged"] is True
    assert 0 < record["area_ratio_normal"] <= record["area_ratio_sliding"] <= 1
    normal_load = 0.155 * Material().Sy * builtin_surface("G5").scan_length ** 2
    assert record["mu_s"] == pytest.approx(record["Ft_max"] / normal_load)
    assert record["cke_valid"] is False  # psi = 13.2 > 8
    assert record["let_valid"] is True
    friction = static_friction(scale_decomposition(builtin_surface("G5")), 0.155, Material())
    assert record["mu_s"] == pytest.approx(friction.mu_s, rel=1e-12)
    assert record["Ft_max"] == pytest.approx(friction.Ft_max, rel=1e-12)
    assert record["area_ratio_normal"] == pytest.approx(friction.area_ratio_normal, rel=1e-12)
    assert record["area_ratio_sliding"] == pytest.approx(friction.area_ratio_sliding, rel=1e-12)
    psi = run_json(capsys, "surface", "stats", "G5")["psi"]
    assert record["psi"] == psi
    assert record["mu_cke"] == pytest.approx(cke_friction(psi, 0.155).mu_s, rel=1e-12)
    assert record["mu_let"] == pytest.approx(let_friction(psi, 0.155).mu_s, rel=1e-12)


def test_npy_file_with_size(tmp_path, capsys):
    """63 um over 64 points: 1 um spacing; heights in metres, their least-squares plane
    removed (the reader's default for a file)."""
    z = np.random.default_rng(1).normal(0.0, 0.1e-6, (64, 64))
    path = tmp_path / "rough.npy"
    np.save(path, z)
    record = run_json(capsys, "surface", "stats", str(path), "--size", "63um")
    assert record["n"] == 64
    assert record["spacing"] == pytest.approx(1e-6)
    x, y = np.indices(z.shape)
    plane = np.column_stack([np.ones(z.size), x.ravel(), y.ravel()])
    residual = z.ravel() - plane @ np.linalg.lstsq(plane, z.ravel(), rcond=None)[0]
    assert_moments_agree(record, residual)


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
#: What the one line of each bad input says is wrong.
BAD_INPUT_REASONS = {
    "nan heights": "16 missing (NaN or unmeasured) heights of 256",  # the diagonal of 16 x 16
    "non-square": "grid 16 x 20 is not square",
    "1-D": "holds a 1-D array of shape (16,), not a 2-D height map",
    "zero roughness": "RMS height 0 m < 1e-10 m",
    "unknown name": "'G10' is neither a file nor a built-in surface",
    "missing file": "nope.npy' is neither a file nor a built-in surface",
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_input_is_one_line_and_nonzero(case, tmp_path, capsys):
    assert main(BAD_INPUTS[case](tmp_path)) == EXIT_INPUT_ERROR
    err = capsys.readouterr().err.strip()
    assert err.startswith("roughfriction: error:")
    assert "\n" not in err and "Traceback" not in err
    assert BAD_INPUT_REASONS[case] in err


@pytest.mark.parametrize("load", ["-0.1", "0", "nan"])
def test_bad_load_is_refused(load, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["multiscale", "G5", "--load", load])
    assert exit_info.value.code != 0
    assert exit_info.value.code == EXIT_INPUT_ERROR
    err = capsys.readouterr().err
    assert "must be a finite number > 0" in err
    assert f"argument --load: must be a finite number > 0, got {load} " in err


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


# --- issue 54: Ctrl-C, --version, one-line argparse errors, help, messages, noise ------------


def one_line(err: str) -> str:
    """The only line of ``err`` (fails if there are more)."""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.parametrize("argv", [["figure", "fig3"], ["fem", "G5", "--load", "0.155"],
                                  ["fem", "G5", "--load", "0.155", "--normal-only"]])
def test_interrupt_is_one_line_and_exit_130(argv, monkeypatch, capsys):
    from roughfriction.scripts import fem, figures

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(figures, "make_figure", interrupted)
    monkeypatch.setattr(fem, "run_fem", interrupted)
    assert main(argv) == EXIT_INTERRUPTED == 130
    captured = capsys.readouterr()
    assert one_line(captured.err) == "roughfriction: interrupted"
    assert captured.out == ""


@pytest.mark.fem
@pytest.mark.parametrize("signal_name", ["SIGINT", "SIGTERM"])
def test_ctrl_c_in_a_real_fem_run_exits_130_without_traceback(signal_name, tmp_path):
    """SIGINT (Ctrl-C) or SIGTERM (what mpirun sends its ranks on Ctrl-C) while the FEM steps:
    one line, status 130, no results file under its name."""
    import signal

    from tests.test_cache import ROOT, command_environment, wait_for_line

    output = tmp_path / "run.h5"
    command = [sys.executable, "-m", "roughfriction.scripts.cli", "fem", "G5", "--n", "16",
               "--window", "best", "--load", "0.155", "--output", str(output)]
    process = subprocess.Popen(command, cwd=ROOT, env=command_environment(), text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        wait_for_line(process, "FEM G5: N=16", 300)  # meshed, about to step
        process.send_signal(getattr(signal, signal_name))
        _, err = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == EXIT_INTERRUPTED, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    assert err.strip().splitlines()[-1] == "roughfriction: interrupted"
    assert not output.exists()


def test_version(capsys):
    from roughfriction import __version__

    with pytest.raises(SystemExit) as exit_info:
        main(["--version"])
    assert exit_info.value.code == 0
    assert capsys.readouterr().out.strip() == f"roughfriction {__version__}"


@pytest.mark.parametrize(("argv", "message"), [
    ([], "required: COMMAND"),
    (["multiscale", "G5"], "required: --load"),
    (["multiscale", "G5", "--load", "x"], "not a number: 'x'"),
    (["fem", "G5", "--load", "0.1", "--bogus"], "unrecognized arguments: --bogus"),
    (["surface", "stats", "G5", "--fill", "cubic"], "invalid choice: 'cubic'"),
    (["figure"], "required: NAME"),
])
def test_argparse_errors_are_one_line_and_exit_2(argv, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == EXIT_INPUT_ERROR
    line = one_line(capsys.readouterr().err)
    assert line.startswith("roughfriction") and ": error: " in line and message in line
    assert "--help" in line  # where to read more, instead of the usage block


def test_bench_says_in_one_line_that_the_benchmarks_run_from_a_checkout(capsys):
    assert main(["bench", "stress", "--n", "x"]) == EXIT_INPUT_ERROR
    line = one_line(capsys.readouterr().err)
    assert line == ("roughfriction: error: the benchmarks are not installed; run them from a "
                    "checkout of the repository: python -m benchmarks stress --n x")


def subcommand_parsers(parser, prefix=("roughfriction",)):
    """(command words, parser) of every parser under ``parser``, itself included."""
    import argparse

    yield prefix, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from subcommand_parsers(sub, (*prefix, name))


def test_every_option_of_every_subcommand_has_help():
    import argparse

    from roughfriction.scripts.cli import build_parser

    def described(action):
        if isinstance(action, argparse._SubParsersAction):  # each command has its help
            return all(choice.help for choice in action._choices_actions)
        return isinstance(action, argparse._HelpAction) or bool((action.help or "").strip())

    missing = [f"{' '.join(words)} {action.dest}"
               for words, parser in subcommand_parsers(build_parser())
               for action in parser._actions if not described(action)]
    assert missing == []


def test_every_subcommand_help_says_what_it_does():
    from roughfriction.scripts.cli import build_parser

    undescribed = [" ".join(words) for words, parser in subcommand_parsers(build_parser())
                   if not (parser.description or "").strip()]
    assert undescribed == []


def test_help_names_real_defaults(capsys):
    from roughfriction.studies.paper import DEFAULT_FEM_N

    with pytest.raises(SystemExit):
        main(["figure", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "scripts.cases" not in text
    assert f"else {DEFAULT_FEM_N})" in text


def write_heights(tmp_path, name, array):
    path = tmp_path / name
    np.save(path, array)
    return ["surface", "stats", str(path), "--size", "15um"]


def grid_with_holes():
    z = np.random.default_rng(2).normal(0.0, 0.1e-6, (16, 20))
    z[3, 4] = np.nan
    return z


#: Bad surfaces, their argv's extra flags, and what the one-line message must say: the flag to
#: use, never the Python argument (fill='nearest', square='crop', pixels='resample').
SURFACE_MESSAGES = {
    "1 x 1": (np.ones((1, 1)) * 1e-7, [], "1 x 1 grid"),
    "1 x 16": (np.ones((1, 16)) * 1e-7, [], "1 x 16 grid"),
    "all NaN": (np.full((16, 16), np.nan), [], "no height is measured"),
    "all NaN, filled": (np.full((16, 16), np.nan), ["--fill", "nearest"], "no height is measured"),
    "holes": (grid_with_holes(), ["--crop"], "--fill=nearest or --fill=plane"),
    "not square": (grid_with_holes(), [], "use --crop"),
    "built-in with a flag": (None, ["--crop"], "--crop"),
}


@pytest.mark.parametrize("case", sorted(SURFACE_MESSAGES))
def test_surface_messages_name_the_flags(case, tmp_path, capsys):
    heights, flags, message = SURFACE_MESSAGES[case]
    argv = (["surface", "stats", "G5"] if heights is None
            else write_heights(tmp_path, "z.npy", heights))
    assert main([*argv, *flags]) == EXIT_INPUT_ERROR
    line = one_line(capsys.readouterr().err)
    assert message in line
    for python_argument in ("fill=", "square=", "pixels=", "(square)", "2-D height map, got"):
        assert python_argument not in line.replace("--fill=", "")


def test_fill_plane_with_too_few_points_says_use_nearest(tmp_path, capsys):
    z = np.full((16, 16), np.nan)
    z[0, 0] = z[5, 5] = 1e-7
    assert main([*write_heights(tmp_path, "z.npy", z), "--fill", "plane"]) == EXIT_INPUT_ERROR
    assert "--fill=nearest" in one_line(capsys.readouterr().err)


def test_warnings_are_counted_into_one_line_each(monkeypatch, capsys):
    import warnings

    from roughfriction.scripts import cli

    def noisy(args):
        for k in range(50):
            np.log(np.zeros(3))  # RuntimeWarning: divide by zero, the same line each time
            warnings.warn(f"step {k} extrapolated", RuntimeWarning, stacklevel=1)
        return {"done": True}

    monkeypatch.setattr(cli, "cmd_surface_list", noisy)
    assert main(["surface", "list"]) == 0
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 2, lines
    assert any("divide by zero" in line and "50 times" in line for line in lines)
    assert any("step 0 extrapolated" in line and "50 times" in line for line in lines)
    assert all(line.startswith("roughfriction: warning") for line in lines)


def test_library_info_logging_is_silenced():
    """After the CLI has set up, FFCx's basicConfig and the C compiler's INFO:root lines (the
    JIT sets the root logger to INFO) do not reach stderr; warnings still do."""
    code = ("import logging; from roughfriction.scripts.cli import main; "
            "main(['surface', 'list']); import ffcx; "
            "logging.getLogger().setLevel(logging.INFO); logging.info('running build_ext'); "
            "logging.getLogger('ffcx').info('compiling'); logging.warning('kept')")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert "running build_ext" not in done.stderr and "compiling" not in done.stderr
    assert "kept" in done.stderr


def test_a_reader_that_leaves_early_gets_no_traceback():
    """stdout closed before the record is printed (``roughfriction ... | head -1``): exit 141
    (128 + SIGPIPE), nothing on stderr."""
    from roughfriction.scripts.cli import EXIT_BROKEN_PIPE

    process = subprocess.Popen([sys.executable, "-m", "roughfriction.scripts.cli", "surface",
                                "list"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)
    process.stdout.close()  # before the child has imported anything
    err = process.stderr.read()
    assert process.wait(60) == EXIT_BROKEN_PIPE == 141
    assert err == ""


@pytest.mark.fem
def test_runs_builds_its_cases_as_fem_does_and_says_what_fem_says(tmp_path, capsys):
    """runs re-grids with the same note, takes --window and --config, and reports per load
    mu_s beside its reliability, with the material, in a table with a header."""
    config = tmp_path / "case.toml"
    config.write_text('[material]\nSy = "800MPa"\n')
    common = ["runs", "G5", "--load", "0.155", "0.5", "--n", "8", "--directory",
              str(tmp_path / "runs")]
    assert main([*common, "--json"]) == 0
    captured = capsys.readouterr()
    assert "note: G5 re-gridded from 128 to 8 points per side" in captured.err
    table = json.loads(captured.out)["runs"]
    assert table["F*"] == [0.155, 0.5] and table["N"] == [8, 8]
    assert all(isinstance(flag, bool) for flag in table["reliable"])
    regridded = surface_on_fem_grid(builtin_surface("G5"), 8)
    assert_rows_are_the_runs(table, [FemCase(regridded, Loading(load)) for load in (0.155, 0.5)],
                             tmp_path / "runs")
    assert main([*common, "--window", "1", "--config", str(config)]) == 0
    captured = capsys.readouterr()
    assert "re-gridded" not in captured.err
    lines = captured.out.splitlines()
    assert lines[2].split() == ["F*", "N", "mu_s", "A_r/A_n", "reliable", "converged", "file"]
    assert "Sy     8e+08" in captured.out
    assert "False" in captured.out  # patches of a cell or two on 8 x 8: not resolved
    assert "warning: at F* = 0.155, 0.5: " in captured.err and "--tol 0.03" in captured.err
    columns = list(zip(*(line.split() for line in lines[3:5]), strict=True))
    printed = {"F*": [float(value) for value in columns[0]], "N": [int(n) for n in columns[1]],
               "mu_s": [float(value) for value in columns[2]],
               "A_r/A_n": [float(value) for value in columns[3]],
               "reliable": [value == "True" for value in columns[4]],
               "converged": [value == "True" for value in columns[5]], "file": list(columns[6])}
    window = Surface(builtin_surface("G5").heights[:8, :8], 1e-6, "G5")
    steel = Material(Sy=800e6)
    assert_rows_are_the_runs(printed, [FemCase(window, Loading(load), material=steel)
                                       for load in (0.155, 0.5)], tmp_path / "runs", digits=6)


def assert_rows_are_the_runs(table, cases, directory, digits=None):
    """Each row of a ``runs`` table is its case's run-cache entry: the file of that case, and
    mu_s, A_r/A_n, reliable and converged as the file holds them (to ``digits`` significant
    digits as printed); the file's F_n is F* (n h)^2 S_y (Eq. 10 over the periodic cell)."""
    from roughfriction.solver.results import RELIABLE_CELLS_PER_PATCH
    from roughfriction.studies.cache import entry_path, physics_version
    from roughfriction.studies.post import read_run

    rel = 1e-12 if digits is None else 0.6 * 10.0 ** (1 - digits)
    assert table["file"] == [str(entry_path(directory, case, physics_version()))
                             for case in cases]
    for row, (case, path) in enumerate(zip(cases, table["file"], strict=True)):
        run = read_run(path)
        assert run.inputs == case.inputs() and run.converged
        summary = run.summary
        assert table["mu_s"][row] == pytest.approx(summary["mu_s"], rel=rel)
        assert table["A_r/A_n"][row] == pytest.approx(summary["area_ratio_normal"], rel=rel)
        assert table["reliable"][row] is summary["reliable"] is (
            summary["cells_per_patch"] >= RELIABLE_CELLS_PER_PATCH)
        assert table["converged"][row] is True
        side = case.surface.n * case.surface.spacing
        assert summary["Fn"] == pytest.approx(
            case.loading.load_star * side**2 * case.material.Sy, rel=1e-9)
        assert summary["mu_s"] == pytest.approx(summary["Ft_max"] / summary["Fn"], rel=1e-12)


@pytest.mark.parametrize("command", [["fem", "G5", "--load", "0.155"],
                                     ["runs", "G5", "--load", "0.155"], ["figure", "fig22"]])
def test_n_is_counted_in_surface_cells(command, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main([*command, "--n", "1"])
    assert exit_info.value.code == EXIT_INPUT_ERROR
    assert one_line(capsys.readouterr().err).endswith(
        "argument --n: surface cells per side must be >= 4, got 1 (see roughfriction "
        f"{command[0]} --help)")


def test_text_tables_name_their_units(capsys):
    assert main(["surface", "stats", "G5"]) == 0
    lines = {line.split()[0]: line.split()[1:] for line in capsys.readouterr().out.splitlines()
             if line.strip()}
    assert lines["rq"][1] == "m" and lines["m4"][1] == "m^-2" and lines["spacing"][1] == "m"
    assert len(lines["psi"]) == 1 and lines["Sy"][1] == "Pa"
    record = run_json(capsys, "surface", "stats", "G5")  # the same numbers, to 6 digits
    for key in ("rq", "m4", "psi", "spacing"):
        assert float(lines[key][0]) == pytest.approx(record[key], rel=5e-6), key
    assert float(lines["Sy"][0]) == Material().Sy
