"""``fem --tol``/``--refine`` levels: contact-adaptive by default, uniform on request."""

import json
from types import SimpleNamespace

import h5py
import pytest
from roughfriction.errors import InputError
from roughfriction.scripts.cli import main as cli_main
from roughfriction.scripts.fem import ladder_limits, run_labels
from roughfriction.studies.certificate import certify

pytest.importorskip("dolfinx")


def main(argv):
    """``roughfriction fem ARGV``."""
    return cli_main(["fem", *argv])


#: G5's first 8 x 8 window at F* = 0.155: a few patches, levels 1x and 2x.
WINDOW = ["G5", "--n", "8", "--window", "1", "--load", "0.155", "--json"]


@pytest.mark.fem
def test_the_levels_are_contact_adaptive_by_default(tmp_path, capsys):
    output = tmp_path / "run.h5"
    assert main([*WINDOW, "--refine", "--output", str(output)]) == 0
    summary = json.loads(capsys.readouterr().out)
    levels = summary["levels"]
    assert summary["error_ladder"] == "adaptive" and summary["converged"]
    assert levels["factor"] == [1, 2] and len(levels["zone_escaped"]) == 2
    assert levels["mu_s"][-1] == summary["mu_s"] and summary["mu_s_error"] > 0
    with h5py.File(output) as h5:
        assert json.loads(h5.attrs["summary"]) == summary
        inputs = json.loads(h5.attrs["inputs"])
        assert h5["maps/contact_normal"].shape == (16, 16)
    # the finest level meshes the own 8 x 8 surface refined once in a zone of own cells
    assert inputs["surface"]["n"] == 8
    refinement = inputs["mesh"]["refinement"]
    assert refinement["level"] == 1 and refinement["zone_size"] == 8
    assert refinement["zone_cells"] > 0
    with h5py.File(tmp_path / "run_coarse.h5") as h5:
        assert json.loads(h5.attrs["summary"])["mu_s"] == summary["mu_s_coarse"]
    # the coarse file is level 0, and the error is the certificate of the two levels
    assert summary["mu_s_coarse"] == levels["mu_s"][0]
    assert summary["mu_s_error"] == pytest.approx(certify(
        levels["mu_s"], levels["contact_nodes"][-1], levels["boundary_nodes"][-1]).error)


@pytest.mark.fem
def test_the_ladder_speaks_plainly(tmp_path, capsys):
    """A header per level (which of how many, factor, dofs, memory, predicted time after the
    first); the error also relative; every level's cut steps; the results file named once;
    what the estimate is and its measured coverage."""
    output = tmp_path / "run.h5"
    assert main([*WINDOW, "--tol", "0.5", "--max-level", "2", "--output", str(output)]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    headers = [line for line in captured.err.splitlines() if line.startswith("level ")]
    assert headers[0].startswith("level 0 of at most 2 (1x mesh): ")
    assert " reduced dofs, ~" in headers[0] and " GB" in headers[0]
    assert len(headers) == len(summary["levels"]["factor"])
    assert all(line.endswith(" min") for line in headers[1:])
    assert summary["mu_s_error_relative"] == pytest.approx(summary["mu_s_error"]
                                                           / summary["mu_s"])
    cuts = summary["levels"]["cut_steps"]
    assert len(cuts) == len(headers) and summary["cut_steps_all_levels"] == sum(cuts)
    assert captured.err.count(f"results: {output}") == 1
    assert "certified" in summary["error_estimate"]
    assert f"note: {summary['error_estimate']}" in captured.err


@pytest.mark.fem
def test_a_uniform_ladder_is_an_option_and_is_named_apart(tmp_path, capsys):
    output = tmp_path / "run.h5"
    assert main([*WINDOW, "--refine", "--ladder", "uniform", "--output", str(output)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["error_ladder"] == "uniform"
    assert summary["levels"]["zone_escaped"] == [False, False]
    with h5py.File(output) as h5:
        inputs = json.loads(h5.attrs["inputs"])
    assert inputs["surface"]["n"] == 16 and "refinement" not in inputs["mesh"]


def arguments(**given):
    """The ladder flags of a command line, unset unless given."""
    names = ("tol", "refine", "ladder", "max_level", "max_memory", "max_time")
    return SimpleNamespace(**{name: given.get(name) for name in names})


def test_the_ladder_option_reaches_the_limits_and_the_results_name():
    assert ladder_limits(arguments(tol=0.03)).ladder == "adaptive"
    uniform = arguments(tol=0.03, ladder="uniform")
    assert ladder_limits(uniform).ladder == "uniform"
    assert run_labels(uniform) == ("tol0.03_L3", "uniform")
    assert run_labels(arguments(tol=0.03, ladder="adaptive")) == ("tol0.03_L3",)
    with pytest.raises(InputError, match="--ladder applies to --tol or --refine"):
        ladder_limits(arguments(ladder="uniform"))


def test_an_unknown_ladder_is_a_command_line_error(capsys):
    with pytest.raises(SystemExit):
        main([*WINDOW, "--tol", "0.1", "--ladder", "octree"])
    assert "invalid choice: 'octree'" in capsys.readouterr().err


def model_events(monkeypatch) -> list[str]:
    """"built" and "freed", in order, for every FEM model (``Equilibrium``) of the test."""
    from roughfriction.solver.equilibrium import Equilibrium

    events = []
    build, free = Equilibrium.__init__, Equilibrium.destroy

    def built(self, *args, **kwargs):
        build(self, *args, **kwargs)
        events.append("built")

    def freed(self):
        free(self)
        events.append("freed")
    monkeypatch.setattr(Equilibrium, "__init__", built)
    monkeypatch.setattr(Equilibrium, "destroy", freed)
    return events


@pytest.mark.fem
def test_each_level_frees_its_model_before_the_next_is_built(tmp_path, monkeypatch, capsys):
    """petsc4py does not free PETSc objects that reference each other: a level's matrices and
    solver are freed once it has run, so that the next level's peak is its own, and a single
    run frees its model too (a batch of API calls in one process does not grow)."""
    events = model_events(monkeypatch)
    assert main([*WINDOW, "--refine", "--output", str(tmp_path / "run.h5")]) == 0
    assert json.loads(capsys.readouterr().out)["levels"]["factor"] == [1, 2]
    assert events == ["built", "freed", "built", "freed"]
    events.clear()
    assert main([*WINDOW, "--output", str(tmp_path / "once.h5")]) == 0
    assert events == ["built", "freed"]
