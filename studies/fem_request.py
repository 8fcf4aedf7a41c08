"""A FEM request, run: where it writes, the reuse of a stored result, one run or the error
ladder (``--tol``), and the summary both front doors return (``studies.api.run_fem`` and
``roughfriction fem``, which prints it as JSON).

A request is a case (``studies.fem_input``), its outputs (:class:`FemOutputs`) and, for an
error estimate, the ladder's limits (:func:`requested_ladder`). A results file that already holds
the same request (:func:`request_digest`), converged and computed by this physics, is returned
instead of run again; any other existing output is refused unless overwritten. Every output is
checked on every rank before anything is solved; every level of a ladder is written as soon as
its estimate is known.
"""

from __future__ import annotations

import hashlib
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from roughfriction.case import FemCase
from roughfriction.errors import ConvergenceError, InputError
from roughfriction.files import agreed, check_results_file, check_writable_directory
from roughfriction.plausibility import material_record, result_warnings
from roughfriction.studies.cache import release
from roughfriction.studies.fem_input import PYTHON_NAMES, InputNames
from roughfriction.studies.refinement import (
    DEFAULT_MARGIN,
    LADDER_RATIO,
    LadderLimits,
    LevelRun,
    ToleranceNotMet,
    level_memory_gb,
    run_ladder,
)


def check_tolerance(tolerance: float) -> float:
    """``tolerance`` if it is a relative error of mu_s to reach: in (0, 1) [-]."""
    if not (isinstance(tolerance, int | float) and not isinstance(tolerance, bool)
            and 0.0 < tolerance < 1.0):
        raise InputError(f"the tolerance must be > 0 and a relative error below 1 (e.g. 0.03), "
                         f"got {tolerance!r}")
    return float(tolerance)


def check_max_level(level: int) -> int:
    """``level`` if it can be a ladder's finest level: an integer >= 1 (2^level times finer)."""
    if isinstance(level, bool) or not isinstance(level, int) or level < 1:
        raise InputError(f"the finest level must be an integer >= 1 (an estimate needs two "
                         f"levels), got {level!r}")
    return level


def requested_ladder(tol: float | None, limits: LadderLimits | None,
                     comm) -> LadderLimits | None:
    """The ladder a request asks for, checked: ``limits`` (default ``LadderLimits()``) with the
    tolerance ``tol``, its memory limit at most what is available to ``comm``'s ranks
    (``solver.memory.available_memory_gb``); None (one run) when neither is given. Without a
    tolerance the ladder runs every level up to ``limits.max_level`` (``--refine``: 1)."""
    from roughfriction.solver.memory import available_memory_gb

    if tol is None and limits is None:
        return None
    limits = limits or LadderLimits()
    if tol is not None:
        if limits.tolerance is not None and limits.tolerance != tol:
            raise InputError(f"two tolerances: tol={tol:g} and limits.tolerance="
                             f"{limits.tolerance:g}; give one")
        limits = replace(limits, tolerance=tol)
    if limits.tolerance is not None:
        check_tolerance(limits.tolerance)
    check_max_level(limits.max_level)
    for name in ("max_memory_gb", "max_time_s"):
        if not getattr(limits, name) > 0:
            raise InputError(f"ladder limit {name} must be > 0, got {getattr(limits, name)}")
    return replace(limits, max_memory_gb=min(limits.max_memory_gb, available_memory_gb(comm)))


def finest_factor(limits: LadderLimits | None) -> int:
    """How many times finer than the case the finest mesh a request is sure to run is [-]: the
    last level of a ladder without a tolerance (it runs every level), else 1 (the levels of a
    tolerance are gated one by one)."""
    if limits is None or limits.tolerance is not None:
        return 1
    return LADDER_RATIO ** limits.max_level


def ladder_labels(limits: LadderLimits | None) -> tuple[str, ...]:
    """What a ladder adds to a request (:func:`request_digest`): ``refined`` (levels 0 and 1
    without a tolerance; ``refined_L<L>`` through level L), the tolerance with its finest level
    (``tol0.03_L3``) and, for either, a ``uniform`` ladder or an adaptive zone margin other than
    the default (``margin2``)."""
    if limits is None:
        return ()
    if limits.tolerance is None:
        what = "refined" if limits.max_level == 1 else f"refined_L{limits.max_level}"
    else:
        what = f"tol{limits.tolerance:g}_L{limits.max_level}"
    return (what,) + (("uniform",) if limits.ladder == "uniform" else ()) + (
        (f"margin{limits.margin}",) if limits.margin != DEFAULT_MARGIN else ())


def request_digest(case: FemCase, labels: tuple[str, ...] = ()) -> str:
    """SHA-256 (hex) of what a request asks for: the case's inputs (surface heights and
    spacing, load, material, mesh and solver options) and ``labels`` (:func:`ladder_labels`,
    and the command line's window)."""
    defined = json.dumps({"inputs": case.inputs(), "labels": list(labels)}, sort_keys=True)
    return hashlib.sha256(defined.encode()).hexdigest()


@dataclass(frozen=True)
class FemOutputs:
    """Where a request writes, and what it asks for.

    Attributes
    ----------
    results : pathlib.Path or None
        The results file (of a ladder: its finest level); None writes none.
    request : str
        :func:`request_digest` of the request: stored in the results file, so that the same
        request run again finds its result.
    coarse : pathlib.Path or None
        Level 0 of a ladder, when it is to be kept apart (``--refine``).
    fields : pathlib.Path or None
        The fields' folder (``fields.xdmf`` and ``fields.h5`` in it; of level 0).
    mesh_file : pathlib.Path or None
        The block as a gmsh file (``--msh``).
    names : InputNames
        How the refusals name the outputs.
    """

    results: Path | None
    request: str
    coarse: Path | None = None
    fields: Path | None = None
    mesh_file: Path | None = None
    names: InputNames = PYTHON_NAMES

    def reusable(self, overwrite: bool) -> dict | None:
        """The stored summary when the results file holds this request, converged, from this
        physics (returned instead of a run); None when there is none to reuse, with
        ``overwrite``, or when fields or a mesh file are asked for (the run is needed). A
        results file of another request, of other physics or unconverged is refused
        (:class:`InputError`, naming which)."""
        from roughfriction.studies.physics import physics_stamp, physics_version
        from roughfriction.studies.results_file import stored_run

        if (overwrite or self.results is None or not self.results.is_file()
                or self.fields is not None or self.mesh_file is not None):
            return None
        names = self.names
        try:
            stored = stored_run(self.results)
        except OSError:
            raise InputError(f"{self.results} exists and is not a results file: pass "
                             f"{names.overwrite} to replace it, or name another "
                             f"{names.output}") from None
        physics = physics_version()
        if stored.request != self.request:
            why = "holds another case"
        elif stored.physics != physics:
            why = (f"is stale: computed by other physics "
                   f"({physics_stamp(stored.physics) or 'unknown'}, this code "
                   f"{physics_stamp(physics)})")
        elif not stored.converged or stored.summary.get("error_tolerance_met") is False:
            why = "holds this case unconverged or short of its tolerance"
        else:
            return stored.summary
        raise InputError(f"{self.results} {why}: pass {names.overwrite} to recompute, or name "
                         f"another {names.output}")

    def check(self, overwrite: bool) -> None:
        """Refuse (:class:`InputError`) an output that cannot be written, or that exists when
        ``overwrite`` is false. Creates nothing."""
        existing = [path for path in (self.results, self.coarse) if path is not None]
        for path in existing:
            check_results_file(path)
        if self.fields is not None:
            check_writable_directory(self.fields)
            existing.append(self.fields / "fields.xdmf")
        present = [str(path) for path in existing if path.exists()]
        if present and not overwrite:
            raise InputError(f"{' and '.join(present)} already exist{'s' * (len(present) == 1)}"
                             f": pass {self.names.overwrite} to replace, or name another "
                             f"{self.names.output}/{self.names.fields}")


@dataclass(frozen=True)
class Voice:
    """Where a request's lines go.

    Attributes
    ----------
    progress : callable
        ``progress(case)``: the progress callable of one run of ``case`` (it receives the run's
        records, ``solver.progress``).
    say : callable
        Receives each of the request's own lines: level headers, the results file, warnings,
        what the error estimate is.
    """

    progress: Callable[[FemCase], Callable]
    say: Callable[[str], None]


def stderr_voice(comm) -> Voice:
    """Every line on stderr on rank 0 of ``comm``, each run's steps numbered with their share
    of the preload and the time left (``solver.progress.CountedProgress``)."""
    from roughfriction.solver.progress import CountedProgress

    def say(line: str) -> None:
        if comm.rank == 0:
            print(line, file=sys.stderr)

    return Voice(lambda case: CountedProgress(comm, case.normal_force), say)


def run_request(case: FemCase, outputs: FemOutputs, limits: LadderLimits | None, comm,
                overwrite: bool = False, voice: Voice | None = None) -> dict:
    """Run ``case`` once (``limits`` None) or on the ladder ``limits`` asks for
    (:func:`run_levels`), unless ``outputs.results`` holds this request already; return the
    summary (the run's, with ``psi_meshed``, ``material`` and ``warnings``; of a ladder, of its
    finest level with the estimate and the per-level columns).

    Raises
    ------
    InputError
        An output that cannot be written or exists (unless ``overwrite``), before any solve.
    ConvergenceError
        A run that did not converge (after writing its partial results); a ladder stopped short
        of its tolerance (:class:`ToleranceNotMet`, after writing the finest level).
    """
    from roughfriction.geometry.statistics import surface_statistics

    voice = voice or stderr_voice(comm)
    stored = agreed(comm, lambda: outputs.reusable(overwrite))
    if stored is not None:
        voice.say(f"reused: {outputs.results} holds this case, computed by this code "
                  f"({outputs.names.overwrite} recomputes it)")
        _say_warnings(stored, voice)
        return stored
    agreed(comm, lambda: outputs.check(overwrite))
    meshed = {"psi_meshed": surface_statistics(case.surface, case.material).psi,
              "material": material_record(case.material)}
    if outputs.mesh_file is not None:
        write_mesh_file(case, outputs.mesh_file, comm)
    if limits is None:
        return run_once(case, outputs, meshed, comm, voice)
    return run_levels(case, outputs, limits, meshed, comm, voice)


def write_mesh_file(case: FemCase, path: Path, comm) -> None:
    """Write the case's block, with the blend layers its run takes, as a gmsh file."""
    from roughfriction.solver.block import write_block_msh
    from roughfriction.solver.run import with_blend_layers_needed

    meshed_case = with_blend_layers_needed(case, lambda note: None)  # the run says it
    write_block_msh(case.surface.heights, case.surface.spacing, meshed_case.mesh, path, comm)


def run_once(case: FemCase, outputs: FemOutputs, meshed: dict, comm, voice: Voice) -> dict:
    """One run of ``case``, written to ``outputs.results`` (fields to ``outputs.fields``);
    its summary with ``meshed`` and ``warnings``."""
    from roughfriction.solver.run import run

    outcome = run(case, comm, voice.progress(case), xdmf_directory=outputs.fields)
    release([outcome])  # what is written below is its result and maps
    summary = with_warnings({**outcome.result.summary(), **meshed}, case)
    save(outputs.results, case, outcome, comm, {**meshed, "warnings": summary["warnings"]},
         outputs.request)
    _say_results(outputs.results, voice)
    _say_warnings(summary, voice)
    return summary


def run_levels(case: FemCase, outputs: FemOutputs, limits: LadderLimits, meshed: dict,
               comm, voice: Voice) -> dict:
    """Run the case on finer and finer meshes (:func:`studies.refinement.run_ladder`, uniform
    or contact-adaptive as ``limits.ladder`` says): each level is written as soon as its
    estimate is known to ``outputs.results`` (level 0 to ``outputs.coarse`` if given), the
    finest replacing the one before; fields are those of level 0. Returns the finest level's
    summary with the estimate and the per-level columns (:func:`ladder_report`); raises
    :class:`ToleranceNotMet` (after writing) when a limit stopped the ladder short of the
    tolerance or of an estimate."""
    from roughfriction.solver.results import touched_nodes
    from roughfriction.solver.run import near_flat, run

    finest = {}  # the summary of the last level run
    done: list[dict] = []  # per level run: wall time [s], reduced dofs, cut steps

    def run_level(level: int, level_case: FemCase) -> LevelRun:
        voice.say(level_header(level, level_case, limits, done, comm.size))
        fem_run = run(level_case, comm, voice.progress(level_case),
                      xdmf_directory=outputs.fields if level == 0 else None)
        release([fem_run])  # so that the next level's memory starts from this one's
        summary = fem_run.result.summary()
        finest.update(summary)
        done.append({"wall_s": summary["wall_s"], "cut_steps": summary["cut_steps"],
                     "reduced_dofs": fem_run.result.sizes["reduced_dofs"]})
        path = outputs.coarse if outputs.coarse is not None and level == 0 else outputs.results
        request = outputs.request if path == outputs.results else ""  # the coarse answers none
        if not fem_run.result.converged:
            save(path, level_case, fem_run, comm, meshed, request)  # raises ConvergenceError

        def save_level(ladder) -> None:
            extra = (meshed if path == outputs.coarse
                     else {**ladder_report(ladder.summary(), done), **meshed})
            flags = with_warnings({**summary, **extra}, level_case)["warnings"]
            save(path, level_case, fem_run, comm, {**extra, "warnings": flags}, request)

        key = "area_ratio_normal" if level_case.loading.normal_only else "mu_s"
        sizes = fem_run.result.sizes
        return LevelRun(summary[key], sizes["reduced_dofs"], sizes["cells"], save_level,
                        touched_nodes(fem_run.maps), near_flat(level_case, fem_run),
                        summary["contact_nodes"], summary["boundary_nodes"])

    ladder = run_ladder(case, run_level, limits,
                        lambda level_case: level_memory_gb(level_case, comm.size))
    if not ladder.met:
        where = f" (results in {outputs.results})" if outputs.results is not None else ""
        raise ToleranceNotMet(f"{ladder.shortfall()}{where}")
    summary = with_warnings({**finest, **ladder_report(ladder.summary(), done), **meshed}, case)
    _say_results(outputs.results, voice)
    _say_warnings(summary, voice)
    voice.say(f"note: {summary['error_estimate']}")
    return summary


def level_header(level: int, level_case: FemCase, limits: LadderLimits, done: list[dict],
                 ranks: int) -> str:
    """The line before a level of the ladder: which of how many, its mesh factor, reduced
    dofs, estimated memory [GB] and (after level 0) predicted wall time [min], the last
    level's time scaled by the ratio of dofs."""
    from roughfriction.studies.refinement import level_dofs

    dofs = level_dofs(level_case)
    predicted = (f", ~{done[-1]['wall_s'] * dofs / done[-1]['reduced_dofs'] / 60:.2g} min"
                 if done else "")
    return (f"level {level} of at most {limits.max_level} ({LADDER_RATIO ** level}x mesh): "
            f"{dofs} reduced dofs, ~{level_memory_gb(level_case, ranks):.2g} GB{predicted}")


def ladder_report(ladder_summary: dict, done: list[dict]) -> dict:
    """The ladder's summary with the cut steps of every level (``levels.cut_steps`` and
    their sum ``cut_steps_all_levels``) and ``error_estimate``: what the estimate is and how
    far it has been shown to hold."""
    from roughfriction.studies.certificate import coverage_statement

    levels = {**ladder_summary["levels"], "cut_steps": [one["cut_steps"] for one in done]}
    return {**ladder_summary, "levels": levels,
            "cut_steps_all_levels": sum(one["cut_steps"] for one in done),
            "error_estimate": coverage_statement()}


def save(output: Path | None, case: FemCase, fem_run, comm, extra: dict, request: str) -> None:
    """Write the run's results file to ``output`` (none for None; ``extra``: added to its
    summary; ``request``: :func:`request_digest`), then refuse an unconverged run
    (:class:`ConvergenceError`, naming the file of its partial results)."""
    from roughfriction.studies.results_file import save_run

    if output is not None:
        save_run(output, case, fem_run, comm, extra=extra, request=request)
    if not fem_run.result.converged:
        where = f" (partial results in {output})" if output is not None else ""
        raise ConvergenceError(f"FEM run did not converge: {fem_run.result.message}{where}")


def unresolved_warning(summary: dict) -> str | None:
    """A one-line warning for a run whose contact patches hold fewer than
    ``RELIABLE_CELLS_PER_PATCH`` grid cells of contact area each (summary ``reliable`` false),
    else None; none for a certified result (a finite ``mu_s_error``, or
    ``area_ratio_normal_error`` of a normal-only ladder), whose certificate states the error
    the unresolved patches leave."""
    import math

    from roughfriction.solver.results import RELIABLE_CELLS_PER_PATCH

    certificates = (summary.get(key) for key in ("mu_s_error", "area_ratio_normal_error"))
    if summary.get("reliable") is not False or any(
            value is not None and math.isfinite(value) for value in certificates):
        return None
    return (f"the contact patches hold {summary['cells_per_patch']:.2g} grid cells of contact "
            f"area each (< {RELIABLE_CELLS_PER_PATCH}): they are not resolved, and the area and "
            "mu_s are mesh-dependent (docs/verification.md); --tol 0.03 refines the mesh until "
            "the estimated error of mu_s is 3 %, or read the result as unreliable")


def with_warnings(summary: dict, case: FemCase) -> dict:
    """``summary`` with ``warnings``: the result's flags (``plausibility.result_warnings``)
    and :func:`unresolved_warning`, one line each."""
    flags = result_warnings(case.loading.load_star, [summary.get("area_ratio_normal"),
                                                     summary.get("area_ratio_sliding")])
    return {**summary, "warnings": flags + [line for line in (unresolved_warning(summary),)
                                            if line]}


def _say_results(output: Path | None, voice: Voice) -> None:
    """Name the results file, once the request's answer is in it."""
    if output is not None:
        voice.say(f"results: {output}")


def _say_warnings(summary: dict, voice: Voice) -> None:
    """Say the summary's ``warnings``, one line each."""
    for line in summary.get("warnings", []):
        voice.say(f"warning: {line}")
