"""Committed run summaries: a finished run as a small JSON file (case, summary, step records,
the preload's interference; no fields), so that figures redraw from a fresh clone.

A summary is named by its run's cache key (``studies.cache.run_key``: case, physics version,
entry format), so the cache finds it like a results file and a physics change leaves it
unfound; :func:`stale_summaries` names those of other physics for the same case. They are read
back by ``studies.post.read_run`` (a ``.json`` path).

    roughfriction figure summaries --n 128    # every FEM figure's finished runs -> data/runs/
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
from roughfriction.files import atomic_write
from roughfriction.studies.post import SUMMARY_FORMAT, interference

#: Where the committed summaries live (in the checkout), unless $ROUGHFRICTION_SUMMARIES says.
SUMMARIES = Path(__file__).resolve().parent.parent / "data" / "runs"
SUMMARIES_VARIABLE = "ROUGHFRICTION_SUMMARIES"


def summaries_directory(directory=None) -> Path:
    """The summaries' directory: ``directory``, else $ROUGHFRICTION_SUMMARIES, else
    :data:`SUMMARIES`."""
    return Path(directory or os.environ.get(SUMMARIES_VARIABLE) or SUMMARIES)


def summary_record(run, key: str, physics: str) -> dict:
    """The JSON record of a run read from its results file (``studies.post.RunFile``)."""
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


def summary_file(key: str, directory=None) -> Path:
    """Where the committed summary of the run with cache key ``key`` (``studies.cache.run_key``)
    would be (:func:`summaries_directory`)."""
    return summaries_directory(directory) / f"{key}.json"


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
