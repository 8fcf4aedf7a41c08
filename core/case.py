"""The FEM case: what is computed (Loading) and how (MeshOptions, SolverOptions), with the surface
and material in one frozen ``FemCase`` that flows from the command line to the results.

Plain data and checks only (no NumPy, no FEM): every layer of the package can import it."""

from __future__ import annotations

import hashlib
import math
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING

from roughfriction.errors import InputError
from roughfriction.material import Material

if TYPE_CHECKING:  # the case holds a surface; the core does not import the geometry layer
    from roughfriction.geometry.surface import Surface

LINEAR_SOLVERS = ("auto", "direct", "iterative")
INTEGRATIONS = ("selective", "full")
#: Resolutions of a refined level's blend zone below its fine layers (MeshOptions.blend_zone).
BLEND_ZONES = ("fine", "coarse")

#: Largest dimensionless normal load F* = F_n / (A_n S_y) accepted [-]: a mean nominal pressure
#: of 100 S_y. A plastic surface is in complete contact by the hardness (about 2.8 S_y), and the
#: elastic verification runs (a sinusoid pressed to 20 times its complete-contact pressure) need
#: F* = 12; a larger F* is a pressure given in MPa or Pa.
MAX_LOAD_STAR = 100.0
#: Largest RMS surface slope accepted [-] (84 degrees). Machined and lapped surfaces have 0.003
#: to 1.2 (the built-in 63M); heights in micrometres taken as metres give 1e3 and more.
MAX_RMS_SLOPE = 10.0


def check_load_star(load_star: float) -> float:
    """``load_star`` as a float if it is a plausible F* = F_n / (A_n S_y) [-] (Eq. 10): finite,
    > 0 and at most :data:`MAX_LOAD_STAR`; else InputError."""
    try:
        load_star = float(load_star)
    except (TypeError, ValueError):
        raise InputError(f"normal load F* must be a number, got {load_star!r}") from None
    if not (math.isfinite(load_star) and load_star > 0):
        raise InputError(f"normal load F* must be > 0, got {load_star}")
    if load_star > MAX_LOAD_STAR:
        raise InputError(f"normal load F* = {load_star:g} > {MAX_LOAD_STAR:g}: F* is "
                         "F_n / (A_n S_y), dimensionless (a mean pressure of F* S_y)")
    return load_star


def check_surface_slope(surface: Surface) -> None:
    """Refuse a surface whose RMS slope (``Surface.rms_slope``) exceeds :data:`MAX_RMS_SLOPE`:
    its heights are not in metres, or not on its grid spacing [m]."""
    slope = surface.rms_slope
    if not slope <= MAX_RMS_SLOPE:
        raise InputError(f"surface {surface.name or 'surface'!r}: RMS slope {slope:.3g} > "
                         f"{MAX_RMS_SLOPE:g}: heights and spacing must both be in metres")


@dataclass(frozen=True, eq=False)
class ZoneRefinement:
    """The contact-adaptive mesh of ``geometry.adaptive``: the surface zone refined 2x per level.

    Parameters
    ----------
    level : int
        L: the zone's surface cells are h / 2^L wide (h the surface's grid spacing) [-], >= 0.
    zone : numpy.ndarray
        Cells to refine, bool, on the grid of a level m <= L: shape (n 2^m, n 2^m) for an
        n x n surface (m = 0: its own cells; m = L - 1: the previous level's contact, say).
        The rest of the surface is as coarse as the 2:1 balance allows.
    """

    level: int
    zone: object

    def __post_init__(self):
        if isinstance(self.level, bool) or int(self.level) != self.level or self.level < 0:
            raise InputError(f"refinement level must be an integer >= 0, got {self.level!r}")
        shape = getattr(self.zone, "shape", ())
        if len(shape) != 2 or shape[0] != shape[1]:
            raise InputError(f"refinement zone must be a square cell mask, got shape {shape}")

    def inputs(self) -> dict:
        """The refinement as plain values: level, zone size and cells, SHA-256 of the mask."""
        mask = self.zone.astype(bool)
        return {"level": int(self.level), "zone_size": int(mask.shape[0]),
                "zone_cells": int(mask.sum()),
                "zone_sha256": hashlib.sha256(mask.tobytes()).hexdigest()}


@dataclass(frozen=True)
class MeshOptions:
    """How the block under the surface is layered.

    Parameters
    ----------
    blend_layers : int
        Layers of thickness h (the grid spacing) over which the roughness fades to flat [-].
    fine_layers : int
        Layers at the full lateral resolution (thickness h) from the surface down, blend layers
        included [-]; ``blend_layers`` if smaller.
    coarsen : bool
        Below the fine layers, halve the lateral resolution level by level (2:1, hanging nodes
        tied exactly), while N stays divisible and at least 2 cells per side remain.
    growth : float
        Thickness ratio of successive layers going down where the lateral size no longer
        changes (no coarsening, or the coarsest level reached) [-], >= 1.
    depth : float
        Minimum block depth below the mean surface plane, in periods (N h) [-]. A surface
        wavelength lambda decays like exp(-2 pi z / lambda): at one period the longest one is down
        to exp(-2 pi) ~ 0.2 %.
    refinement : ZoneRefinement, optional
        Refine the surface zone only (``geometry.adaptive``); ``blend_layers`` then counts
        layers h thick of the surface's own grid (the blend zone is as deep at every level),
        ``fine_layers`` layers of the finest grid (h / 2^L thick), and the layers follow
        ``geometry.adaptive.adaptive_layers``. None: no refinement, level 0 (the surface's own
        grid everywhere; ``geometry.adaptive.block_layout`` is where None becomes that layout).
    blend_zone : {"fine", "coarse"}
        Resolution of a refined level's blend zone below its ``fine_layers``: "fine", the
        finest grid through the blend depth; "coarse", the previous level's (cells twice as
        wide and thick, ``geometry.adaptive.coarse_blend_zone``). Level 0 has no previous one.
    """

    blend_layers: int = 2
    fine_layers: int = 2
    coarsen: bool = True
    growth: float = 1.4
    depth: float = 1.0
    refinement: ZoneRefinement | None = None
    blend_zone: str = "fine"

    def __post_init__(self):
        for name in ("blend_layers", "fine_layers"):
            value = getattr(self, name)
            if isinstance(value, bool) or int(value) != value:
                raise InputError(f"{name} must be an integer, got {value!r}")
            if value < 1:
                raise InputError(f"{name} must be >= 1, got {value}")
        if not isinstance(self.coarsen, bool):
            raise InputError(f"coarsen must be true or false, got {self.coarsen!r}")
        if not (math.isfinite(self.growth) and 1.0 <= self.growth <= 3.0):
            raise InputError(f"layer growth ratio must lie in [1, 3], got {self.growth}")
        if not (math.isfinite(self.depth) and self.depth > 0):
            raise InputError(f"block depth must be > 0 periods, got {self.depth}")
        if self.blend_zone not in BLEND_ZONES:
            raise InputError(f"blend_zone must be one of {', '.join(BLEND_ZONES)}, got "
                             f"{self.blend_zone!r}")
        if self.refinement is not None and not isinstance(self.refinement, ZoneRefinement):
            raise InputError(f"mesh refinement must be a ZoneRefinement, got "
                             f"{type(self.refinement).__name__}")

    def inputs(self) -> dict:
        """The options as plain values (the refinement's zone by its digest)."""
        values = {name: getattr(self, name) for name in
                  ("blend_layers", "fine_layers", "coarsen", "growth", "depth")}
        if self.blend_zone != BLEND_ZONES[0]:  # the default keeps the keys of earlier runs
            values["blend_zone"] = self.blend_zone
        if self.refinement is not None:
            values["refinement"] = self.refinement.inputs()
        return values


@dataclass(frozen=True)
class Loading:
    """Normal preload, then (unless ``normal_only``) tangential sliding of the flat.

    Parameters
    ----------
    load_star : float
        Dimensionless normal load F* = F_n / (A_n S_y) [-].
    normal_only : bool
        Stop after the preload (no mu_s).
    """

    load_star: float
    normal_only: bool = False

    def __post_init__(self):
        check_load_star(self.load_star)


@dataclass(frozen=True)
class SolverOptions:
    """Numerical choices of the FEM solve.

    Parameters
    ----------
    elastic : bool
        Linear elastic solid (no plasticity).
    integration : {"selective", "full"}
        Pressure at 1 point per cell (SRI, default) or at 2 x 2 x 2 points (locks).
    penalty : float
        Normal contact penalty eps_N = penalty E' / h_grid [-].
    tangential_penalty : float
        Stick penalty eps_T = tangential_penalty eps_N [-] (see :mod:`solver.contact`: a
        tenth keeps Newton from flipping stick and slip near inception; mu_s does not change).
    friction_ramp : float
        The shear cap tau_c min(1, p / p_r) rises with the contact pressure p up to
        p_r = friction_ramp S_y [-]; 0 gives the paper's pure cap tau_c, with which a node at a
        patch edge can have no consistent contact state (see :mod:`solver.contact`).
    contact_points : int
        Gauss points per side of each surface face where gap and friction are evaluated
        (n x n per face; even, so that each point lies in the tributary quarter of one node) [-].
    penetration_tolerance : float
        Augmented Lagrangian: Uzawa updates until no contact node penetrates deeper than this
        times the grid spacing [-].
    max_augmentations : int
        Uzawa updates per load step before the step counts as failed [-].
    linear_solver : {"auto", "direct", "iterative"}
        CG preconditioned by MUMPS Cholesky factors or by GAMG, or "auto": direct up to
        ``direct_limit`` reduced dofs.
    direct_limit : int
        Largest reduced system solved directly by "auto" [dofs]. A nearly incompressible solid
        (nu -> 0.5) needs "direct": GAMG-preconditioned CG then stalls.
    residual_tolerance : float
        Newton: ||R|| and |sum p a - F_n| below this times F_n [-] (a Newton solve that
        stagnates within ``solver.newton_options.NewtonOptions.residual_floor`` times it is
        accepted).
    increment_tolerance : float
        Newton: max |du| below this times the grid spacing [-] (the penetration tolerance:
        the displacement is not known better than that).
    max_iterations : int
        Newton iterations per active-set round before a step is cut [-] (up to
        ``NewtonOptions.max_rounds`` rounds while the contact set settles).
    normal_increments : int
        Initial number of preload increments [-] (adapted).
    max_preload_increment : float
        Largest preload increment as a fraction of F_n [-] (the plastic path depends on it:
        ``bench path`` measures mu_s against a 4x finer path; an elastic preload takes the
        whole load at once).
    first_slide : float
        First tangential increment as a fraction of tau_c H / G, the slide at which a flat
        block would slip [-] (adapted).
    max_slide_increment : float
        Largest tangential increment as a fraction of tau_c H / G [-] (resolves the F_t(U)
        curve and where inception falls: ``bench path``).
    max_slide : float
        Give up (unconverged) if sliding has not started after this multiple of tau_c H / G [-].
    stuck_shear_tolerance : float
        Sliding inception: every contact node slips, or the shear the sticking contact could
        still add (its c(p) - t_x over its area) and F_t's change over the last two sliding
        steps are both at most this fraction of F_t, so that nodes that have just touched,
        stuck at a small pressure, do not hold the flat on its plateau of F_t [-].
    max_steps : int
        Upper bound on accepted plus cut steps [-].
    """

    elastic: bool = False
    integration: str = "selective"
    penalty: float = 40.0
    tangential_penalty: float = 0.1
    friction_ramp: float = 0.025
    contact_points: int = 2
    penetration_tolerance: float = 1e-4
    max_augmentations: int = 10
    linear_solver: str = "auto"
    direct_limit: int = 1_000
    residual_tolerance: float = 1e-6
    increment_tolerance: float = 1e-4
    max_iterations: int = 15
    normal_increments: int = 5
    max_preload_increment: float = 0.5
    first_slide: float = 0.02
    max_slide_increment: float = 0.25
    max_slide: float = 20.0
    stuck_shear_tolerance: float = 1e-3
    max_steps: int = 300

    def __post_init__(self):
        if self.integration not in INTEGRATIONS:
            raise InputError(f"integration must be one of {INTEGRATIONS}, got {self.integration!r}")
        if self.linear_solver not in LINEAR_SOLVERS:
            raise InputError(
                f"linear solver must be one of {LINEAR_SOLVERS}, got {self.linear_solver!r}")
        positive = ("penalty", "tangential_penalty", "penetration_tolerance", "residual_tolerance",
                    "increment_tolerance", "first_slide", "max_slide", "max_slide_increment",
                    "stuck_shear_tolerance")
        for name, value in ((name, getattr(self, name)) for name in positive):
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"solver option {name} must be > 0, got {value}")
        for name in ("direct_limit", "max_iterations", "normal_increments", "max_steps",
                     "contact_points"):
            if getattr(self, name) < 1:
                raise InputError(f"solver option {name} must be >= 1, got {getattr(self, name)}")
        if self.contact_points % 2:
            raise InputError(f"solver option contact_points must be even, got "
                             f"{self.contact_points}")
        if not (math.isfinite(self.friction_ramp) and 0.0 <= self.friction_ramp < 1.0):
            raise InputError(f"solver option friction_ramp must lie in [0, 1), got "
                             f"{self.friction_ramp}")
        if not (math.isfinite(self.max_preload_increment)
                and 0.0 < self.max_preload_increment <= 1.0):
            raise InputError(f"solver option max_preload_increment must lie in (0, 1], got "
                             f"{self.max_preload_increment}")
        if self.max_augmentations < 0:
            raise InputError(f"solver option max_augmentations must be >= 0, got "
                             f"{self.max_augmentations}")


@dataclass(frozen=True, eq=False)
class FemCase:
    """Everything one FEM run depends on.

    Parameters
    ----------
    surface : Surface
        Height map on the FEM grid (N x N, spacing h [m]); the block's period is N h.
    loading : Loading
        Preload and sliding.
    material : Material
        Constants [Pa].
    mesh : MeshOptions
        Layering of the block.
    solver : SolverOptions
        Numerics.
    """

    surface: Surface
    loading: Loading
    material: Material = field(default_factory=Material)
    mesh: MeshOptions = field(default_factory=MeshOptions)
    solver: SolverOptions = field(default_factory=SolverOptions)

    def __post_init__(self):
        check_surface_slope(self.surface)

    @property
    def nominal_area(self) -> float:
        """A_n = (N h)^2 [m^2]."""
        return self.surface.period**2

    @property
    def normal_force(self) -> float:
        """Target F_n = F* A_n S_y [N]."""
        return self.loading.load_star * self.nominal_area * self.material.Sy

    def inputs(self) -> dict:
        """The case as nested plain values (for results files)."""
        return {
            "surface": {"name": self.surface.name, "n": self.surface.n,
                        "spacing_m": self.surface.spacing, "sha256": self.surface.digest()},
            "loading": asdict(self.loading),
            "material": asdict(self.material),
            "mesh": self.mesh.inputs(),
            "solver": asdict(self.solver),
        }
