"""What a FEM run reports: per-step records and the run's summary (mu_s...). The HDF5 file
that holds them is written by :mod:`roughfriction.studies.results_file`, outside the physics."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from roughfriction.case import ZoneRefinement
from roughfriction.geometry.adaptive import interpolated_in_cells, overlapped_nodes, surface_levels
from roughfriction.geometry.surface import bilinear_rms_height
from scipy import ndimage


@dataclass(frozen=True)
class StepRecord:
    """State after one converged load step.

    Attributes
    ----------
    phase : str
        "normal" (preload) or "tangential".
    normal_force : float
        F_n, the integral of the contact pressure [N].
    tangential_force : float
        F_t, the x force on the flat [N].
    slide : float
        Flat's tangential displacement u_x [m].
    flat_height : float
        Flat position h above the mean surface plane [m].
    area_ratio : float
        A_r / A_n, the measure of the surface where p > 0 (integration points) [-].
    contact_nodes : int
        Surface nodes with a contact point in their faces [-].
    contact_patches : int
        Connected groups of contact nodes on the periodic grid [-].
    slipping_nodes : int
        Contact nodes all of whose contact points are at the friction cap [-].
    plastic_volume_fraction : float
        Volume fraction with plastic strain [-].
    newton_iterations : int
        Newton iterations of the step's accepted attempt [-].
    krylov_iterations : int
        Krylov iterations of the step [-].
    wall_s : float
        Wall time since the start of loading [s].
    cuts : int
        Failed attempts (step cuts) just before this step was accepted [-].
    cut_iterations : int
        Newton iterations of those failed attempts [-].
    stuck_shear_share : float
        The shear the sticking contact could still add, over F_t
        (``RigidFlat.stuck_shear_reserve``; 0 when every contact point slips, NaN in the
        preload) [-].
    boundary_nodes : int
        Contact nodes on a patch boundary (:func:`count_boundary_nodes`) [-].
    """

    phase: str
    normal_force: float
    tangential_force: float
    slide: float
    flat_height: float
    area_ratio: float
    contact_nodes: int
    contact_patches: int
    slipping_nodes: int
    plastic_volume_fraction: float
    newton_iterations: int
    krylov_iterations: int
    wall_s: float
    cuts: int = 0
    cut_iterations: int = 0
    stuck_shear_share: float = 0.0
    boundary_nodes: int = 0

    def __str__(self) -> str:
        """One progress line."""
        return (f"{self.phase:10s} Fn={self.normal_force:.5e} N Ft={self.tangential_force:.5e} N "
                f"ux={self.slide:.4e} m Ar/An={self.area_ratio:.4f} nodes={self.contact_nodes} "
                f"slip={self.slipping_nodes} stuck={self.stuck_shear_share:.1e} "
                f"plastic={self.plastic_volume_fraction:.4f} "
                f"newton={self.newton_iterations} t={self.wall_s:.1f}s")


@dataclass(frozen=True)
class SlipState:
    """What sliding inception is judged on at one sliding step.

    Attributes
    ----------
    slipping_nodes, contact_nodes : int
        Contact nodes slipping, and in contact [-].
    stuck_shear_share : float
        The shear the sticking contact could still add, over F_t [-].
    force_change : float
        F_t's largest change over the last :data:`PLATEAU_STEPS` sliding steps, over F_t
        (:func:`plateau_change`) [-].
    """

    slipping_nodes: int
    contact_nodes: int
    stuck_shear_share: float
    force_change: float


#: Sliding steps over which F_t must stay within the inception tolerance to be on its plateau.
PLATEAU_STEPS = 2


def plateau_change(forces) -> float:
    """The largest |F_t - F_t'| / F_t between the last of the sliding steps' ``forces`` [N] and
    the :data:`PLATEAU_STEPS` before it [-]; inf with fewer steps or without F_t > 0."""
    forces = list(forces)
    if len(forces) <= PLATEAU_STEPS or forces[-1] <= 0.0:
        return float("inf")
    return max(abs(forces[-1] - before) for before in forces[-1 - PLATEAU_STEPS:-1]) / forces[-1]


def at_inception(state: SlipState, tolerance: float) -> bool:
    """Sliding inception (the paper's "all contact elements slide"): some node touches, and
    every contact node slips, or F_t is on its plateau with the sticking nodes unable to
    raise it: the shear they could still add and F_t's change over the last
    :data:`PLATEAU_STEPS` steps are both at most ``tolerance`` of F_t (a node that has just
    touched, stuck at a small pressure, does not hold the flat) [-]."""
    if state.contact_nodes == 0:
        return False
    return state.slipping_nodes == state.contact_nodes or (
        state.stuck_shear_share <= tolerance and state.force_change <= tolerance)


def slip_state(records) -> SlipState:
    """The :class:`SlipState` of the last of ``records`` (:class:`StepRecord`, the last a
    sliding step)."""
    last = records[-1]
    forces = [record.tangential_force for record in records if record.phase == "tangential"]
    return SlipState(last.slipping_nodes, last.contact_nodes, last.stuck_shear_share,
                     plateau_change(forces))


def touched_nodes(maps: dict) -> np.ndarray:
    """Nodes in contact at the end of the preload or at inception (when reached): the union of
    a run's maps "contact_normal" and "contact_sliding", bool, on its finest grid."""
    contact = np.asarray(maps["contact_normal"], dtype=bool)
    if "contact_sliding" in maps:
        contact = contact | np.asarray(maps["contact_sliding"], dtype=bool)
    return contact


#: A node may touch on a mesh twice as fine where its deformed gap on this mesh is below this
#: share of the RMS height of the meshed (bilinear) surface [-]: the smallest that held every
#: contact node of the finer mesh in docs/verification.md ("Does a run's contact predict where
#: a mesh twice as fine touches?").
CANDIDATE_GAP_SHARE = 0.8


def closest_gap(maps: dict) -> np.ndarray:
    """The smallest weighted gap of each node between the flat and the deformed surface at
    the end of the preload and at inception (when reached) [m], on a run's finest grid; NaN
    where the run has no free surface node (``solver.contact.RigidFlat.node_maps``)."""
    gap = np.asarray(maps["gap_normal"], dtype=float)
    if "gap_sliding" in maps:
        gap = np.fmin(gap, np.asarray(maps["gap_sliding"], dtype=float))
    return gap


def near_flat_nodes(maps: dict, heights: np.ndarray, lowest_flat: float,
                    refinement: ZoneRefinement | None = None) -> np.ndarray:
    """Where a mesh twice as fine may touch besides a run's contact, on its finest grid (bool):
    the nodes both overlapped by the rigid flat at the run's lowest height on the undeformed
    surface (``geometry.adaptive.overlapped_nodes``: the surface only moves down, so no other
    node can touch a flat as high) and within :data:`CANDIDATE_GAP_SHARE` times the meshed
    surface's RMS height (``geometry.surface.bilinear_rms_height``) of it on the deformed one
    (:func:`closest_gap`).

    Parameters
    ----------
    maps : dict
        The run's maps (``FemRun.maps``) on its finest grid.
    heights : numpy.ndarray
        Heights of the surface [m] on its own grid (or on the finest grid of a uniform run:
        the same bilinear surface), shape (n, n).
    lowest_flat : float
        The flat's lowest height above the mean plane in the run [m].
    refinement : ZoneRefinement, optional
        The run's adaptive zone; there the gap at the grid points without a free node is
        interpolated over the surface cell they lie on
        (``geometry.adaptive.interpolated_in_cells``).
    """
    gap, level = closest_gap(maps), 0
    if refinement is not None:
        level = refinement.level
        levels = surface_levels(np.shape(heights)[0], level, refinement.zone)
        gap = interpolated_in_cells(gap, levels, level)
    gap_limit = CANDIDATE_GAP_SHARE * bilinear_rms_height(heights)  # [m]
    return overlapped_nodes(heights, level, lowest_flat) & (gap < gap_limit)


def count_boundary_nodes(contact: np.ndarray) -> int:
    """Contact nodes with a node out of contact among their four neighbours along x and y on
    the periodic grid of in-contact flags ``contact`` (bool, N x N) [-]."""
    contact = np.asarray(contact, dtype=bool)
    inside = contact.copy()
    for axis in (0, 1):
        for shift in (1, -1):
            inside &= np.roll(contact, shift, axis)
    return int(np.count_nonzero(contact & ~inside))


def count_patches(contact: np.ndarray) -> int:
    """Connected components of contact nodes on a periodic grid [-].

    Two contact nodes belong to one patch when they are neighbours along x or y (they share a
    cell edge), including across the periodic boundary.

    Parameters
    ----------
    contact : numpy.ndarray
        In-contact flags on the N x N surface grid, bool.
    """
    labels, count = ndimage.label(contact)
    parent = np.arange(count + 1)

    def root(label: int) -> int:
        while parent[label] != label:
            label = parent[label]
        return label

    for first, last in ((labels[0, :], labels[-1, :]), (labels[:, 0], labels[:, -1])):
        for a, b in zip(first, last, strict=True):
            if a and b:
                parent[root(a)] = root(b)
    return len({root(label) for label in range(1, count + 1)})


#: The paper's reliability criterion, at least 4 contact nodes per patch, for contact at
#: integration points: at least this much contact area per patch, in grid cells h^2 (a node of
#: the paper's node-to-surface contact stands for one cell; a single touching integration point
#: already makes the 4 corners of its face contact nodes) [-].
RELIABLE_CELLS_PER_PATCH = 4


def nodes_per_patch(record: StepRecord | None) -> float | None:
    """Contact nodes per contact patch of a step [-]; None without a step or without contact."""
    if record is None or record.contact_patches == 0:
        return None
    return record.contact_nodes / record.contact_patches


def cells_per_patch(record: StepRecord | None, grid_size: int | None) -> float | None:
    """Contact area per contact patch of a step in grid cells, A_r N^2 / (A_n patches) [-];
    None without a step, a grid size N or contact."""
    if record is None or not grid_size or record.contact_patches == 0:
        return None
    return record.area_ratio * grid_size**2 / record.contact_patches


@dataclass(frozen=True)
class FemResult:
    """Outcome of a run.

    Attributes
    ----------
    records : list of StepRecord
        Every converged step, preload then sliding.
    converged : bool
        The requested loading finished (preload, and sliding inception unless normal-only).
    message : str
        Why not, if not converged.
    normal_only : bool
        No sliding was requested.
    timings : dict
        Wall times of the phases [s].
    sizes : dict
        Cells, grid size N, layers, depth, reduced dofs, ranks, linear solver.
    """

    records: list
    converged: bool
    message: str
    normal_only: bool
    timings: dict
    sizes: dict

    def _last(self, phase: str) -> StepRecord | None:
        matching = [record for record in self.records if record.phase == phase]
        return matching[-1] if matching else None

    @property
    def mu_s(self) -> float | None:
        """Static friction coefficient (F_t)max / F_n at sliding inception; None unless the
        sliding phase converged to inception."""
        inception = self._last("tangential")
        if self.normal_only or not self.converged or inception is None:
            return None
        return inception.tangential_force / inception.normal_force

    def summary(self) -> dict:
        """The JSON dict of the command line (SI units; None where not reached).

        Contact nodes, patches, ``nodes_per_patch`` and ``cells_per_patch`` are those at
        inception, else at the end of the preload; ``reliable``: ``cells_per_patch`` >=
        :data:`RELIABLE_CELLS_PER_PATCH` (None without contact). ``cut_steps``: failed attempts
        before accepted steps; ``newton_iterations``: all Newton iterations of the accepted
        steps and of those failed attempts, ``cut_iterations`` of the failed attempts alone.
        """
        preload, inception = self._last("normal"), self._last("tangential")
        sliding = self.mu_s is not None
        final = inception if sliding else preload
        cells = cells_per_patch(final, self.sizes.get("grid_size"))
        return {
            "mu_s": self.mu_s,
            "Ft_max": inception.tangential_force if sliding else None,
            "Fn": preload.normal_force if preload else None,
            "area_ratio_normal": preload.area_ratio if preload else None,
            "area_ratio_sliding": inception.area_ratio if sliding else None,
            "junction_growth": (inception.area_ratio / preload.area_ratio - 1.0
                                if sliding and preload.area_ratio > 0 else None),
            "contact_nodes": final.contact_nodes if preload else 0,
            "contact_patches": final.contact_patches if preload else 0,
            "boundary_nodes": final.boundary_nodes if preload else 0,
            "nodes_per_patch": nodes_per_patch(final),
            "cells_per_patch": cells,
            "reliable": None if cells is None else cells >= RELIABLE_CELLS_PER_PATCH,
            "steps": len(self.records),
            "cut_steps": sum(record.cuts for record in self.records),
            "newton_iterations": sum(record.newton_iterations + record.cut_iterations
                                     for record in self.records),
            "cut_iterations": sum(record.cut_iterations for record in self.records),
            "wall_s": self.timings.get("total_s"),
            "converged": self.converged,
            "ranks": self.sizes.get("ranks"),
        }
