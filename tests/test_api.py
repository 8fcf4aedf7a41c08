"""Tests of studies.api, the public Python API, and of docs/api.md, whose examples run here."""

import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import roughfriction as rf
from roughfriction.studies import api

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

    monkeypatch.setattr(api, "surface_on_fem_grid", re_grid)
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
    (0, 16, "window takes 'best' or a window number 1, 2, ..., got 0"),
    ("first", 16, "got 'first'"),
    (True, 16, "got True"),
    (65, 16, "has 64 windows of 16 x 16 points, not 65"),
    ("best", None, "a window needs n below the surface's 128 points"),
    ("best", 3, "integer >= 4"),
])
def test_bad_windows_are_refused_in_one_line(window, n, message):
    with pytest.raises(rf.InputError, match=re.escape(message)):
        rf.fem_case(rf.load_surface("G5"), 0.155, n=n, window=window)


@pytest.mark.fem
@pytest.mark.parametrize("where, message", [
    ("exists.h5", "exists; pass overwrite=True"),
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
    assert out.count("refused:") == 4
    assert (tmp_path / "g5_window.h5").is_file()


@pytest.mark.mpi
@pytest.mark.fem
def test_run_fem_on_two_ranks_writes_one_file_and_refuses_on_every_rank(tmp_path_factory):
    """Under mpirun every rank calls run_fem: one results file, the same summary on both
    ranks, and a refused output raises on both (no rank left waiting)."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    assert comm.size == 2, "run under mpirun -n 2"
    folder = comm.bcast(str(tmp_path_factory.mktemp("api")) if comm.rank == 0 else None)
    output = Path(folder) / "run.h5"
    case = rf.fem_case(rf.load_surface("G5"), 0.155, n=8, window="best", normal_only=True)
    fem = rf.run_fem(case, output, progress=lambda record: None)
    areas = comm.allgather(fem.result.summary()["area_ratio_normal"])
    assert areas[0] == areas[1] == rf.read_run(output).summary["area_ratio_normal"]
    with pytest.raises(rf.InputError, match="exists"):
        rf.run_fem(case, output)
    comm.barrier()
