"""The Krylov method of the non-symmetric sliding solves, compared on one FEM run.

    python -m benchmarks.krylov CSV SURFACE LOAD N [RANKS [VARIANT ...]]

Runs ``roughfriction fem SURFACE --load LOAD --n N`` under ``mpirun -n RANKS`` once per
variant, each a set of PETSc options under the iterative solver's prefix (the options the
solver sets, ``solver.linear.default_options``, yield to them), and appends a row per variant
to CSV: mu_s, steps, Newton and Krylov iterations, the slowest step's wall time, the run's
wall time and peak memory. The symmetric solves stay CG; an option ``ksp_type`` sets the method
of the non-symmetric ones (``LinearSolver._use``).
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

#: Prefix of the iterative solver's PETSc options (``solver.linear.LinearSolver``).
PREFIX = "-roughfriction_iterative_"
#: Variants by name: PETSc options under :data:`PREFIX` ("" is the code's default).
VARIANTS = {
    "default": "",
    "gmres30": "ksp_gmres_restart 30",
    "gmres60": "ksp_gmres_restart 60",
    "lgmres30": "ksp_type lgmres ksp_gmres_restart 30",
    "bcgsl4": "ksp_type bcgsl ksp_bcgsl_ell 4",
}
#: The variants run when none is named (BCGSL stalls Newton at G1's inception: not by default).
DEFAULT_VARIANTS = ("default", "gmres30", "gmres60", "lgmres30")
COLUMNS = ("variant", "options", "surface", "load_star", "n", "ranks", "exit_status", "mu_s",
           "steps", "newton_iterations", "krylov_iterations", "slowest_step_s", "wall_s",
           "peak_memory_gb")


def petsc_options(variant: str) -> str:
    """The PETSC_OPTIONS string of ``variant`` (each option under :data:`PREFIX`)."""
    words = VARIANTS[variant].split()
    return " ".join(PREFIX + word if index % 2 == 0 else word
                    for index, word in enumerate(words))


def run_variant(variant: str, surface: str, load: float, n: int, ranks: int) -> dict:
    """Run the case once with ``variant``'s options; its row (:data:`COLUMNS`)."""
    with tempfile.TemporaryDirectory() as directory:
        output = Path(directory) / "run.h5"
        program = Path(sys.executable).with_name("roughfriction")
        command = ["mpirun", "-n", str(ranks), "--oversubscribe", str(program), "fem", surface,
                   "--load", str(load), "--n", str(n), "--output", str(output)]
        environment = dict(os.environ, PETSC_OPTIONS=petsc_options(variant))
        start = time.perf_counter()
        status = subprocess.run(command, env=environment, stdout=subprocess.DEVNULL).returncode
        wall = time.perf_counter() - start
        row = {"variant": variant, "options": VARIANTS[variant], "surface": surface,
               "load_star": load, "n": n, "ranks": ranks, "exit_status": status,
               "wall_s": wall}
        if output.is_file():
            with h5py.File(output) as results:
                steps = results["steps"]
                summary = json.loads(results.attrs["summary"])
                row |= {"mu_s": summary.get("mu_s"),
                        "steps": len(steps["wall_s"]),
                        "newton_iterations": int(np.sum(steps["newton_iterations"])),
                        "krylov_iterations": int(np.sum(steps["krylov_iterations"])),
                        "slowest_step_s": float(np.max(np.diff(steps["wall_s"][:],
                                                               prepend=0.0))),
                        "peak_memory_gb": results["sizes"].attrs["peak_memory_gb"]}
        return row


def append_row(path: Path, row: dict) -> None:
    """Append ``row`` to the CSV at ``path`` (a header first if it is new)."""
    new = not path.is_file()
    with open(path, "a", newline="") as file:
        writer = csv.DictWriter(file, COLUMNS, extrasaction="ignore")
        if new:
            writer.writeheader()
        writer.writerow(row)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) < 4:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    path, surface, load, n = Path(argv[0]), argv[1], float(argv[2]), int(argv[3])
    ranks = int(argv[4]) if len(argv) > 4 else 2
    for variant in argv[5:] or DEFAULT_VARIANTS:
        if variant not in VARIANTS:
            print(f"unknown variant {variant!r}: one of {', '.join(VARIANTS)}", file=sys.stderr)
            return 2
        row = run_variant(variant, surface, load, n, ranks)
        append_row(path, row)
        print(", ".join(f"{key}={row.get(key, '')}" for key in COLUMNS if key != "options"),
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
