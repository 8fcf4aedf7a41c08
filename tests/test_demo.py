"""Tests of docs/demo.py, the literate demo "from heights to mu_s": it runs as a script and
prints the mu_s its results file holds."""

import re
import subprocess
import sys
from pathlib import Path

import pytest
import roughfriction as rf

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "docs" / "demo.py"
#: The name of the results file the demo writes into its OUTPUT_DIR.
RESULTS_NAME = "demo_fem.h5"
#: Range [-] a static friction coefficient of the demo's G5-like surface at F* = 0.155 can take.
PLAUSIBLE_MU_S = (0.05, 1.5)


def printed_value(label: str, output: str) -> str:
    """The number printed after ``label`` at the start of a line of ``output`` (as printed)."""
    found = re.search(rf"^\s*{re.escape(label)}\s+([-+0-9.eE]+)\b", output, flags=re.MULTILINE)
    assert found, f"no line '{label} <number>' in the demo's output:\n{output}"
    return found.group(1)


def test_a_printed_value_is_found_only_after_its_label():
    output = "mu_s at F* = 0.155\n  theory mu_s 0.2063  (multi-scale)\n  FEM mu_s    0.1809\n"
    assert printed_value("theory mu_s", output) == "0.2063"
    assert printed_value("FEM mu_s", output) == "0.1809"
    with pytest.raises(AssertionError, match="no line 'LET mu_s <number>'"):
        printed_value("LET mu_s", output)


@pytest.mark.fem
def test_the_demo_runs_and_prints_the_mu_s_of_its_results_file(tmp_path):
    pytest.importorskip("dolfinx")
    output_directory = tmp_path / "demo"
    done = subprocess.run([sys.executable, str(DEMO), str(output_directory)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    theory_mu_s = printed_value("theory mu_s", done.stdout)
    fem_mu_s = printed_value("FEM mu_s", done.stdout)
    for value in (theory_mu_s, fem_mu_s):
        assert PLAUSIBLE_MU_S[0] < float(value) < PLAUSIBLE_MU_S[1], done.stdout
    # the results file, and nothing else, in OUTPUT_DIR
    assert sorted(path.name for path in output_directory.iterdir()) == [RESULTS_NAME]
    run = rf.read_run(output_directory / RESULTS_NAME)
    assert run.converged
    digits = len(fem_mu_s.partition(".")[2])
    assert f"{run.summary['mu_s']:.{digits}f}" == fem_mu_s
    assert isinstance(run.summary["reliable"], bool)
    assert f"reliable: {run.summary['reliable']}" in done.stdout
    # the theory's mu_s is that of the demo's surface, recomputed here from its inputs
    demo = demo_module()
    surface = rf.gaussian_surface(demo.RMS_HEIGHT, n=demo.POINTS_PER_SIDE, spacing=demo.SPACING,
                                  seed=demo.SEED, name="demo")
    theory = rf.theory(surface, demo.LOAD_STAR)
    assert theory_mu_s == f"{theory.mu_s:.{len(theory_mu_s.partition('.')[2])}f}"
    # the file is the demo's case, and the sliding steps printed are the file's
    assert run.inputs == rf.fem_case(surface, demo.LOAD_STAR, n=demo.FEM_CELLS_PER_SIDE,
                                     window="best").inputs()
    sliding = run.steps["phase"] == "tangential"
    printed = [line.split() for line in done.stdout.splitlines()
               if re.fullmatch(r"\s+[-0-9.]+\s+[0-9.]+\s+[0-9.]+\s+\d+/\d+", line)]
    assert len(printed) == sliding.sum() > 0
    ratios = run.steps["tangential_force"][sliding] / run.steps["normal_force"][sliding]
    assert [float(row[1]) for row in printed] == pytest.approx(ratios, abs=5e-5)
    assert [row[3] for row in printed] == [
        f"{slipping}/{contact}" for slipping, contact in
        zip(run.steps["slipping_nodes"][sliding], run.steps["contact_nodes"][sliding],
            strict=True)]
    assert float(printed[-1][1]) == pytest.approx(run.summary["mu_s"], abs=5e-5)


def demo_module():
    """docs/demo.py as a module (its inputs; importing runs nothing)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("demo", DEMO)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
