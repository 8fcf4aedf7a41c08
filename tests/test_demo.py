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
