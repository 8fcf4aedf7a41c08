"""Reading a FEM results file (``roughfriction fem --output``, or a run-cache entry) with h5py.

No dolfinx: figure scripts and ``roughfriction post RUN`` use this on any machine. The file's
layout is written by :func:`studies.results_file.write_hdf5`; here it is read back into a
:class:`RunFile`, and the derived quantities are small pure functions of it: the per-step table,
the state at the end of the preload, the interference omega_0, junction growth, and summaries
and CSV files of the surface maps.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from roughfriction.errors import InputError
from roughfriction.solver.results import StepRecord

#: Root attributes every results file has.
REQUIRED_ATTRIBUTES = ("inputs", "summary", "converged", "message")
#: Step datasets every results file has (one per StepRecord field).
STEP_FIELDS = tuple(field.name for field in fields(StepRecord))
#: Step datasets added later: read where present (older files lack them).
OPTIONAL_STEP_FIELDS = ("cuts", "boundary_nodes")


@dataclass(frozen=True)
class RunFile:
    """One run as stored in its results file.

    Attributes
    ----------
    path : pathlib.Path
        The file.
    inputs : dict
        The case (``FemCase.inputs()``): surface, loading, material, mesh, solver.
    summary : dict
        The run's JSON summary (mu_s, Ft_max [N], Fn [N], areas, ...).
    converged : bool
        The requested loading finished.
    message : str
        Why not, if not converged.
    steps : dict
        StepRecord field -> array over the converged steps (SI units; "phase" as str;
        ``cuts`` only in files written since it was recorded).
    maps : dict
        Name -> N x N array ([i, j] at x = i h, y = j h): contact and slip flags (bool),
        pressures and shear [Pa], contact fractions per cell [-], ``surface_heights`` [m] when
        recorded (units: :data:`MAP_UNITS`).
    timings : dict
        Wall times of the phases [s].
    sizes : dict
        Cells, reduced dofs, ranks, linear solver, peak memory [GB].
    note : str
        How the run was obtained if not the usual way ("" otherwise), e.g. on a standalone
        normal path after its shared one failed (:mod:`studies.cache`).
    interference_m : float or None
        omega_0 [m] as a committed run summary (``studies.run_summary``, no maps) keeps it.
    """

    path: Path
    inputs: dict
    summary: dict
    converged: bool
    message: str
    steps: dict
    maps: dict
    timings: dict
    sizes: dict
    note: str = ""
    interference_m: float | None = None

    @property
    def surface_name(self) -> str:
        """The surface's label."""
        return self.inputs["surface"]["name"]

    @property
    def load_star(self) -> float:
        """F* = F_n / (A_n S_y) [-]."""
        return float(self.inputs["loading"]["load_star"])

    @property
    def n(self) -> int:
        """Surface cells per side of the FEM grid [-]."""
        return int(self.inputs["surface"]["n"])

    @property
    def spacing(self) -> float:
        """FEM grid spacing h [m]."""
        return float(self.inputs["surface"]["spacing_m"])


def _plain(value):
    """An HDF5 attribute as a plain Python value."""
    if isinstance(value, bytes):
        return value.decode()
    return value.item() if isinstance(value, np.generic) else value


#: Layout version of a committed run summary (``studies.run_summary`` writes them).
SUMMARY_FORMAT = 1


def read_summary(path: Path) -> RunFile:
    """A committed run summary (JSON, ``studies.run_summary``) as a :class:`RunFile` without
    maps (``interference_m`` kept)."""
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


def read_run(path) -> RunFile:
    """Read a results file.

    Parameters
    ----------
    path : str or pathlib.Path
        An HDF5 file written by :func:`studies.results_file.write_hdf5`, or a committed run
        summary (``.json``, :func:`read_summary`).

    Returns
    -------
    RunFile

    Raises
    ------
    InputError
        The file is missing, not HDF5 (e.g. truncated by an interrupted write), or not a
        roughfriction results file.
    """
    import h5py

    path = Path(path)
    if not path.is_file():
        raise InputError(f"no results file {path}")
    if path.suffix == ".json":
        return read_summary(path)
    if path.name.startswith(".") and path.name.endswith(".tmp"):
        raise InputError(f"{path} is the temporary file of an unfinished write, not a result")
    try:
        with h5py.File(path, "r") as h5:
            missing = [name for name in REQUIRED_ATTRIBUTES if name not in h5.attrs]
            missing += [f"steps/{name}" for name in STEP_FIELDS
                        if f"steps/{name}" not in h5 and name not in OPTIONAL_STEP_FIELDS]
            if missing:
                raise InputError(f"{path} is not a roughfriction FEM results file (no "
                                 f"{', '.join(missing[:3])})")
            steps = {name: h5["steps"][name][()] for name in STEP_FIELDS
                     if f"steps/{name}" in h5}
            steps["phase"] = np.array([_plain(value) for value in steps["phase"]], dtype=str)
            return RunFile(
                path=path,
                inputs=json.loads(h5.attrs["inputs"]),
                summary=json.loads(h5.attrs["summary"]),
                converged=bool(h5.attrs["converged"]),
                message=_plain(h5.attrs["message"]),
                steps=steps,
                maps={name: h5["maps"][name][()] for name in h5.get("maps", {})},
                timings={k: _plain(v) for k, v in h5["timings"].attrs.items()},
                sizes={k: _plain(v) for k, v in h5["sizes"].attrs.items()},
                note=_plain(h5.attrs.get("note", "")),
            )
    except OSError as error:
        raise InputError(f"cannot read {path} as HDF5 (truncated or not HDF5): {error}") from None


# --- derived quantities ----------------------------------------------------------------------


def step_table(run: RunFile) -> dict:
    """The per-step table.

    Returns
    -------
    dict
        Equal-length columns: ``phase``, ``Fn_N``, ``Ft_N``, ``Ft_over_Fn`` [-], ``ux_m``,
        ``area_ratio`` (A_r/A_n) [-], ``contact_nodes``, ``contact_patches``,
        ``nodes_per_patch`` (NaN without contact) [-], ``slipping_nodes``, ``newton_iterations``,
        ``wall_s``.
    """
    steps = run.steps
    nodes, patches = steps["contact_nodes"], steps["contact_patches"]
    with np.errstate(divide="ignore", invalid="ignore"):
        per_patch = np.where(patches > 0, nodes / np.maximum(patches, 1), np.nan)
        ratio = steps["tangential_force"] / steps["normal_force"]
    return {
        "phase": steps["phase"],
        "Fn_N": steps["normal_force"],
        "Ft_N": steps["tangential_force"],
        "Ft_over_Fn": ratio,
        "ux_m": steps["slide"],
        "area_ratio": steps["area_ratio"],
        "contact_nodes": nodes,
        "contact_patches": patches,
        "nodes_per_patch": per_patch,
        "slipping_nodes": steps["slipping_nodes"],
        "newton_iterations": steps["newton_iterations"],
        "wall_s": steps["wall_s"],
    }


#: Relative tolerance on F_n for a preload step to count as the full preload [-].
PRELOAD_TOLERANCE = 1e-4


def target_normal_force(run: RunFile) -> float:
    """F_n = F* A_n S_y of the case [N], A_n = (N h)^2."""
    nominal_area = (run.n * run.spacing) ** 2
    return run.load_star * nominal_area * float(run.inputs["material"]["Sy"])


def preload_end(run: RunFile) -> int | None:
    """Index of the step that completed the preload (the last "normal" step, at the target
    F_n), or None if the preload did not get there."""
    normal = np.flatnonzero(run.steps["phase"] == "normal")
    if not normal.size:
        return None
    reached = run.steps["normal_force"][normal[-1]] / target_normal_force(run)
    return int(normal[-1]) if abs(reached - 1.0) <= PRELOAD_TOLERANCE else None


def preload_state(run: RunFile) -> dict | None:
    """The state at the end of the preload (one row of :func:`step_table`), None if the
    preload did not reach its load.

    This is also what a normal-only request reads from a sliding run of the same case (the
    preload is the same computation).
    """
    index = preload_end(run)
    if index is None:
        return None
    return {key: column[index].item() for key, column in step_table(run).items()}


def tangential_curve(run: RunFile) -> dict:
    """The tangential loading from the end of the preload (u_x = 0) through every sliding step.

    Returns
    -------
    dict
        Equal-length arrays ``ux_m`` [m], ``Ft_over_Fn`` [-], ``area_ratio`` (A_r/A_n) [-];
        empty if the preload did not finish.
    """
    index = preload_end(run)
    rows = [] if index is None else [index, *np.flatnonzero(run.steps["phase"] == "tangential")]
    steps = run.steps
    return {"ux_m": steps["slide"][rows],
            "Ft_over_Fn": steps["tangential_force"][rows] / steps["normal_force"][rows],
            "area_ratio": steps["area_ratio"][rows]}


def interference(run: RunFile) -> float | None:
    """omega_0, the interference under the normal preload only [m].

    The approach of the flat from first touch to the end of the preload: the highest point of
    the surface above its mean plane minus the flat's height above that plane at the end of
    the preload (the paper's normalisation of Fig. 21). None without the recorded surface
    heights or without a preload step.
    """
    index = preload_end(run)
    heights = run.maps.get("surface_heights")
    if heights is None and index is not None:
        return run.interference_m
    if index is None:
        return None
    return float(np.max(heights - heights.mean()) - run.steps["flat_height"][index])


def junction_growth(run: RunFile) -> dict:
    """Contact area at the end of the preload and at the last sliding step (the paper's
    Fig. 15; the last step is sliding inception when ``inception``).

    Returns
    -------
    dict
        ``area_ratio_normal`` [-] (None if the preload did not finish), ``area_ratio_sliding``
        [-] (None without a sliding step), ``growth`` = sliding / normal - 1 [-] (None without
        both), ``inception`` (bool).
    """
    area = tangential_curve(run)["area_ratio"]
    normal = float(area[0]) if area.size else None
    sliding = float(area[-1]) if area.size > 1 else None
    growth = sliding / normal - 1.0 if normal and sliding is not None else None
    return {"area_ratio_normal": normal, "area_ratio_sliding": sliding, "growth": growth,
            "inception": run.summary.get("mu_s") is not None}


#: The unit of each non-flag surface map, by its name without the phase suffix.
MAP_UNITS = {"pressure": "Pa", "shear_x": "Pa", "contact_fraction": "-", "surface_heights": "m",
             "gap": "m"}


def map_unit(name: str) -> str:
    """The unit of map ``name`` (``<map>_<phase>`` or ``surface_heights``), from
    :data:`MAP_UNITS`; ValueError for a map whose unit is not declared there."""
    base = name.removesuffix("_normal").removesuffix("_sliding")
    if base not in MAP_UNITS:
        raise ValueError(f"map {name!r} has no declared unit (studies.post.MAP_UNITS)")
    return MAP_UNITS[base]


def map_summary(name: str, values: np.ndarray) -> dict:
    """A few numbers that describe one surface map, each in the map's own unit.

    Contact and slip flags: nodes set, their fraction, patches (periodic connectivity) and
    nodes per patch. Contact fractions (per cell, the fraction of its area in contact) [-]:
    their mean, which is A_r/A_n, the largest, and the cells with any contact. Pressures and
    shear [Pa]: max and mean over the nonzero nodes. Heights and gaps [m]: min and max.
    """
    from roughfriction.solver.results import count_patches

    values = np.asarray(values)
    if values.dtype == bool:
        nodes = int(np.count_nonzero(values))
        patches = count_patches(values)
        return {"nodes": nodes, "fraction": nodes / values.size, "patches": patches,
                "nodes_per_patch": nodes / patches if patches else None}
    unit = map_unit(name)
    if unit == "m":  # heights, or gaps (NaN where a grid point has no surface node)
        return {"min_m": float(np.nanmin(values)), "max_m": float(np.nanmax(values))}
    if unit == "-":
        return {"area_ratio": float(values.mean()), "max_cell_fraction": float(values.max()),
                "cells_in_contact": int(np.count_nonzero(values))}
    loaded = values[values != 0]
    return {"max_Pa": float(np.abs(values).max()),
            "mean_nonzero_Pa": float(loaded.mean()) if loaded.size else 0.0}


def map_column(name: str, values: np.ndarray) -> str:
    """The CSV column of map ``name``: the name with its unit (:func:`map_unit`) appended, e.g.
    ``pressure_normal_Pa``; flags (0/1) and dimensionless maps keep the bare name."""
    if np.asarray(values).dtype == bool:
        return name
    unit = map_unit(name)
    return name if unit == "-" else f"{name}_{unit}"


def map_table(values: np.ndarray, spacing: float) -> np.ndarray:
    """An n x n map as rows (x [m], y [m], value), x = i h, y = j h with ``spacing`` h [m], in
    the order of ``values.ravel()`` (x-major): column 2 reshaped to (n, n) is the map again;
    flags become 0/1."""
    values = np.asarray(values)
    i, j = np.indices(values.shape)
    return np.column_stack([i.ravel() * spacing, j.ravel() * spacing,
                            values.astype(float).ravel()])


def write_map_csv(path, name: str, values: np.ndarray, spacing: float) -> Path:
    """Write map ``name`` as the CSV ``path`` atomically: the header ``x_m,y_m,<column>``
    (:func:`map_column`), then one row per grid point (:func:`map_table`, ``spacing`` h [m]);
    return ``path``."""
    from roughfriction.files import atomic_write

    value_format = "%d" if np.asarray(values).dtype == bool else "%.10g"
    atomic_write(Path(path), lambda temporary: np.savetxt(
        temporary, map_table(values, spacing), fmt=["%.10g", "%.10g", value_format],
        delimiter=",", header=f"x_m,y_m,{map_column(name, values)}", comments=""))
    return Path(path)


def write_map_csvs(run: RunFile, directory) -> list[Path]:
    """Write every map as ``DIRECTORY/<name>.csv`` (:func:`write_map_csv`): the header
    ``x_m,y_m,<name>[_<unit>]``, then one row per grid point in x-major order (x = i h,
    y = j h [m]; the third column reshaped to (N, N) is the map): flags as 0/1, pressures and
    shear in Pa, contact fractions per cell in 0..1 (-), heights and gaps in m. Readable by
    ``pandas.read_csv`` and ``np.loadtxt(path, delimiter=",", skiprows=1)``.

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    return [write_map_csv(Path(directory) / f"{name}.csv", name, values, run.spacing)
            for name, values in run.maps.items()]


def run_report(run: RunFile) -> dict:
    """Everything ``roughfriction post`` prints: case, summary, steps, junction growth, maps.

    Returns
    -------
    dict
        Scalars first (``file``, ``surface``, ``n``, ``load_star``, the run's summary, the
        interference ``omega_0_m`` [m]); for the finest level of ``fem --tol``/``--refine``, the
        summary also holds ``mu_s_error`` (or ``area_ratio_normal_error``), the order used and
        ``levels``: per level the refinement ``factor``, ``reduced_dofs``, ``cells``, the value
        and ``wall_s`` [s] (:meth:`studies.refinement.Ladder.summary`); then ``per_step`` (the
        columns of :func:`step_table`, as lists), ``junction`` (:func:`junction_growth`),
        ``tangential_curve`` (:func:`tangential_curve`, as lists) and ``maps`` (name ->
        :func:`map_summary`).
    """
    curve = tangential_curve(run)
    return {
        "file": str(run.path),
        "surface": run.surface_name,
        "n": run.n,
        "load_star": run.load_star,
        "normal_only": bool(run.inputs["loading"]["normal_only"]),
        **run.summary,
        "message": run.message,
        "note": run.note,
        "omega_0_m": interference(run),
        "per_step": {key: column.tolist() for key, column in step_table(run).items()},
        "junction": junction_growth(run),
        "tangential_curve": {key: values.tolist() for key, values in curve.items()},
        "maps": {name: map_summary(name, values) for name, values in run.maps.items()},
    }
