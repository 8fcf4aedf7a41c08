"""Committed run summaries: a finished run as a small JSON file (case, summary, step records,
the preload's interference; no fields), so that figures redraw from a fresh clone.

A summary is named by its run's cache key (``studies.cache.run_key``: case, physics version,
entry format), so the cache finds it like a results file and a physics change leaves it
unfound; :func:`stale_summaries` names those of other physics for the same case.

    roughfriction figure summaries --n 128    # every FEM figure's finished runs -> data/runs/
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
from roughfriction.errors import InputError
from roughfriction.files import atomic_write

#: Layout version of a summary file.
SUMMARY_FORMAT = 1
#: Where the committed summaries live (in the checkout), unless $ROUGHFRICTION_SUMMARIES says.
SUMMARIES = Path(__file__).resolve().parent.parent / "data" / "runs"
SUMMARIES_VARIABLE = "ROUGHFRICTION_SUMMARIES"


def summaries_directory(directory=None) -> Path:
    """The summaries' directory: ``directory``, else $ROUGHFRICTION_SUMMARIES, else
    :data:`SUMMARIES`."""
    return Path(directory or os.environ.get(SUMMARIES_VARIABLE) or SUMMARIES)


def summary_record(run, key: str, physics: str) -> dict:
    """The JSON record of a run read from its results file (``studies.post.RunFile``)."""
    from roughfriction.studies.post import interference

    return {
        "format": SUMMARY_FORMAT, "key": key, "physics": physics, "inputs": run.inputs,
        "summary": run.summary, "converged": run.converged, "message": run.message,
        "steps": {name: np.asarray(values).tolist() for name, values in run.steps.items()},
        "timings": run.timings, "sizes": run.sizes, "note": run.note,
        "interference_m": interference(run),
    }


def write_summary(directory: Path, record: dict) -> Path:
    """Write a summary record as ``<key>.json`` in ``directory`` (atomically); its path."""
    path = Path(directory) / f"{record['key']}.json"
    path.parent.mkdir(parents=True, exist_ok=True)

    def write(temporary) -> None:
        Path(temporary).write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
    atomic_write(path, write)
    return path


def read_summary(path: Path):
    """A summary file as a ``studies.post.RunFile`` without maps (``interference_m`` kept)."""
    from roughfriction.studies.post import RunFile

    try:
        record = json.loads(Path(path).read_text())
    except (OSError, ValueError) as error:
        raise InputError(f"cannot read run summary {path}: {error}") from None
    if record.get("format") != SUMMARY_FORMAT:
        raise InputError(f"{path} is not a run summary of format {SUMMARY_FORMAT}")
    steps = {name: np.asarray(values) for name, values in record["steps"].items()}
    steps["phase"] = steps["phase"].astype(str)
    return RunFile(path=Path(path), inputs=record["inputs"], summary=record["summary"],
                   converged=record["converged"], message=record["message"], steps=steps,
                   maps={}, timings=record["timings"], sizes=record["sizes"],
                   note=record["note"], interference_m=record["interference_m"])


def summary_path(case, physics: str, directory=None) -> Path:
    """Where the committed summary of ``case`` under ``physics`` would be
    (:func:`summaries_directory`)."""
    from roughfriction.studies.cache import run_key

    return summaries_directory(directory) / f"{run_key(case, physics)}.json"


def stale_summaries(cases, physics: str, directory=None) -> int:
    """How many committed summaries answer one of ``cases`` under another physics version."""
    inputs = [json.dumps(case.inputs(), sort_keys=True) for case in cases]
    stale = 0
    for path in summaries_directory(directory).glob("*.json"):
        try:
            record = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        if (record.get("physics") != physics
                and json.dumps(record.get("inputs"), sort_keys=True) in inputs):
            stale += 1
    return stale
