"""Discretisation error of a FEM result from the same surface on finer meshes.

A run resolves its surface as the bilinear interpolant through the grid points; a mesh refined
by a factor r samples that interpolant r times finer (``geometry.surface.bilinear_refine``), so
every mesh of a ladder sees the same surface and the results differ by discretisation only.
With results f_1, f_2 (, f_4) on meshes of spacing h, h/2 (, h/4):

* two meshes: Richardson extrapolation at an assumed order p, f_inf = f_2 + (f_2 - f_1) /
  (2^p - 1), and the error estimate of f_2 is |f_2 - f_1| / (2^p - 1);
* three meshes: the observed order p = log2(|f_2 - f_1| / |f_4 - f_2|) and the same
  extrapolation from the two finest.

The estimate can be trusted in the asymptotic range, where the observed order is steady: with
two meshes that is an assumption (p = 1 is the conservative choice for a contact area counted
at points: its error is proportional to the contact perimeter times the spacing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from roughfriction.case import FemCase
from roughfriction.geometry.mesh import blend_layers_needed
from roughfriction.geometry.surface import Surface, bilinear_refine

#: Order assumed with two meshes [-].
ASSUMED_ORDER = 1.0
#: Spacing ratio of consecutive meshes of a ladder (:func:`richardson`) [-].
LADDER_RATIO = 2


def refined_case(case: FemCase, factor: int) -> FemCase:
    """The case on a mesh ``factor`` times finer: the same (bilinear) surface, sampled finer,
    with at least the blend layers its deepest valley needs at the finer spacing
    (:func:`geometry.mesh.blend_layers_needed`; the layers are thinner)."""
    if factor == 1:
        return case
    surface = case.surface
    fine = Surface(bilinear_refine(surface.heights, factor), surface.spacing / factor,
                   surface.name)
    blend_layers = max(case.mesh.blend_layers, blend_layers_needed(fine.heights, fine.spacing))
    return replace(case, surface=fine, mesh=replace(case.mesh, blend_layers=blend_layers))


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
