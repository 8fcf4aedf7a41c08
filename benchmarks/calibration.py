"""The certificate (``studies.certificate``) judged on the calibration set, and its factors fitted.

    python -m benchmarks.calibration docs/bench/calibration_ladders.csv \
        [docs/bench/calibration.csv [VARIANT_LADDERS]]

The set's ladders (``benchmarks.calibration_set``: uniform levels 1x, 2x, 4x, 8x of 16^2
windows) give per case (window and load) a reference: the finest level, mu_ref, with
s_ref = |mu_ref - mu_(ref-1)| its last difference. A level L is judged when the reference is
at least two levels finer (else s_ref is its own error). With the certificate's error e of
mu_L, over the set (the issue's criteria):

* covered: |mu_L - mu_ref| <= e + s_ref, in at least :data:`COVERAGE` of the cases;
* never badly overconfident: |mu_L - mu_ref| <= 3 e + s_ref in every case;
* sharp: the median of e / max(|mu_L - mu_ref|, :data:`SHARPNESS_FLOOR` mu_L) at most
  :data:`SHARPNESS`.

The factors (C_d, C_b) are chosen on a grid as the sharpest pair that meets the first two;
the leave-one-out coverage (each case judged with the factors fitted without it) says how
much of that is fit.
"""

from __future__ import annotations

import csv
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from roughfriction.studies.certificate import BOUNDARY_FACTOR, LADDER_FACTOR, certify

from benchmarks.calibration_set import write_rows

#: Share of the cases the certificate must cover [-].
COVERAGE = 0.9
#: Largest median of e / max(actual error, floor) [-].
SHARPNESS = 3.0
#: Floor of the actual error in the sharpness ratio, relative to mu_s [-].
SHARPNESS_FLOOR = 0.005
#: A case needs a finer reference when its last difference exceeds this share of mu_s [-].
REFERENCE_SPREAD = 0.01
#: Factors tried by the fit [-].
FACTOR_GRID = np.round(np.geomspace(0.01, 2.0, 47), 4)
#: Columns of the judged table.
COLUMNS = ("surface", "window", "n", "load_star", "level", "factor", "mu_s", "mu_coarse",
           "contact_nodes", "boundary_nodes", "reference_factor", "mu_reference", "s_reference",
           "mu_s_error", "ladder_term", "resolution_term", "actual_error", "covered",
           "overconfident", "sharpness", "needs_finer_reference", "physics")


@dataclass(frozen=True)
class Case:
    """One judged level of one case: the value, the level below, the finest level's contact
    counts and the reference (finest level) with its last difference [-]."""

    label: tuple
    level: int
    mu_s: float
    mu_coarse: float
    contact_nodes: int
    boundary_nodes: int
    reference_factor: int
    mu_reference: float
    s_reference: float
    physics: str

    @property
    def actual_error(self) -> float:
        """|mu_L - mu_ref| [-]."""
        return abs(self.mu_s - self.mu_reference)


def ladder_levels(path: Path | None) -> dict[tuple, dict[int, dict]]:
    """The rows of a ladder table by case (surface, window, n, F*) and level (none without a
    table)."""
    if path is None:
        return {}
    with open(path, newline="") as file:
        rows = list(csv.DictReader(file))
    ladders: dict[tuple, dict[int, dict]] = {}
    for row in rows:
        label = (row["surface"], int(row["window"]), int(row["n"]), float(row["load_star"]))
        ladders.setdefault(label, {})[int(row["level"])] = row
    return ladders


def read_cases(path: Path, variant: Path | None = None) -> list[Case]:
    """The judged cases of a ladder table (``benchmarks.calibration_set.COLUMNS``): every
    converged ladder's levels L <= reference - 2 (a ladder with an unconverged level is left
    out). With a ``variant`` table (the same columns, e.g. ``benchmarks.blend_zone``'s), the
    levels it holds are judged instead, their values and the level below taken from it where
    it has them; the reference stays the ladder's."""
    variants = ladder_levels(variant)
    cases = []
    for label, by_level in ladder_levels(path).items():
        levels = [by_level[level] for level in sorted(by_level)]
        if any(row["converged"] != "True" or row["mu_s"] == "" for row in levels):
            continue
        mu = [float(row["mu_s"]) for row in levels]
        judged = by_level | variants.get(label, {})
        for level in range(1, len(levels) - 2):
            if variant is not None and level not in variants.get(label, {}):
                continue
            row, below = judged[level], judged[level - 1]
            if row["converged"] != "True" or row["mu_s"] == "":
                continue
            cases.append(Case(label, level, float(row["mu_s"]), float(below["mu_s"]),
                              int(row["contact_nodes"]), int(row["boundary_nodes"]),
                              int(levels[-1]["factor"]), mu[-1], abs(mu[-1] - mu[-2]),
                              row["physics"]))
    return cases


def provisional_cases(path: Path, variant: Path | None = None) -> list[Case]:
    """Every converged ladder's 2x level (the ``variant``'s where given, :func:`read_cases`)
    judged against its 4x level taken as exact (s_ref = 0): a first look while the 8x
    references run, not a calibration."""
    variants = ladder_levels(variant)
    cases = []
    for label, levels in ladder_levels(path).items():
        variant_levels = variants.get(label, {})
        if variant is not None and 1 not in variant_levels:
            continue
        rows = [levels.get(0), variant_levels.get(1, levels.get(1)), levels.get(2)]
        if any(row is None or row["converged"] != "True" or row["mu_s"] == "" for row in rows):
            continue
        mu = [float(row["mu_s"]) for row in rows]
        cases.append(Case(label, 1, mu[1], mu[0], int(rows[1]["contact_nodes"]),
                          int(rows[1]["boundary_nodes"]), 4, mu[2], 0.0, rows[1]["physics"]))
    return cases


def judge(case: Case, ladder_factor: float, boundary_factor: float) -> dict:
    """The certificate of one case with these factors, and the three checks."""
    certificate = certify((case.mu_coarse, case.mu_s), case.contact_nodes, case.boundary_nodes,
                          ladder_factor, boundary_factor)
    error, actual = certificate.error, case.actual_error
    return {"mu_s_error": error, "ladder_term": certificate.ladder_term,
            "resolution_term": certificate.resolution_term, "actual_error": actual,
            "covered": actual <= error + case.s_reference,
            "overconfident": actual > 3.0 * error + case.s_reference,
            "sharpness": error / max(actual, SHARPNESS_FLOOR * abs(case.mu_s))}


@dataclass(frozen=True)
class Verdict:
    """The set's three measures with one pair of factors."""

    ladder_factor: float
    boundary_factor: float
    covered: int
    overconfident: int
    median_sharpness: float
    cases: int

    @property
    def passes(self) -> bool:
        """Coverage, no overconfident case and sharpness all met."""
        return (self.covered >= COVERAGE * self.cases and self.overconfident == 0
                and self.median_sharpness <= SHARPNESS)


def verdict(cases: list[Case], ladder_factor: float, boundary_factor: float) -> Verdict:
    """Judge every case with one pair of factors."""
    judged = [judge(case, ladder_factor, boundary_factor) for case in cases]
    return Verdict(ladder_factor, boundary_factor, sum(j["covered"] for j in judged),
                   sum(j["overconfident"] for j in judged),
                   float(np.median([j["sharpness"] for j in judged])) if judged else math.nan,
                   len(cases))


def fit(cases: list[Case], grid=FACTOR_GRID) -> Verdict | None:
    """The sharpest pair of factors on ``grid`` that covers :data:`COVERAGE` of the cases with
    none overconfident (None if no pair does)."""
    feasible = [one for one in (verdict(cases, c_d, c_b) for c_d in grid for c_b in grid)
                if one.covered >= COVERAGE * one.cases and one.overconfident == 0]
    return min(feasible, key=lambda one: one.median_sharpness, default=None)


def leave_one_out(cases: list[Case], grid=FACTOR_GRID) -> int:
    """Cases covered by the factors fitted on the other cases (a case whose fit fails counts
    as not covered)."""
    covered = 0
    for index, case in enumerate(cases):
        fitted = fit(cases[:index] + cases[index + 1:], grid)
        if fitted is not None:
            covered += judge(case, fitted.ladder_factor, fitted.boundary_factor)["covered"]
    return covered


def table_rows(cases: list[Case], ladder_factor: float = LADDER_FACTOR,
               boundary_factor: float = BOUNDARY_FACTOR) -> list[dict]:
    """The judged table, a row per case, with the factors the code uses."""
    rows = []
    for case in cases:
        surface, window, n, load = case.label
        rows.append({"surface": surface, "window": window, "n": n, "load_star": load,
                     "level": case.level, "factor": 2**case.level, "mu_s": case.mu_s,
                     "mu_coarse": case.mu_coarse, "contact_nodes": case.contact_nodes,
                     "boundary_nodes": case.boundary_nodes,
                     "reference_factor": case.reference_factor,
                     "mu_reference": case.mu_reference, "s_reference": case.s_reference,
                     **judge(case, ladder_factor, boundary_factor),
                     "needs_finer_reference":
                         case.s_reference > REFERENCE_SPREAD * abs(case.mu_reference),
                     "physics": case.physics})
    return rows


def write_table(path: Path, rows: list[dict]) -> None:
    """Write the judged rows as CSV (atomically), numbers to 6 significant digits."""
    write_rows(path, rows, COLUMNS, digits=6)


def main(argv: list[str] | None = None) -> int:
    """Judge the set of the ladder table given first with the code's factors, write the judged
    table (second argument, default docs/bench/calibration.csv) and print the three measures,
    the fitted factors and the leave-one-out coverage; a third argument judges the levels of
    that table (:func:`read_cases`' ``variant``) instead."""
    argv = sys.argv[1:] if argv is None else argv
    ladders = Path(argv[0] if argv else "docs/bench/calibration_ladders.csv")
    output = Path(argv[1] if len(argv) > 1 else "docs/bench/calibration.csv")
    variant = Path(argv[2]) if len(argv) > 2 else None
    cases = read_cases(ladders, variant)
    write_table(output, table_rows(cases))
    if cases:
        report(cases, "against the finest level")
    else:
        print(f"{ladders}: no case has a reference two levels finer than its 2x level yet")
    first_look = provisional_cases(ladders, variant)
    if first_look:
        report(first_look, "provisional: 2x against 4x taken as exact")
    return 0


def report(cases: list[Case], what: str) -> None:
    """Print the three measures with the code's factors, the fitted factors and the
    leave-one-out coverage of ``cases``."""
    used = verdict(cases, LADDER_FACTOR, BOUNDARY_FACTOR)
    print(f"{what}, {used.cases} cases; with C_d = {LADDER_FACTOR}, C_b = {BOUNDARY_FACTOR}: "
          f"covered {used.covered}, overconfident {used.overconfident}, median sharpness "
          f"{used.median_sharpness:.3g} ({'passes' if used.passes else 'fails'})")
    fitted = fit(cases)
    if fitted is None:
        print("  no pair of factors on the grid covers 90 % with none overconfident")
    else:
        print(f"  fitted: C_d = {fitted.ladder_factor}, C_b = {fitted.boundary_factor}: covered "
              f"{fitted.covered}, median sharpness {fitted.median_sharpness:.3g}; "
              f"leave-one-out covered {leave_one_out(cases)} of {len(cases)}")


if __name__ == "__main__":
    sys.exit(main())
