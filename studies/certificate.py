"""The error certificate of the finest level of a mesh ladder: an estimate of the error of the
value reported, not of the level below it.

At sliding inception mu_s ~ tau_c A_s / F_n, so the FEM's mu_s is as good as its contact area,
which a mesh resolves node by node. The certificate has two terms, added in quadrature:

* the **ladder term** C_d |v_L - v_(L-1)|: the part of the last change between levels that the
  finest level may still carry (C_d < 1: the change shrinks fast once patches are resolved);
* the **resolution term** C_b |v_L| sqrt(N_b) / N: the finest level's contact of N nodes, N_b of
  them on a patch boundary, each boundary node's share of area known to about C_b of a node,
  with independent signs. It is what the ladder term misses when two levels agree by chance,
  and it shrinks as a surface holds more, better resolved patches.

The factors are fitted on the calibration set (uniform 16^2-window ladders to an 8x reference,
``docs/bench/calibration_ladders.csv``; docs/verification.md states the fit, its coverage and
where it does not apply).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

#: Share of the last change between levels the finest value may still carry [-].
LADDER_FACTOR = 0.0709
#: Uncertainty of a boundary node's share of the contact, in nodes [-].
BOUNDARY_FACTOR = 0.7959


@dataclass(frozen=True)
class Certificate:
    """The certified error of the finest of a ladder's values.

    Attributes
    ----------
    values : tuple of float
        The quantity on each level, coarse to fine [-].
    ladder_term : float
        C_d |v_L - v_(L-1)| [-].
    resolution_term : float
        C_b |v_L| sqrt(N_b) / N [-] (inf without contact nodes).
    contact_nodes, boundary_nodes : int
        N and N_b of the finest level [-].
    """

    values: tuple
    ladder_term: float
    resolution_term: float
    contact_nodes: int
    boundary_nodes: int

    @property
    def error(self) -> float:
        """The certified error of the finest value, the two terms in quadrature [-]."""
        return math.hypot(self.ladder_term, self.resolution_term)

    @property
    def relative_error(self) -> float:
        """error / |finest value| [-] (inf for a zero value)."""
        finest = abs(self.values[-1])
        return self.error / finest if finest > 0 else math.inf


def certify(values, contact_nodes: int, boundary: int, ladder_factor: float = LADDER_FACTOR,
            boundary_factor: float = BOUNDARY_FACTOR) -> Certificate:
    """The certificate of the finest of ``values`` (two or more levels, coarse to fine) whose
    contact holds ``contact_nodes`` nodes, ``boundary`` of them on a patch boundary."""
    values = tuple(float(value) for value in values)
    if len(values) < 2:
        raise ValueError(f"a certificate needs 2 levels or more, got {len(values)}")
    ladder_term = ladder_factor * abs(values[-1] - values[-2])
    resolution_term = (boundary_factor * abs(values[-1]) * math.sqrt(boundary) / contact_nodes
                       if contact_nodes > 0 else math.inf)
    return Certificate(values, ladder_term, resolution_term, int(contact_nodes), int(boundary))


#: The judged calibration table quoted with every certificate (in the checkout).
CALIBRATION_TABLE = Path(__file__).resolve().parent.parent / "docs" / "bench" / "calibration.csv"


def coverage_statement(table: Path = CALIBRATION_TABLE) -> str:
    """One line on what the certificate is and how often it covered the reference on the
    calibration set ``table`` (``benchmarks.calibration``'s judged table); without the table,
    where to read it."""
    what = ("the error is certified from the last two levels' difference and the finest "
            "level's contact resolution (studies/certificate.py)")
    try:
        with open(table, newline="") as file:
            rows = list(csv.DictReader(file))
    except OSError:
        rows = []
    if not rows:
        return f"{what}; its calibration is in docs/verification.md"
    covered = sum(row["covered"] == "True" for row in rows)
    return (f"{what}; on the calibration set it covered {covered} of {len(rows)} cases against "
            f"uniform references up to {max(int(row['reference_factor']) for row in rows)}x "
            f"({table.name})")
