"""The HDF5 results file of a FEM run, with its provenance (package versions, git revision).

Output, not physics: this module is outside the run cache's physics key
(:data:`studies.cache.PHYSICS_MODULES`), so changing how a run is written keeps the cached runs;
a change of what a file holds bumps :data:`FILE_FORMAT`, which is part of every cache key. The
file is read back by :func:`studies.post.read_run`.
"""

from __future__ import annotations

import json
import subprocess
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from roughfriction.case import FemCase
from roughfriction.files import agreed, atomic_write
from roughfriction.solver.results import FemResult, StepRecord
from roughfriction.studies.physics import physics_version

#: Layout version of a results file (bumped when what a file holds changes; it keys the cache).
FILE_FORMAT = 2


def package_versions() -> dict:
    """Versions of roughfriction and of the numerical stack (recorded with every result)."""
    import dolfinx
    import gmsh
    import h5py
    import petsc4py
    import scipy
    import ufl
    from roughfriction.version import __version__

    modules = {"dolfinx": dolfinx, "ufl": ufl, "petsc4py": petsc4py, "gmsh": gmsh, "numpy": np,
               "scipy": scipy, "h5py": h5py}
    return {"roughfriction": __version__} | {name: module.__version__
                                              for name, module in modules.items()}


def git_revision() -> str:
    """The source tree's git commit (with "-dirty" if modified), or "unknown"."""
    root = Path(__file__).resolve().parent.parent  # the checkout (studies/ is in it)
    try:
        revision = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=root,
                                  capture_output=True, text=True, timeout=10, check=True)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return revision.stdout.strip()


def write_hdf5(path: Path, inputs: dict, result: FemResult, maps: dict, note: str = "",
               extra: dict | None = None, request: str = "") -> None:
    """Write a run to HDF5 atomically (temporary file, then rename). Call on one rank.

    Layout: root attributes ``inputs``, ``summary`` (JSON), ``versions``, ``git``,
    ``physics`` (``studies.cache.physics_version``), ``request``, ``converged``, ``message``;
    group ``steps`` with one dataset per :class:`StepRecord` field; groups ``timings`` and
    ``sizes`` as attributes; group ``maps`` with N x N contact maps.

    Parameters
    ----------
    path : pathlib.Path
        Destination file.
    inputs : dict
        The case (``FemCase.inputs()``).
    result : FemResult
        The run.
    maps : dict
        Name -> N x N array (e.g. contact at the end of preload and at inception).
    note : str
        How the run was obtained, if not the usual way (root attribute ``note``).
    extra : dict, optional
        Added to the summary (e.g. the discretisation error estimate ``mu_s_error``).
    request : str
        What the command asked for, as a digest (``scripts.fem.request_digest``): a re-run of
        the same command finds its result by it.
    """
    summary = {**result.summary(), **(extra or {})}
    provenance = {"request": request, "note": note}
    atomic_write(Path(path), lambda temporary: _write_hdf5(temporary, inputs, result, summary,
                                                           maps, provenance))


def _write_hdf5(path, inputs: dict, result: FemResult, summary: dict, maps: dict,
                provenance: dict) -> None:
    import h5py

    # Provenance first: importing the FEM stack while the file is open leaves it locked.
    versions, revision, physics = package_versions(), git_revision(), physics_version()
    with h5py.File(path, "w") as h5:
        h5.attrs["inputs"] = json.dumps(inputs)
        h5.attrs["summary"] = json.dumps(summary)
        h5.attrs["versions"] = json.dumps(versions)
        h5.attrs["git"] = revision
        h5.attrs["physics"] = physics
        h5.attrs["request"] = provenance["request"]
        h5.attrs["converged"] = result.converged
        h5.attrs["message"] = result.message
        if provenance["note"]:
            h5.attrs["note"] = provenance["note"]
        steps = h5.create_group("steps")
        for field in fields(StepRecord):
            values = [getattr(record, field.name) for record in result.records]
            steps.create_dataset(field.name, data=np.array(values, dtype="S" if field.type == "str"
                                                           else None))
        for name, values in (("timings", result.timings), ("sizes", result.sizes)):
            group = h5.create_group(name)
            for key, value in values.items():
                group.attrs[key] = value
        grid_maps = h5.create_group("maps")
        for name, values in maps.items():
            grid_maps.create_dataset(name, data=values)


def run_version(path: Path) -> str:
    """The code that wrote a results file, as ``roughfriction --version`` prints it, with the
    git revision: ``roughfriction 0.19.0 (a53d6e2)``; "unknown" where the file does not say."""
    import h5py

    with h5py.File(path, "r") as h5:
        versions = json.loads(h5.attrs.get("versions", "{}"))
        revision = h5.attrs.get("git", "unknown")
    return f"roughfriction {versions.get('roughfriction', 'unknown')} ({revision})"


@dataclass(frozen=True)
class StoredRun:
    """What a results file says about itself, read without its steps and maps.

    Attributes
    ----------
    request : str
        The command's request digest ("" when the file was not written by ``fem``).
    physics : str
        The physics version of the code that wrote it ("" for files older than the record).
    converged : bool
        Whether the run converged.
    summary : dict
        The run's JSON summary, as the command printed it.
    """

    request: str
    physics: str
    converged: bool
    summary: dict


def stored_run(path: Path) -> StoredRun:
    """The :class:`StoredRun` of the results file at ``path``."""
    import h5py

    with h5py.File(path, "r") as h5:
        attrs = h5.attrs
        return StoredRun(str(attrs.get("request", "")), str(attrs.get("physics", "")),
                         bool(attrs.get("converged", False)),
                         json.loads(attrs.get("summary", "{}")))


def save_run(path: Path, case: FemCase, fem_run, comm, note: str = "",
             extra: dict | None = None, request: str = "") -> None:
    """Write a run's results file (rank 0 writes, atomically; every rank waits for it, and a
    failure to write raises :class:`~roughfriction.errors.InputError` on every rank).

    The file holds the case's inputs, the records and summary, and the surface maps of the
    run plus ``surface_heights``, the N x N heights of the FEM grid [m] (for the interference
    and for drawing maps over the topography), and the root attribute ``note`` if given.

    Parameters
    ----------
    path : pathlib.Path
        Destination HDF5 file.
    case : FemCase
        The case that was run.
    fem_run : solver.run.FemRun
        Its outcome.
    comm : mpi4py.MPI.Comm
        The communicator the run used; call on every rank.
    note : str
        How the run was obtained, if not the usual way (e.g. on a standalone path after its
        shared normal path failed, see :mod:`roughfriction.studies.cache`).
    extra : dict, optional
        Added to the summary (``fem``: the psi of the meshed surface; with ``--tol`` or
        ``--refine`` the discretisation error estimate and the per-level columns ``levels``,
        :meth:`studies.refinement.Ladder.summary`).
    request : str
        The command's request digest (:func:`write_hdf5`).
    """
    def write() -> None:
        if comm.rank == 0:
            maps = {"surface_heights": case.surface.heights, **fem_run.maps}
            write_hdf5(path, case.inputs(), fem_run.result, maps, note, extra, request)

    agreed(comm, write)
