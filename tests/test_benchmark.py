"""The FEM benchmark's table (benchmarks/fem.py), with a stand-in for the mpirun runs."""

from pathlib import Path

import pytest
from roughfriction.studies.certificate import certify

from benchmarks import fem as benchmark
from benchmarks.cli import parse_case


def fake_run(surface, load, n, ranks):
    return {"surface": surface, "load_star": load, "n": n, "ranks": ranks,
            "wall_s": 10.0 * n / ranks, "converged": True}


def test_rows_of_other_cases_sizes_and_rank_counts_are_kept(tmp_path, monkeypatch):
    monkeypatch.setattr(benchmark, "BENCH_DIR", tmp_path)
    monkeypatch.setattr(benchmark, "run_size", fake_run)
    g5 = [("G5", 0.155)]
    benchmark.benchmark_sizes([32, 64], ranks=2, cases=g5)
    benchmark.benchmark_sizes([64], ranks=1, cases=g5)
    rows = benchmark.read_rows(tmp_path / "fem.csv")
    assert sorted(rows) == [("G5", 0.155, 32, 2), ("G5", 0.155, 64, 1), ("G5", 0.155, 64, 2)]
    assert float(rows["G5", 0.155, 64, 1]["wall_s"]) == 640.0
    assert float(rows["G5", 0.155, 64, 2]["wall_s"]) == 320.0
    benchmark.benchmark_sizes([64], ranks=2, cases=g5)  # a rerun replaces its own row only
    assert len(benchmark.read_rows(tmp_path / "fem.csv")) == 3
    benchmark.benchmark_sizes([32], ranks=2, cases=[("G1", 1.86)])
    rows = benchmark.read_rows(tmp_path / "fem.csv")
    assert len(rows) == 4 and rows["G1", 1.86, 32, 2]["surface"] == "G1"


def test_rows_written_before_the_case_columns_are_g5_at_the_low_load(tmp_path, monkeypatch):
    monkeypatch.setattr(benchmark, "BENCH_DIR", tmp_path)
    monkeypatch.setattr(benchmark, "run_size", fake_run)
    (tmp_path / "fem.csv").write_text("n,ranks,wall_s\n128,2,541.0\n")
    benchmark.benchmark_sizes([32], ranks=2, cases=[("2L", 0.5)])
    rows = benchmark.read_rows(tmp_path / "fem.csv")
    assert sorted(rows) == [("2L", 0.5, 32, 2), ("G5", 0.155, 128, 2)]
    assert float(rows["G5", 0.155, 128, 2]["wall_s"]) == 541.0


def test_a_case_is_surface_colon_load():
    import pytest
    from roughfriction.errors import InputError

    assert parse_case("G1:1.86") == ("G1", 1.86)
    with pytest.raises(InputError, match="SURFACE:LOAD"):
        parse_case("G1")


def test_the_path_error_compares_the_default_path_with_a_finer_one(tmp_path, monkeypatch):
    """Each case runs twice: the second with a case file that the CLI accepts and whose largest
    increments are the defaults over PATH_FACTOR; path_error is mu_s / mu_s(fine) - 1."""
    from roughfriction.case import SolverOptions
    from roughfriction.scripts.fem import read_config

    def run(surface, load, n, ranks, config=None, label="fem"):
        options = SolverOptions(**read_config(config).get("solver", {}) if config else {})
        return {"mu_s": 0.3 + options.max_slide_increment, "newton_iterations": 10,
                "wall_s": 1.0, "converged": True}

    monkeypatch.setattr(benchmark, "BENCH_DIR", tmp_path)
    monkeypatch.setattr(benchmark, "run_size", run)
    rows = benchmark.path_errors(64, 2, [("G5", 0.93)], factor=4)
    default = SolverOptions()
    assert rows[0]["mu_s"] == 0.3 + default.max_slide_increment
    assert rows[0]["mu_s_fine_path"] == 0.3 + default.max_slide_increment / 4
    assert rows[0]["path_error"] == rows[0]["mu_s"] / rows[0]["mu_s_fine_path"] - 1
    assert (tmp_path / "path.csv").read_text().count("\n") == 2
    benchmark.path_errors(128, 2, [("G5", 0.93)], factor=4)  # another N keeps the row above
    assert sorted(benchmark.read_rows(tmp_path / "path.csv")) == [("G5", 0.93, 64, 2),
                                                                   ("G5", 0.93, 128, 2)]


def test_a_path_run_without_inception_leaves_the_error_empty(tmp_path, monkeypatch):
    """A run that does not reach inception has no mu_s: its row says so and the others go on."""
    def run(surface, load, n, ranks, config=None, label="fem"):
        converged = config is None
        return {"mu_s": 0.3 if converged else None, "newton_iterations": 10, "wall_s": 1.0,
                "converged": converged}

    monkeypatch.setattr(benchmark, "BENCH_DIR", tmp_path)
    monkeypatch.setattr(benchmark, "run_size", run)
    rows = benchmark.path_errors(32, 2, [("G5", 0.93), ("G1", 1.86)])
    assert [row["path_error"] for row in rows] == [None, None]
    assert not any(row["converged"] for row in rows)


def profile_of(n, peak_gb):
    """A ``bench profile`` result of G5 at F* = 0.155 with one phase and one object."""
    return {"case": {"surface": "G5", "load_star": 0.155, "n": n, "ranks": 2},
            "mu_s": 0.25, "newton_iterations": 41,
            "linear_solves": {"x1 cg": {"krylov_iterations": 507},
                              "x2 cg": {"krylov_iterations": 158}},
            "memory": {"peak_gb": peak_gb, "peak_kb_per_dof": 16.0, "reduced_dofs": 32784,
                       "phases": {"mesh": {"peak_gb": 0.34, "peak_kb_per_dof": 11.1}},
                       "objects": {"reduced tangent": {"gb": 0.0667, "kb_per_dof": 2.185,
                                                       "kb_per_surface_node": 17.5}}}}


def test_a_version_s_memory_column_replaces_its_own_and_keeps_the_others(tmp_path):
    import csv

    import pytest
    from roughfriction.errors import InputError

    path = tmp_path / "memory.csv"
    benchmark.add_memory_column(path, profile_of(64, 0.50), "0.23")
    benchmark.add_memory_column(path, profile_of(64, 0.60), "0.24")
    benchmark.add_memory_column(path, profile_of(64, 0.49), "0.24")
    with open(path, newline="") as stream:
        rows = list(csv.DictReader(stream))
    peaks = {row["version"]: row for row in rows if row["item"].startswith("peak (VmHWM")}
    assert [row["version"] for row in rows].count("0.24") == 5  # replaced, not appended
    assert peaks["0.23"]["gb"] == "0.5000" and peaks["0.24"]["gb"] == "0.4900"
    above = next(row for row in rows if row["version"] == "0.24" and "above" in row["item"])
    assert float(above["kb_per_dof"]) == pytest.approx(
        (0.49 - benchmark.FIXED_STARTUP_GB) * 2**30 / 1e3 / 32784, abs=1e-3)
    assert rows[-1]["item"] == "mu_s=0.250000000000 newton=41 krylov=507/158"
    assert rows[0]["case"] == "G5 N=64 F*=0.155 2 ranks 32784 dofs"
    with pytest.raises(InputError, match="not G5 N=128"):
        benchmark.add_memory_column(path, profile_of(128, 0.9), "0.24")


def ladder_summary(values, error):
    """A ``Ladder.summary()`` of levels with the mu_s ``values``."""
    count = len(values)
    return {"mu_s_error": error, "levels": {
        "factor": [2**k for k in range(count)], "reduced_dofs": [100 * 4**k for k in range(count)],
        "cells": [10 * 4**k for k in range(count)], "wall_s": [1.0 + k for k in range(count)],
        "mu_s": list(values), "zone_escaped": [False] * count}}


def test_a_ladder_gives_a_row_per_level_with_its_memory_and_error_on_the_finest():
    case = {"surface": "G5", "load_star": 0.155, "n": 8, "ranks": 2, "ladder": "adaptive"}
    rows = benchmark.ladder_rows(ladder_summary([0.3, 0.25, 0.24], 0.01),
                                 {"peak_memory_gb": 1.5}, case, "0.25.0")
    assert [row["level"] for row in rows] == [0, 1, 2]
    assert [row["mu_s"] for row in rows] == [0.3, 0.25, 0.24]
    assert [row["peak_memory_gb"] for row in rows] == [None, None, 1.5]
    assert [row["mu_s_error"] for row in rows] == [None, None, 0.01]
    assert all(row["ladder"] == "adaptive" and row["version"] == "0.25.0" for row in rows)


def test_a_rerun_ladder_replaces_all_its_levels_and_keeps_the_other_ladders(tmp_path):
    table = tmp_path / "ladder.csv"
    case = {"surface": "G5", "load_star": 0.155, "n": 8, "ranks": 2}
    for ladder, values in (("adaptive", [0.3, 0.25, 0.24]), ("uniform", [0.3, 0.26])):
        benchmark.merge_ladder_rows(table, benchmark.ladder_rows(
            ladder_summary(values, 0.01), {}, {**case, "ladder": ladder}, "0.25.0"))
    benchmark.merge_ladder_rows(table, benchmark.ladder_rows(
        ladder_summary([0.3, 0.2], 0.1), {}, {**case, "ladder": "adaptive"}, "0.25.0"))
    rows = benchmark.read_table(table)
    assert [(row["ladder"], row["level"], row["mu_s"]) for row in rows] == [
        ("adaptive", "0", "0.3"), ("adaptive", "1", "0.2"), ("uniform", "0", "0.3"),
        ("uniform", "1", "0.26")]


def test_the_ladders_of_two_windows_are_kept_apart(tmp_path):
    table = tmp_path / "ladder_windows.csv"
    case = {"surface": "G5", "load_star": 0.155, "n": 8, "ranks": 2, "ladder": "uniform"}
    for window, values in ((1, [0.3, 0.25]), (2, [0.2, 0.21]), (None, [0.4, 0.3])):
        benchmark.merge_ladder_rows(table, benchmark.ladder_rows(
            ladder_summary(values, 0.01), {}, {**case, "window": window}, "0.26.0"))
    rows = benchmark.read_table(table)
    assert [(row["window"], row["level"], row["mu_s"]) for row in rows] == [
        ("", "0", "0.4"), ("", "1", "0.3"), ("1", "0", "0.3"), ("1", "1", "0.25"),
        ("2", "0", "0.2"), ("2", "1", "0.21")]


def test_a_window_s_ladder_runs_fem_on_that_window_into_its_own_file():
    whole = benchmark.ladder_command("G5", 0.155, 8, 2, 2, "adaptive", Path("out.h5"))
    window = benchmark.ladder_command("G5", 0.155, 8, 2, 2, "adaptive", Path("out.h5"), 3)
    assert "--window" not in whole and window == whole + ["--window", "3"]
    assert benchmark.case_stem("G5", 0.155, 8, 2, 3) == "G5_F0.155_N8_W3_2ranks"
    assert benchmark.case_stem("G5", 0.155, 8, 2) == "G5_F0.155_N8_2ranks"


@pytest.mark.fem
def test_a_ladder_runs_under_mpirun_and_reports_its_levels(tmp_path, monkeypatch):
    """The whole path: roughfriction fem --tol under mpirun (exit 3: the tolerance of 1e-12
    is not met), its finest results file, the rows."""
    monkeypatch.setattr(benchmark, "BENCH_DIR", tmp_path)
    rows = benchmark.run_ladder_levels("G5", 0.155, 4, 1, 1, "adaptive")
    assert [row["level"] for row in rows] == [0, 1]
    assert rows[1]["reduced_dofs"] > rows[0]["reduced_dofs"] > 0
    assert all(row["mu_s"] > 0.0 for row in rows)
    certificate = certify([row["mu_s"] for row in rows], rows[1]["contact_nodes"],
                          rows[1]["boundary_nodes"])
    assert rows[1]["mu_s_error"] == pytest.approx(certificate.error)
    assert rows[1]["peak_memory_gb"] > 0.0
    # the finest row is the results file the run wrote: its mu_s, that of its last step, and
    # its sizes; the tolerance was out of reach, and the file says so
    from roughfriction.studies.post import read_run

    (output,) = tmp_path.glob("ladder_adaptive_G5_F0.155_N4_1ranks*.h5")
    finest = read_run(output)
    assert rows[1]["mu_s"] == finest.summary["mu_s"] == pytest.approx(
        finest.steps["tangential_force"][-1] / finest.steps["normal_force"][-1], rel=1e-12)
    assert finest.summary["levels"]["mu_s"] == [row["mu_s"] for row in rows]
    assert rows[1]["peak_memory_gb"] == finest.sizes["peak_memory_gb"]
    assert rows[1]["reduced_dofs"] == finest.sizes["reduced_dofs"]
    assert finest.summary["error_tolerance"] == 1e-12
    assert finest.summary["error_tolerance_met"] is False


#: The folders of the installed package (pyproject's package-dir), which never import the
#: benchmarks.
PACKAGE_FOLDERS = ("core", "geometry", "solver", "multiscale", "studies", "scripts")
REPOSITORY = Path(__file__).resolve().parents[1]


def benchmark_imports(source: str) -> list[str]:
    """The modules of ``benchmarks`` that Python ``source`` imports, anywhere in it."""
    import ast

    names = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names.append(node.module)
    return [name for name in names if name == "benchmarks" or name.startswith("benchmarks.")]


def test_the_installed_package_never_imports_the_benchmarks():
    assert benchmark_imports("import os\ndef f():\n    from benchmarks.fem import run_size\n"
                             "import benchmarks\n") == ["benchmarks", "benchmarks.fem"]
    assert benchmark_imports("from roughfriction.studies import benchmarks_x\n") == []
    found = {str(path.relative_to(REPOSITORY)): imports
             for folder in PACKAGE_FOLDERS for path in sorted((REPOSITORY / folder).rglob("*.py"))
             if (imports := benchmark_imports(path.read_text()))}
    assert found == {}


def test_the_benchmarks_are_not_installed():
    import tomllib

    setuptools = tomllib.loads((REPOSITORY / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert not any("benchmarks" in package for package in setuptools["packages"])
    assert not any(folder.startswith("benchmarks") for folder in
                   setuptools["package-dir"].values())


def test_a_bad_benchmark_command_line_is_one_line_and_exits_2(capsys):
    from benchmarks.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main(["stress", "--n", "x"])
    assert exit_info.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("python -m benchmarks stress: error: ")
    assert "invalid int value" in lines[0] and "--help" in lines[0]


def test_every_benchmark_command_and_option_has_help():
    import argparse

    from benchmarks.cli import build_parser

    def parsers(parser):
        yield parser
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub in action.choices.values():
                    yield from parsers(sub)

    every = list(parsers(build_parser()))
    assert len(every) == 10  # the front end and its nine commands
    assert [parser.prog for parser in every if not (parser.description or "").strip()] == []
    assert [f"{parser.prog} {action.dest}" for parser in every for action in parser._actions
            if not isinstance(action, argparse._SubParsersAction | argparse._HelpAction)
            and not (action.help or "").strip()] == []


def test_a_profile_on_a_finer_level_is_named_by_its_factor():
    assert benchmark.case_stem("G5", 0.155, 128, 2, level=1) == "G5_F0.155_N128_2x_2ranks"
    assert benchmark.case_stem("G5", 0.155, 128, 2, level=0) == "G5_F0.155_N128_2ranks"
    profile = profile_of(128, 4.0)
    assert benchmark.memory_case_label(profile) == "G5 N=128 F*=0.155 2 ranks 32784 dofs"
    profile["case"]["level"] = 2
    assert benchmark.memory_case_label(profile) == "G5 N=128 4x F*=0.155 2 ranks 32784 dofs"
    profile["physics"] = "0123456789ab"
    rows = benchmark.memory_column(profile, "0.26")
    assert {row["physics"] for row in rows} == {"0123456789ab"}


def test_python_m_benchmarks_runs_from_the_checkout_only(tmp_path):
    import subprocess
    import sys

    from commands import command_environment

    command = [sys.executable, "-m", "benchmarks", "stress", "--n", "x"]
    inside = subprocess.run(command, cwd=REPOSITORY, capture_output=True, text=True,
                            env=command_environment(), timeout=120)
    assert inside.returncode == 2 and "invalid int value: 'x'" in inside.stderr
    outside = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True,
                             env=command_environment(), timeout=120)
    assert outside.returncode == 1 and "No module named benchmarks" in outside.stderr
