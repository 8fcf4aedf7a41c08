"""Discretisation error of a FEM result from the same surface on finer meshes.

A run resolves its surface as the bilinear interpolant through the grid points; a mesh refined
by a factor r samples that interpolant r times finer (``geometry.surface.bilinear_refine``), so
every mesh of a ladder sees the same surface and the results differ by discretisation only.
:func:`richardson` extrapolates results f_1, f_2 (, f_4) on meshes of spacing h, h/2 (, h/4)
(two meshes at an assumed order p, three at the observed one): the tamaas peer and the
convergence benchmarks use it. A ladder's finest value carries the certificate of
``studies.certificate`` instead (:func:`ladder_certificate`): an estimate of the error of the
value reported, from the last two levels and the finest level's contact resolution, calibrated
on a set of uniform ladders (docs/verification.md).

:func:`run_ladder` adds levels (1x, 2x, 4x, ...) until the certified error of the finest value
is within a relative tolerance, or a limit (level, memory, time) stops it. A level is either the
uniform mesh 2^k times finer (:func:`level_case`) or, by default, the contact-adaptive
refinement of the level before (:func:`adaptive_level_case`: its contact at the end of the
preload and at inception, dilated by a margin, refined 2x); :func:`next_level` is the one place
where the case of level k + 1 is made. Both mesh the same layering (the adaptive block refined
everywhere is the uniform one, ``geometry.adaptive.refined_layering``), so that the two ladders
differ only by where the surface is refined.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from roughfriction.case import FemCase
from roughfriction.errors import ConvergenceError, InputError
from roughfriction.geometry.adaptive import (
    AdaptiveLayout,
    block_layout,
    refined_layering,
    refinement_after,
    surface_levels,
    zone_escaped,
)
from roughfriction.geometry.mesh import blend_layers_needed
from roughfriction.geometry.surface import Surface, bilinear_refine
from roughfriction.studies.certificate import Certificate, certify

#: Order assumed with two meshes [-].
ASSUMED_ORDER = 1.0
#: Spacing ratio of consecutive meshes of a ladder (:func:`richardson`) [-].
LADDER_RATIO = 2


def blend_depth_layers(case: FemCase) -> int:
    """Blend layers (of thickness h) the case's run meshes: its own count, or more where its
    deepest valley needs them (as ``solver.run.with_blend_layers_needed`` takes) [-]."""
    surface = case.surface
    return max(case.mesh.blend_layers, blend_layers_needed(surface.heights, surface.spacing))


def refined_case(case: FemCase, factor: int) -> FemCase:
    """The case on a mesh ``factor`` times finer: the same (bilinear) surface, sampled finer,
    and the layering of ``geometry.adaptive.refined_layering`` (the layering of the adaptive
    block refined everywhere): a blend zone of the same physical depth, ``factor`` times the
    layers the case meshes (:func:`blend_depth_layers`, each h / factor thick), or more where
    the finer valleys need them (:func:`geometry.mesh.blend_layers_needed`)."""
    if factor == 1:
        return case
    surface = case.surface
    fine = Surface(bilinear_refine(surface.heights, factor), surface.spacing / factor,
                   surface.name)
    mesh = refined_layering(replace(case.mesh, blend_layers=blend_depth_layers(case)), factor)
    blend_layers = max(mesh.blend_layers, blend_layers_needed(fine.heights, fine.spacing))
    return replace(case, surface=fine, mesh=replace(mesh, blend_layers=blend_layers))


def level_case(case: FemCase, level: int) -> FemCase:
    """The case of level ``level`` of a uniform ladder (level 0: the case itself): the mesh
    :data:`LADDER_RATIO` ** level times finer (:func:`refined_case`)."""
    return refined_case(case, LADDER_RATIO**level)


def adaptive_level_case(case: FemCase, contact: np.ndarray, margin: int,
                        near: np.ndarray | None = None) -> FemCase:
    """The contact-adaptive level after ``case`` (a level-0 case, or one with a
    ``ZoneRefinement`` of level L): the same surface with the cells of level L's finest grid
    at a node of ``contact`` (bool, that grid's shape) dilated by ``margin`` of those cells,
    and those at a node ``near`` the flat (bool, optional: where a finer mesh may touch),
    refined to level L + 1 (``geometry.adaptive.refinement_after``), 2:1 balanced; the blend
    zone as deep as the case meshes it (:func:`blend_depth_layers`)."""
    zone = refinement_after(case.mesh.refinement, contact, margin, near)
    return replace(case, mesh=replace(case.mesh, blend_layers=blend_depth_layers(case),
                                      refinement=zone))


def level_layout(case: FemCase) -> AdaptiveLayout:
    """The layout of a case's block (``geometry.adaptive.block_layout``: its
    ``ZoneRefinement``, or level 0)."""
    surface = case.surface
    return block_layout(surface.n, surface.spacing, case.mesh)


def level_dofs(case: FemCase) -> int:
    """Reduced dofs of a case's block (``solver.memory.block_size``) [-]."""
    from roughfriction.solver.memory import block_size

    return block_size(level_layout(case))[1]


def level_memory_gb(case: FemCase, ranks: int) -> float:
    """Estimated peak memory of a case's run on ``ranks`` ranks
    (``solver.memory.layout_memory_gb``) [GB]."""
    from roughfriction.solver.memory import layout_memory_gb

    return layout_memory_gb(level_layout(case), ranks)


def contact_escaped(case: FemCase, contact: np.ndarray | None) -> bool:
    """Whether the contact of a level's run (bool nodes on its finest grid,
    :class:`LevelRun`) reached a cell outside its refined zone
    (``geometry.adaptive.zone_escaped``); never on a uniform level."""
    refinement = case.mesh.refinement
    if refinement is None or contact is None:
        return False
    levels = surface_levels(case.surface.n, refinement.level, refinement.zone)
    return zone_escaped(levels, refinement.level, contact)


def next_level(case: FemCase, level: int, current: FemCase, outcome: LevelRun,
               limits: LadderLimits, margin: int) -> FemCase:
    """The case of level ``level + 1`` of a ladder from ``case`` (level 0), after ``current``
    (level ``level``, whose run gave ``outcome``): ``limits.ladder`` "uniform":
    :func:`level_case`; "adaptive": :func:`adaptive_level_case` of ``current`` around its
    run's contact with ``margin`` [cells of level ``level``'s finest grid] and its nodes near
    the flat."""
    if limits.ladder == "uniform":
        return level_case(case, level + 1)
    if outcome.contact is None:
        raise ValueError("an adaptive ladder needs each level's contact map")
    return adaptive_level_case(current, outcome.contact, margin, outcome.near)


def next_mesh(case: FemCase) -> FemCase:
    """The case on the next mesh of a ladder: :data:`LADDER_RATIO` times finer."""
    return refined_case(case, LADDER_RATIO)


@dataclass(frozen=True)
class ErrorEstimate:
    """A result on a mesh ladder (spacing h, h/2, ...), extrapolated to zero spacing.

    Attributes
    ----------
    values : tuple of float
        The result on each mesh, coarse to fine.
    extrapolated : float
        Richardson extrapolation to zero spacing.
    error : float
        Estimated error of the finest value, |extrapolated - finest|.
    order : float
        Observed order (three meshes) or the assumed one (two) [-].
    observed : bool
        The order was observed, not assumed.
    """

    values: tuple
    extrapolated: float
    error: float
    order: float
    observed: bool

    @property
    def relative_error(self) -> float:
        """error / |finest value| [-] (inf for a zero value)."""
        finest = abs(self.values[-1])
        return self.error / finest if finest > 0 else math.inf


def richardson(values, order: float = ASSUMED_ORDER) -> ErrorEstimate:
    """Error estimate of the finest of 2 or 3 results on meshes halved in spacing each time.

    Parameters
    ----------
    values : sequence of float
        Results, coarse to fine.
    order : float
        Order assumed with two results [-]; with three it is observed, unless the differences
        do not shrink (then the assumed order is kept and ``observed`` is False).
    """
    values = tuple(float(v) for v in values)
    if len(values) not in (2, 3):
        raise ValueError(f"richardson needs 2 or 3 results, got {len(values)}")
    observed = False
    if len(values) == 3:
        first, second = values[1] - values[0], values[2] - values[1]
        if second != 0.0 and first * second > 0.0 and abs(second) < abs(first):
            order, observed = math.log(abs(first) / abs(second), LADDER_RATIO), True
    coarse, fine = values[-2], values[-1]
    correction = (fine - coarse) / (float(LADDER_RATIO)**order - 1.0)
    return ErrorEstimate(values, fine + correction, abs(correction), order, observed)


# --- a ladder of levels up to a tolerance -----------------------------------------------------

#: Finest level a ladder may reach unless the user allows another: 2^3 = 8x [-].
DEFAULT_MAX_LEVEL = 3


class ToleranceNotMet(ConvergenceError):
    """The error of the finest level stayed above the tolerance within the limits the user
    allows (the results of the finest level are written; the CLI exits with status 3)."""


#: How a ladder makes its levels: the contact-adaptive refinement of the level before, or the
#: uniform mesh 2^k times finer.
LADDERS = ("adaptive", "uniform")
#: Margin around a level's contact, in cells of its finest grid, of the next level's zone [-].
DEFAULT_MARGIN = 1


@dataclass(frozen=True)
class LadderLimits:
    """What a ladder may spend, and how it refines.

    Attributes
    ----------
    tolerance : float or None
        Relative error of the finest value to reach [-]; None: run every level up to
        ``max_level`` and report the estimate (``--refine``: max_level 1).
    max_level : int
        Finest level (mesh 2^max_level times finer) [-], >= 1.
    max_memory_gb : float
        Estimated peak memory of a level, summed over ranks [GB].
    max_time_s : float
        Wall time of the whole ladder [s]; a level is not started when the time of the
        previous one, scaled by the ratio of dofs, would take the ladder past it.

    ladder : {"adaptive", "uniform"}
        Level k + 1 is the contact-adaptive refinement of level k (:func:`adaptive_level_case`)
        or the uniform mesh 2^(k+1) times finer (:func:`level_case`).
    margin : int
        Adaptive: cells of level k's finest grid (h / 2^k) by which its contact
        (:class:`LevelRun`) is dilated in level k + 1's zone [-], >= 0 (its nodes near the flat
        join undilated); doubled (0 to 1) for the levels after one whose contact reached a
        cell outside its zone (:func:`contact_escaped`). Assumed: level k + 1 touches only
        where level k touched or came near the flat (``solver.results.near_flat_nodes``,
        measured in docs/verification.md); a level that breaks this is flagged
        ``zone_escaped``.
    """

    tolerance: float | None = None
    max_level: int = DEFAULT_MAX_LEVEL
    max_memory_gb: float = math.inf
    max_time_s: float = math.inf
    ladder: str = "adaptive"
    margin: int = DEFAULT_MARGIN

    def __post_init__(self):
        if self.ladder not in LADDERS:
            raise InputError(f"ladder must be one of {', '.join(LADDERS)}, got {self.ladder!r}")
        if isinstance(self.margin, bool) or int(self.margin) != self.margin or self.margin < 0:
            raise InputError(f"zone margin must be an integer >= 0 cells, got {self.margin!r}")


@dataclass(frozen=True, eq=False)
class LevelRun:
    """What a runner returns for one level: the ladder's quantity (mu_s, or A_r/A_n for a
    normal-only run) [-], the size of the level's problem (reduced dofs, hexahedra) [-],
    optionally ``save(ladder)``, called once the ladder including this level is known (to write
    the level's results with the estimate), and on its finest grid (bool; an adaptive ladder
    needs the contact) the nodes in contact at the end of the preload or at inception
    (``solver.results.touched_nodes``) and those near the flat, where a finer mesh may touch
    (``solver.run.near_flat``; optional), and the run summary's ``contact_nodes`` and
    ``boundary_nodes`` (the certificate's resolution term, ``studies.certificate``)."""

    value: float
    reduced_dofs: int
    cells: int
    save: Callable | None = None
    contact: np.ndarray | None = None
    near: np.ndarray | None = None
    contact_nodes: int | None = None
    boundary_nodes: int | None = None


@dataclass(frozen=True)
class Level:
    """One finished level: its number, refinement factor [-], quantity [-], reduced dofs and
    hexahedra [-], wall time (mesh, preload and sliding) [s], whether its contact reached
    the edge of its refined zone (:func:`contact_escaped`), and its contact nodes and their
    boundary nodes at inception (else at the end of the preload) [-]."""

    level: int
    factor: int
    value: float
    reduced_dofs: int
    cells: int
    wall_s: float
    zone_escaped: bool = False
    contact_nodes: int | None = None
    boundary_nodes: int | None = None


@dataclass(frozen=True)
class Ladder:
    """A finished ladder.

    Attributes
    ----------
    key : str
        The quantity: ``mu_s``, or ``area_ratio_normal`` for normal-only runs.
    levels : tuple of Level
        Coarse to fine.
    estimate : Certificate or None
        The certificate of the finest value (:func:`ladder_certificate`; None with one level
        or without the finest level's contact counts).
    limits : LadderLimits
        What it was allowed.
    stopped : str
        Why no finer level was run ("" when the tolerance was met or all levels ran).
    """

    key: str
    levels: tuple
    estimate: Certificate | None
    limits: LadderLimits
    stopped: str = ""

    @property
    def met(self) -> bool:
        """The finest value's estimated relative error is within the tolerance (True without
        a tolerance once there is an estimate)."""
        if self.estimate is None:
            return False
        tolerance = self.limits.tolerance
        return tolerance is None or self.estimate.relative_error <= tolerance

    def summary(self) -> dict:
        """The quantity of the finest level with its certified error (``<key>_error``, and
        relative), ``<key>_coarse`` (the level before), the certificate's two terms, the
        tolerance, the ladder ("adaptive" or "uniform") and the per-level columns
        (``levels``)."""
        key, estimate = self.key, self.estimate
        columns = {"factor": [], "reduced_dofs": [], "cells": [], key: [], "wall_s": [],
                   "zone_escaped": [], "contact_nodes": [], "boundary_nodes": []}
        for level in self.levels:
            for name in columns:
                columns[name].append(level.value if name == key else getattr(level, name))
        values = columns[key]
        return {
            key: values[-1],
            f"{key}_error": estimate.error if estimate else None,
            f"{key}_error_relative": estimate.relative_error if estimate else None,
            f"{key}_coarse": values[-2] if len(values) > 1 else None,
            "error_ladder_term": estimate.ladder_term if estimate else None,
            "error_resolution_term": estimate.resolution_term if estimate else None,
            "error_tolerance": self.limits.tolerance,
            "error_tolerance_met": self.met,
            "error_stopped": self.stopped,
            "error_ladder": self.limits.ladder,
            "levels": columns,
        }

    def shortfall(self) -> str:
        """One line: the best estimate and why the tolerance was not met (or, without a
        tolerance, why there is no estimate)."""
        finest = self.levels[-1]
        if self.estimate is None:
            best = f"{self.key} = {finest.value:.4g} with no error estimate (one level)"
        else:
            best = (f"{self.key} = {finest.value:.4g} +- {self.estimate.error:.2g} "
                    f"({100 * self.estimate.relative_error:.3g} %, certified) at "
                    f"{finest.factor}x")
        tolerance = self.limits.tolerance
        goal = (f"tolerance {100 * tolerance:.3g} % not met" if tolerance is not None
                else "no error estimate")
        return f"{goal}: {best}; {self.stopped}"


def ladder_certificate(levels) -> Certificate | None:
    """The certificate (``studies.certificate.certify``) of the finest of ``levels`` (a
    sequence of :class:`Level`), None with fewer than two levels or without the finest level's
    contact counts."""
    levels = list(levels)
    finest = levels[-1] if levels else None
    if len(levels) < 2 or finest.contact_nodes is None or finest.boundary_nodes is None:
        return None
    return certify([level.value for level in levels], finest.contact_nodes,
                   finest.boundary_nodes)


def level_refused(case: FemCase, last: Level, elapsed_s: float, limits: LadderLimits,
                  memory_gb: Callable[[FemCase], float]) -> str:
    """Why the level after ``last`` (case ``case``) may not run, or "" if it may: the level
    limit, its estimated memory ``memory_gb(case)`` [GB], or its time predicted as the last
    level's wall time times the ratio of reduced dofs [s]."""
    level = last.level + 1
    factor = LADDER_RATIO**level
    if level > limits.max_level:
        return f"the finest level allowed ({LADDER_RATIO**limits.max_level}x, --max-level " \
               f"{limits.max_level}) is reached"
    needed = memory_gb(case)
    if needed > limits.max_memory_gb:
        return (f"the {factor}x level needs about {needed:.3g} GB, {limits.max_memory_gb:.3g} "
                "GB are allowed (--max-memory, or what is available)")
    predicted = last.wall_s * level_dofs(case) / last.reduced_dofs
    if elapsed_s + predicted > limits.max_time_s:
        return (f"the {factor}x level would take about {predicted / 60:.3g} min after "
                f"{elapsed_s / 60:.3g} min, {limits.max_time_s / 60:.3g} min are allowed "
                "(--max-time)")
    return ""


def run_ladder(case: FemCase, run_level: Callable[[int, FemCase], LevelRun],
               limits: LadderLimits, memory_gb: Callable[[FemCase], float],
               clock: Callable[[], float] = time.perf_counter) -> Ladder:
    """Run levels 0, 1, ... (:func:`next_level`: uniform or contact-adaptive, as
    ``limits.ladder`` says) until the estimated relative error of the finest value is within
    ``limits.tolerance`` (without a tolerance: through ``limits.max_level``), or a limit refuses
    the next level (:func:`level_refused`). A level whose contact reached the edge of its zone
    is marked ``zone_escaped`` and doubles the margin of the levels after it (0 becomes 1).

    Parameters
    ----------
    case : FemCase
        Level 0.
    run_level : callable
        ``run_level(level, level_case)`` runs one level and returns its :class:`LevelRun`
        (with its contact map for an adaptive ladder).
    limits : LadderLimits
        Tolerance and limits.
    memory_gb : callable
        Estimated peak memory of a case's run, summed over ranks [GB].
    clock : callable
        Wall clock [s].
    """
    key = "area_ratio_normal" if case.loading.normal_only else "mu_s"
    started = clock()
    levels: list[Level] = []
    current, margin = case, limits.margin
    while True:
        level, mark = len(levels), clock()
        outcome = run_level(level, current)
        escaped = contact_escaped(current, outcome.contact)
        levels.append(Level(level, LADDER_RATIO**level, outcome.value, outcome.reduced_dofs,
                            outcome.cells, clock() - mark, escaped, outcome.contact_nodes,
                            outcome.boundary_nodes))
        estimate = ladder_certificate(levels)
        ladder = Ladder(key, tuple(levels), estimate, limits)
        done = ladder.met if limits.tolerance is not None else level >= limits.max_level
        if not done:
            margin = max(1, 2 * margin) if escaped else margin
            current = next_level(case, level, current, outcome, limits, margin)
            stopped = level_refused(current, levels[-1], clock() - started, limits, memory_gb)
            ladder = replace(ladder, stopped=stopped)
        if outcome.save is not None:
            outcome.save(ladder)
        outcome = None  # the level's model is freed before the next one is built
        if done or ladder.stopped:
            return ladder
