"""The physics stamp under each generated table of the docs: which physics made the table's rows,
and whether that is this code's.

A bench file's rows carry the short physics version (``studies.physics.physics_stamp``) of the
code that computed them: a ``physics`` column (CSV) or key (a profile's JSON); rows without one
were made before the stamps. Under each table of results ``make docs`` writes one line:

* ``*Physics f3c011b14e00 (this code's).*``: every row by this code's physics;
* ``*Physics 0123456789ab, carried to this code's f3c011b14e00 by docs/bench/equivalence.csv.*``:
  by earlier physics that an equivalence record shows to give the same results;
* ``*Made by earlier physics, not re-run since: ... This code's physics: f3c011b14e00.*``: any
  other row, so that a stale table says so.

An equivalence record (docs/bench/equivalence.csv, a row per change of the physics shown to
leave results unchanged: the old and the new stamp, the cases compared and the largest relative
difference of their mu_s) carries the old stamp to the new one; records chain.
"""

from __future__ import annotations

import csv
import json
import re
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from roughfriction.errors import InputError
from roughfriction.studies.physics import STAMP_LENGTH

#: The equivalence records, in the bench directory.
EQUIVALENCE_FILE = "equivalence.csv"
#: Where the stamp lines say the records are.
EQUIVALENCE_PATH = f"docs/bench/{EQUIVALENCE_FILE}"
EQUIVALENCE_COLUMNS = ("old_physics", "new_physics", "cases", "largest_mu_s_difference")
#: Largest relative difference of mu_s [-] between the old and the new physics that a record
#: may carry forward: round-off (a run repeats bitwise on the same ranks; 1, 2 and 4 ranks
#: agree to 1e-6 on a 12² surface).
EQUIVALENT_MU_S = 1e-6
#: How a stamp line starts when the table is marked stale.
STALE_MARK = "*Made by earlier physics, not re-run since:"
#: A stamp line that claims the rows' physics for this code: the stamps it names.
STAMPED = re.compile(rf"\*Physics (?P<stamps>[0-9a-f]{{{STAMP_LENGTH}}}"
                     rf"(?:, [0-9a-f]{{{STAMP_LENGTH}}})*)[ ,]")
#: A version number in a bench file's ``version`` field ("roughfriction 0.19.0 (e5c0c0e)").
VERSION = re.compile(r"\d+\.\d+(?:\.\d+)?")


@dataclass(frozen=True)
class Physics:
    """This code's physics stamp and the equivalence records that carry older stamps forward.

    Attributes
    ----------
    today : str
        ``physics_stamp(physics_version())`` of this code.
    carried : dict
        Old stamp -> the newer stamp an equivalence record carries it to.
    """

    today: str
    carried: dict = field(default_factory=dict)

    def resolve(self, stamp: str) -> str:
        """The newest stamp the records carry ``stamp`` to (``stamp`` itself without one)."""
        seen = {stamp}
        while stamp != self.today and self.carried.get(stamp, stamp) not in seen:
            stamp = self.carried[stamp]
            seen.add(stamp)
        return stamp

    def is_current(self, stamp: str) -> bool:
        """Whether rows of physics ``stamp`` stand for this code's ("" never does)."""
        return bool(stamp) and self.resolve(stamp) == self.today


def read_equivalence(path: Path) -> dict[str, str]:
    """Old stamp -> new stamp of the equivalence records at ``path`` (none if it is absent).

    Raises
    ------
    InputError
        A record without both stamps or its cases, with a difference above
        :data:`EQUIVALENT_MU_S`, or a second record of the same old stamp.
    """
    if not path.is_file():
        return {}
    with open(path, newline="") as stream:
        records = list(csv.DictReader(stream))
    carried: dict[str, str] = {}
    for line, record in enumerate(records, start=2):
        old, new = (record.get(key) or "" for key in EQUIVALENCE_COLUMNS[:2])
        where = f"{path}, line {line}"
        if not (old and new and (record.get("cases") or "").strip()):
            raise InputError(f"{where}: a record needs {', '.join(EQUIVALENCE_COLUMNS)}")
        try:
            difference = float(record.get("largest_mu_s_difference") or "nan")
        except ValueError:
            difference = float("nan")
        if not abs(difference) <= EQUIVALENT_MU_S:
            raise InputError(f"{where}: mu_s moved by {record.get('largest_mu_s_difference')!r}"
                             f" (at most {EQUIVALENT_MU_S:g} carries a stamp): re-run the tables")
        if old in carried:
            raise InputError(f"{where}: a second record of physics {old}")
        carried[old] = new
    return carried


def code_physics(bench: Path) -> Physics:
    """This code's :class:`Physics`, with the records of ``bench``/:data:`EQUIVALENCE_FILE`."""
    from roughfriction.studies.physics import physics_stamp, physics_version  # reads the code

    return Physics(physics_stamp(physics_version()), read_equivalence(bench / EQUIVALENCE_FILE))


@dataclass(frozen=True)
class RowStamp:
    """Which code made one row of a bench file.

    Attributes
    ----------
    physics : str
        Its physics stamp ("" for a row made before the stamps).
    version : str
        Its roughfriction version ("" where the file does not say).
    """

    physics: str
    version: str


def row_stamps(paths: Sequence[Path]) -> list[RowStamp]:
    """The :class:`RowStamp` of every row of the CSV files (their ``physics`` and ``version``
    columns) and of every JSON file (one row: its ``physics`` and ``version`` keys)."""
    stamps = []
    for path in paths:
        if path.suffix == ".json":
            rows = [json.loads(path.read_text())]
        else:
            with open(path, newline="") as stream:
                rows = list(csv.DictReader(stream))
        stamps += [RowStamp(row.get("physics") or "", row.get("version") or "") for row in rows]
    return stamps


def rows_text(count: int) -> str:
    return f"{count} row" if count == 1 else f"{count} rows"


def stale_parts(stamps: Sequence[RowStamp], physics: Physics) -> list[str]:
    """What made the rows that do not stand for this code's physics: per earlier stamp, and the
    rows without a stamp with their versions, each with its count of rows."""
    stale = Counter(stamp.physics for stamp in stamps
                    if stamp.physics and not physics.is_current(stamp.physics))
    parts = [f"physics {stamp} ({rows_text(count)})" for stamp, count in sorted(stale.items())]
    unstamped = [stamp for stamp in stamps if not stamp.physics]
    if unstamped:
        versions = list(dict.fromkeys(match[0] for stamp in unstamped
                                      if (match := VERSION.search(stamp.version))))
        named = (f", version{'s' if len(versions) > 1 else ''} {', '.join(versions)}"
                 if versions else "")
        parts.append(f"no physics stamp{named} ({rows_text(len(unstamped))})")
    return parts


def stamp_line(stamps: Sequence[RowStamp], physics: Physics) -> str:
    """The line under a table whose rows have ``stamps`` (see the module docstring)."""
    parts = stale_parts(stamps, physics)
    if not parts:
        named = sorted({stamp.physics for stamp in stamps})
        if named == [physics.today]:
            return f"*Physics {physics.today} (this code's).*"
        earlier = ", ".join(stamp for stamp in named if stamp != physics.today)
        if physics.today in named:
            return (f"*Physics {physics.today} (this code's) and {earlier}, carried to it by "
                    f"{EQUIVALENCE_PATH}.*")
        return f"*Physics {earlier}, carried to this code's {physics.today} by {EQUIVALENCE_PATH}.*"
    current = sum(physics.is_current(stamp.physics) for stamp in stamps)
    if current:
        parts.append(f"the other {rows_text(current)}: this code's")
    return f"{STALE_MARK} {'; '.join(parts)}. This code's physics: {physics.today}.*"


def stamp_problem(body: str, physics: Physics) -> str | None:
    """Why the stamp line of a generated table (the last line of its block's ``body``) does not
    hold for this code, or None if it does: a table marked stale holds; one that names physics
    holds if each stamp it names is this code's or carried to it."""
    lines = body.strip().splitlines()
    line = lines[-1] if lines else ""
    if line.startswith(STALE_MARK):
        return None
    claimed = STAMPED.match(line)
    if claimed is None:
        return "no physics stamp under the table (run make docs)"
    earlier = [stamp for stamp in claimed["stamps"].split(", ") if not physics.is_current(stamp)]
    if not earlier:
        return None
    return (f"made by physics {', '.join(earlier)}, not this code's {physics.today}: re-run its "
            f"bench target, or run make docs to mark it stale, or record in {EQUIVALENCE_PATH} "
            "that the change leaves its results unchanged")
