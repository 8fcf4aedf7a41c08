"""Tests of studies.api, the public Python API, and of docs/api.md, whose examples run here."""

import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import roughfriction as rf
from roughfriction.studies import api, fem_input
from roughfriction.studies.certificate import certify

DOCS = Path(__file__).resolve().parents[1] / "docs" / "api.md"
HEAVY = ("dolfinx", "mpi4py", "petsc4py", "gmsh", "ufl")


def python_blocks(markdown: str) -> list[str]:
    """The ```python blocks of a Markdown text, in order."""
    return re.findall(r"^```python\n(.*?)^```", markdown, flags=re.MULTILINE | re.DOTALL)


def loaded_after(code: str) -> list[str]:
    """Top-level packages among numpy and the FEM stack imported by ``code`` in a fresh
    interpreter."""
    probe = (f"import sys\n{code}\nprint(sorted({{m.split('.')[0] for m in sys.modules}} & "
             f"{{'numpy', *{HEAVY!r}}}))")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          check=True)
    return eval(done.stdout)


def test_import_roughfriction_loads_neither_numpy_nor_the_fem_stack():
    assert loaded_after("import roughfriction") == []


def test_the_theory_half_of_the_api_loads_no_fem_stack():
    code = "import roughfriction as rf; rf.theory(rf.load_surface('G1'), 0.1)"
    assert loaded_after(code) == ["numpy"]


def test_the_package_offers_exactly_the_api_names():
    assert sorted(rf.API_NAMES) == sorted(api.__all__)
    for name in api.__all__:
        assert getattr(rf, name) is getattr(api, name)
        assert name in dir(rf)
    with pytest.raises(AttributeError, match="no attribute 'run'"):
        rf.run  # noqa: B018


def test_fem_case_checks_the_load_before_re_gridding(monkeypatch):
    def re_grid(*args):
        raise AssertionError("re-gridded before the load was checked")

    monkeypatch.setattr(fem_input, "surface_on_fem_grid", re_grid)
    with pytest.raises(rf.InputError, match=r"normal load F\* = 1e\+09 > 100"):
        rf.fem_case(rf.load_surface("G5"), 1e9, n=16)


def test_fem_case_re_grids_with_a_warning_or_takes_a_window():
    g5 = rf.load_surface("G5")
    with pytest.warns(UserWarning, match=r"re-gridded from 128 to 16 .* psi 13\.2 -> "):
        coarse = rf.fem_case(g5, 0.155, n=16)
    assert coarse.surface.n == 16 and coarse.surface.spacing == pytest.approx(127e-6 / 15)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        second = rf.fem_case(g5, 0.155, n=16, window=2, normal_only=True)
        whole = rf.fem_case(g5, 0.155)
    np.testing.assert_array_equal(second.surface.heights, g5.heights[:16, 16:32])
    assert second.loading.normal_only and whole.surface is g5


def test_an_n_above_the_surface_points_is_noted_like_a_re_grid():
    """--n above the points Fourier-interpolates the surface: said with the psi of both and
    the command that refines the mesh of the surface as measured instead."""
    window = rf.fem_case(rf.load_surface("G5"), 0.155, n=16, window=1).surface
    with pytest.warns(UserWarning, match=r"Fourier-interpolated from 16 to 32 points per side: "
                      r"psi .* -> .*; the measured surface on a finer mesh is --tol"):
        finer = rf.fem_case(window, 0.155, n=32)
    assert finer.surface.n == 32


@pytest.mark.parametrize("window, n, message", [
    (0, 16, "window counts from 1, got 0"),
    ("first", 16, "got 'first'"),
    (True, 16, "got True"),
    (65, 16, "has 64 windows of 16 x 16 points, not 65"),
    ("best", None, "window needs n below the surface's 128 points"),
    ("best", 3, "integer >= 4"),
])
def test_bad_windows_are_refused_in_one_line(window, n, message):
    with pytest.raises(rf.InputError, match=re.escape(message)):
        rf.fem_case(rf.load_surface("G5"), 0.155, n=n, window=window)


@pytest.mark.fem
@pytest.mark.parametrize("where, message", [
    ("exists.h5", "exists and is not a results file: pass overwrite=True"),
    ("a_file/run.h5", "cannot write"),
    (".", "is a directory"),
])
def test_an_output_that_cannot_be_written_is_refused_before_the_run(where, message, tmp_path,
                                                                    monkeypatch):
    from roughfriction.solver import run as solver_run

    monkeypatch.setattr(solver_run, "run", lambda *args: pytest.fail("the run started"))
    (tmp_path / "exists.h5").write_bytes(b"")
    (tmp_path / "a_file").write_bytes(b"")
    case = rf.fem_case(rf.load_surface("G5"), 0.155, n=8, window=1)
    with pytest.raises(rf.InputError, match=message):
        rf.run_fem(case, tmp_path / where)


@pytest.mark.fem
def test_an_unconverged_run_is_written_then_raised(tmp_path):
    case = rf.fem_case(rf.load_surface("G5"), 0.155, n=8, window="best",
                       solver=rf.SolverOptions(max_steps=1))
    output = tmp_path / "partial.h5"
    with pytest.raises(rf.ConvergenceError, match=f"did not converge: .*partial results in "
                       f"{re.escape(str(output))}"):
        rf.run_fem(case, output, progress=lambda record: None)
    run = rf.read_run(output)
    assert not run.converged and run.summary["mu_s"] is None
    # one step of the preload, written as computed; the message says where it stopped
    assert list(run.steps["phase"]) == ["normal"] and run.summary["steps"] == 1
    reached = run.steps["normal_force"][-1]
    assert run.summary["Fn"] == reached
    target = 0.155 * (8 * case.surface.spacing) ** 2 * case.material.Sy  # Eq. 10
    assert 0 < reached < target
    assert run.message == (f"step limit reached during preload at F_n = {reached / target:.4g}"
                           " x target")


# --- case files: the command's --config, through the API ------------------------------------

CASE_FILE = ('load = 0.3\nn = 16\nnormal_only = true\n[mesh]\nblend_layers = 3\n'
             '[solver]\npenalty = 20.0\n[material]\nE = "210GPa"\nSy = "800MPa"\n')


def command_line(**given):
    """The parsed flags of ``roughfriction fem G5`` that building a case reads, unset unless
    given."""
    from types import SimpleNamespace

    names = ("config", "load", "n", "window", "elastic", "normal_only")
    return SimpleNamespace(surface="G5", **{name: given.get(name) for name in names})


def test_a_case_file_through_the_api_is_the_case_the_command_builds(tmp_path):
    """load_case(path, surface, **overrides) == the case of fem G5 --config path --flags."""
    from roughfriction.scripts.fem import case_from_args

    path = tmp_path / "case.toml"
    path.write_text(CASE_FILE)
    g5 = rf.load_surface("G5")
    through_api = rf.load_case(path, g5, window=2, elastic=True)
    through_cli = case_from_args(command_line(config=str(path), window="2", elastic=True), g5)
    assert through_api.inputs() == through_cli.inputs()
    np.testing.assert_array_equal(through_api.surface.heights, g5.heights[:16, 16:32])
    assert (through_api.material.E, through_api.material.Sy) == (210e9, 800e6)
    assert through_api.mesh.blend_layers == 3 and through_api.solver.penalty == 20.0
    assert through_api.solver.elastic and through_api.loading.normal_only
    assert through_api.loading.load_star == 0.3
    heavier = rf.load_case(path, g5, load=0.62, n=8, window="best")
    as_flags = case_from_args(command_line(config=str(path), load=0.62, n=8, window="best"), g5)
    assert heavier.inputs() == as_flags.inputs()
    assert (heavier.loading.load_star, heavier.surface.n) == (0.62, 8)


@pytest.mark.parametrize("text, message", [
    ("load = 0.3\n[solver]\npenalti = 3\n", "unknown keys in "),
    ("load = 0.3\n[material]\nE = 210\n", "E = 210 Pa is not a metal's"),
    ("load = 0.3\n[material]\nSy = \"800 MPascal\"\n", "give a number in Pa"),
    ("n = 16\n", "the normal load is required: load=F* (or load = ... in the case file)"),
    ("load = [0.3\n", "cannot read case file"),
    ("load = 1e9\n", "normal load F* = 1e+09 > 100"),
])
def test_a_bad_case_file_is_refused_in_one_line(text, message, tmp_path):
    path = tmp_path / "case.toml"
    path.write_text(text)
    with pytest.raises(rf.InputError, match=re.escape(message)):
        rf.load_case(path, rf.load_surface("G5"))


def test_a_run_too_large_for_memory_is_refused_before_re_gridding(monkeypatch):
    """The command's memory gate, in fem_case: an n whose run would not fit (N = 1024 needs
    about 46 GB, 5 GB are available here) is refused before the surface is interpolated onto
    it; N = 256 (about 3 GB) fits."""
    from roughfriction.solver import memory

    def re_grid(*args):
        raise AssertionError("re-gridded before the memory was checked")

    monkeypatch.setattr(memory, "available_memory_gb", lambda comm: 5.0)
    g5 = rf.load_surface("G5")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Fourier interpolation's note
        assert rf.fem_case(g5, 0.155, n=256).surface.n == 256
    monkeypatch.setattr(fem_input, "surface_on_fem_grid", re_grid)
    with pytest.raises(rf.InputError, match="N = 1024: the FEM run needs about .* GB .*, 5 GB are "
                       "available"):
        rf.fem_case(g5, 0.155, n=1024)


@pytest.mark.parametrize("tol, limits, message", [
    (1.5, None, "a relative error below 1"),
    (0.0, None, "must be > 0"),
    (0.1, rf.LadderLimits(tolerance=0.2), "two tolerances"),
    (None, rf.LadderLimits(max_level=0), "an estimate needs two levels"),
    (0.1, rf.LadderLimits(max_time_s=0.0), "max_time_s must be > 0"),
])
def test_bad_ladders_are_refused_before_the_run(tol, limits, message, monkeypatch):
    from roughfriction.solver import run as solver_run

    monkeypatch.setattr(solver_run, "run", lambda *args, **kwargs: pytest.fail("the run started"))
    case = rf.fem_case(rf.load_surface("G5"), 0.155, n=8, window=1)
    with pytest.raises(rf.InputError, match=re.escape(message)):
        rf.run_fem(case, tol=tol, limits=limits)


def test_requests_differ_by_what_their_ladder_computes():
    """The request digest (the results file a request reuses) tells apart a single run, the
    two-level ladder, tolerances, a uniform ladder and another zone margin; not the limits on
    time and memory, which only stop a ladder sooner."""
    from roughfriction.studies.fem_request import ladder_labels, request_digest

    case = rf.fem_case(rf.load_surface("G5"), 0.155, n=8, window=1)
    ladders = [None, rf.LadderLimits(max_level=1), rf.LadderLimits(0.03),
               rf.LadderLimits(0.05), rf.LadderLimits(0.03, max_level=2),
               rf.LadderLimits(0.03, ladder="uniform"), rf.LadderLimits(0.03, margin=2)]
    digests = {request_digest(case, ladder_labels(limits)) for limits in ladders}
    assert len(digests) == len(ladders)
    assert ladder_labels(rf.LadderLimits(0.03, max_memory_gb=2.0, max_time_s=60.0)) == (
        "tol0.03_L3",)


# --- the error ladder through run_fem ---------------------------------------------------------

def quiet(record):
    """A progress callable that drops every line."""


def without_timings(summary: dict) -> dict:
    """A summary without its wall times (the rest of a deterministic run repeats exactly)."""
    return {**{key: value for key, value in summary.items() if key != "wall_s"},
            "levels": {key: value for key, value in summary["levels"].items()
                       if key != "wall_s"}}


@pytest.mark.fem
def test_run_fem_with_a_tolerance_is_the_command_s_ladder(tmp_path, capsys):
    """G5's first 8 x 8 window at F* = 0.155 to 50 % within level 2, through the API and
    through fem --tol 0.5 --max-level 2: the same levels, mu_s and mu_s_error."""
    import json

    from roughfriction.scripts.cli import main

    case = rf.fem_case(rf.load_surface("G5"), 0.155, n=8, window=1)
    summary = rf.run_fem(case, tmp_path / "api.h5", tol=0.5, limits=rf.LadderLimits(max_level=2),
                         progress=quiet)
    levels = summary["levels"]
    assert summary["error_tolerance"] == 0.5 and summary["error_tolerance_met"]
    assert levels["factor"][:2] == [1, 2] and levels["mu_s"][-1] == summary["mu_s"]
    assert 0 < summary["mu_s_error"] <= 0.5 * summary["mu_s"]
    assert rf.read_run(tmp_path / "api.h5").summary == summary
    assert main(["fem", "G5", "--n", "8", "--window", "1", "--load", "0.155", "--tol", "0.5",
                 "--max-level", "2", "--json", "--output", str(tmp_path / "cli.h5")]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["mu_s_error"] == summary["mu_s_error"]
    assert printed["levels"]["mu_s"] == levels["mu_s"]
    assert without_timings(printed) == without_timings(summary)


@pytest.mark.fem
def test_the_same_request_from_either_door_is_one_results_file(tmp_path, monkeypatch, capsys):
    """A two-level ladder run through the API is the request of fem --refine --ladder uniform:
    the command finds it in the API's results file and prints its summary without a solve."""
    import json

    from roughfriction.scripts.cli import main
    from roughfriction.solver import run as solver_run

    path = tmp_path / "rough.npy"
    np.save(path, np.random.default_rng(3).normal(0.0, 0.1e-6, (8, 8)))
    surface = rf.load_surface(str(path), size="7um")
    case = rf.fem_case(surface, 0.3, normal_only=True, solver=rf.SolverOptions(elastic=True),
                       measured=True)
    output = tmp_path / "run.h5"
    summary = rf.run_fem(case, output, limits=rf.LadderLimits(max_level=1, ladder="uniform"),
                         progress=quiet)
    assert summary["levels"]["factor"] == [1, 2] and summary["error_ladder"] == "uniform"
    levels = summary["levels"]
    assert summary["area_ratio_normal_error"] == pytest.approx(certify(
        levels["area_ratio_normal"], levels["contact_nodes"][-1],
        levels["boundary_nodes"][-1]).error)
    monkeypatch.setattr(solver_run, "run", lambda *args, **kwargs: pytest.fail("solved"))
    assert main(["fem", str(path), "--size", "7um", "--load", "0.3", "--normal-only",
                 "--elastic", "--refine", "--ladder", "uniform", "--json",
                 "--output", str(output)]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out) == summary
    assert captured.err.startswith(f"reused: {output} holds this case")


@pytest.mark.fem
def test_the_examples_of_docs_api_md_run(tmp_path, monkeypatch, capsys):
    """Every ```python block of docs/api.md, in order, as one script in an empty folder."""
    blocks = python_blocks(DOCS.read_text())
    assert len(blocks) >= 5
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "docs_api"}
    for number, block in enumerate(blocks, 1):
        try:
            exec(compile(block, f"docs/api.md block {number}", "exec"), namespace)
        except Exception as error:
            pytest.fail(f"docs/api.md block {number} failed: {error!r}")
    out = capsys.readouterr().out
    assert out.count("refused:") == 5
    assert (tmp_path / "g5_window.h5").is_file() and (tmp_path / "g5_tol.h5").is_file()
    refusals = [line for line in out.splitlines() if line.startswith("refused: ")]
    reasons = ("normal load F* = 1e+09 > 100", "heights and spacing must both be in metres",
               "G5 has 256 windows of 8 x 8 points, not 300", "a relative error below 1",
               "g5_window.h5 holds another case")
    assert len(refusals) == len(reasons)
    for line, reason in zip(refusals, reasons, strict=True):
        assert reason in line, line
    # the files hold what the examples returned; the ladder's 1x level is the single run
    # computed a second time, and its error the certificate of its levels
    single, estimated = namespace["summary"], namespace["estimated"]
    assert rf.read_run(tmp_path / "g5_window.h5").summary == single
    assert rf.read_run(tmp_path / "g5_tol.h5").summary == estimated
    levels = estimated["levels"]
    assert levels["factor"][0] == 1 and levels["mu_s"][0] == pytest.approx(single["mu_s"],
                                                                            rel=1e-9)
    assert estimated["mu_s"] == levels["mu_s"][-1]
    assert estimated["mu_s_error"] == pytest.approx(certify(
        levels["mu_s"], levels["contact_nodes"][-1], levels["boundary_nodes"][-1]).error)
    steps = namespace["run"].steps
    assert single["mu_s"] == pytest.approx(steps["tangential_force"][-1]
                                           / steps["normal_force"][-1], rel=1e-12)
    assert f"mu_s {single['mu_s']:.3f}, A_r/A_n {single['area_ratio_normal']:.3f}, " in out
    assert (namespace["heavier"].loading.load_star, namespace["from_file"].material.Sy) == (
        0.62, 800e6)


@pytest.mark.mpi
@pytest.mark.fem
def test_run_fem_on_two_ranks_writes_one_file_and_refuses_on_every_rank(tmp_path_factory):
    """Under mpirun every rank calls run_fem: one results file, the same summary on both
    ranks, the same request again read from it, and a refused output raises on both (no rank
    left waiting)."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    assert comm.size == 2, "run under mpirun -n 2"
    folder = comm.bcast(str(tmp_path_factory.mktemp("api")) if comm.rank == 0 else None)
    output = Path(folder) / "run.h5"
    case = rf.fem_case(rf.load_surface("G5"), 0.155, n=8, window="best", normal_only=True)
    summary = rf.run_fem(case, output, progress=lambda record: None)
    areas = comm.allgather(summary["area_ratio_normal"])
    assert areas[0] == areas[1] == rf.read_run(output).summary["area_ratio_normal"]
    written = rf.read_run(output)
    assert written.inputs == case.inputs() and written.sizes["ranks"] == 2
    assert written.summary["area_ratio_normal"] == written.steps["area_ratio"][-1]
    stored = written.summary  # rank 0's summary (the ranks' wall times differ)
    assert rf.run_fem(case, output, progress=lambda record: None) == stored  # read, not run
    assert stored == summary or comm.rank != 0
    heavier = rf.fem_case(rf.load_surface("G5"), 0.3, n=8, window="best", normal_only=True)
    with pytest.raises(rf.InputError, match="holds another case"):
        rf.run_fem(heavier, output)
    comm.barrier()
