"""Tables of result rows as CSV text, written whole or not at all (the figure-scenes table of
``make docs``, the benchmark tables)."""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path

from roughfriction.files import atomic_write


def csv_text(rows: Sequence[dict], columns: Sequence[str]) -> str:
    """Rows as CSV text: floats to 10 significant digits, None as an empty field, quoted
    where needed (messages contain commas)."""
    def cell(value):
        if value is None:
            return ""
        return f"{value:.10g}" if isinstance(value, float) else value

    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([cell(row.get(column)) for column in columns])
    return buffer.getvalue()


def write_text(path: Path, text: str) -> None:
    """Write a file atomically (temporary name, then rename)."""
    atomic_write(Path(path), lambda temporary: Path(temporary).write_text(text))
