"""The surfaces and loads of the paper's comparison figures, declared once, and the FEM cases
built from them."""

import os

import numpy as np

#: Table 1 Gaussian surfaces (Figs. 20–25).
GAUSSIAN_SURFACES = tuple(f"G{k}" for k in range(1, 10))
#: Loads F* of Figs. 22–25 (mu_s vs psi).
PSI_SWEEP_LOADS = (0.155, 0.62, 0.93, 1.86)
#: Surfaces of Figs. 26–28 (mu_s vs F*).
LOAD_SWEEP_SURFACES = ("2L", "8L", "G5")
#: Loads F* of Figs. 26–28: ten values spanning the paper's range, log-spaced.
LOAD_SWEEP = tuple(float(f"{v:.3g}") for v in np.geomspace(0.05, 2.0, 10))

# --- FEM ------------------------------------------------------------------------------------
# Every FEM run costs minutes, so the FEM loads are few and chosen to share runs between
# figures: a normal-only case is answered by the sliding run of the same case when that is in
# the run cache (``studies.cache``), so ``make figures`` builds the sliding figures first.

#: FEM surface cells per side of the figures' runs (``--n`` or $ROUGHFRICTION_FEM_N override).
DEFAULT_FEM_N = 32
FEM_N_VARIABLE = "ROUGHFRICTION_FEM_N"
#: Points per side of the paper's surfaces: FEM figures on a coarser grid are previews [-].
PAPER_FEM_N = 128


def preview_note(n: int) -> str:
    """The line a FEM figure on ``n`` cells per side carries when it is a preview ("" on the
    paper's own grid)."""
    if n >= PAPER_FEM_N:
        return ""
    return (f"Quick preview: FEM on {n} x {n} surface cells, not the paper's {PAPER_FEM_N}² "
            f"surfaces (make figures N={PAPER_FEM_N})")
#: FEM loads F* of Figs. 26–28 (sliding); they include Fig. 14's loads and three of Figs. 22–25.
FEM_LOAD_SWEEP = (0.06, 0.155, 0.5, 0.62, 0.93, 1.86)
#: Loads F* of Fig. 8 (8L contact maps, normal load only).
CONTACT_MAP_LOADS = (0.06, 0.12)
#: FEM loads F* of Figs. 9–10 (8L patches and nodes, normal load only).
PATCH_LOADS = (0.06, 0.12, 0.155, 0.5, 0.93, 1.86)
#: FEM loads F* of Fig. 20 (A_r/A_n of G1–G9, normal load only).
AREA_LOADS = (0.06, *PSI_SWEEP_LOADS)
#: Load F* of Figs. 21 and 29 (F_t/F_n during the tangential loading of G1–G9).
CURVE_LOAD = 0.155
#: First and largest sliding increment of the runs of Figs. 21 and 29, a fraction of
#: tau_c H / G (``SolverOptions.first_slide``, ``max_slide_increment``) [-]: uniform steps
#: small enough to draw F_t(u_x) up to inception as a curve; the other runs keep the default
#: adaptive steps, which reach inception in a few.
CURVE_SLIDE_INCREMENT = 0.006
#: Loads F* whose mu-vs-psi figure also runs other windows of each G surface, to show how much
#: mu_s scatters between windows of one i.i.d. surface (at F* = 0.155 a run takes seconds).
WINDOW_SCATTER_LOADS = (0.155,)
#: Most windows per surface in that scatter [-].
SCATTER_WINDOWS = 4
#: Loads F* at which the mu_s figures (22–28) also run each FEM point on a 2x finer mesh of the
#: same surface (``studies.refinement.next_mesh``): the point drawn is the 2x value, its bar
#: the certificate of that value (``studies.certificate``). Every FEM load of those figures.
ERROR_BAR_LOADS = tuple(sorted({*FEM_LOAD_SWEEP, *PSI_SWEEP_LOADS}))
#: Surface and load F* of Fig. 15 (junction growth; Fig. 17 shows the theory at this load).
JUNCTION_SURFACE, JUNCTION_LOAD = "2L", 0.5


def fem_resolution(n=None) -> int:
    """Surface cells per side of the FEM runs [-]: ``n``, else $ROUGHFRICTION_FEM_N, else
    :data:`DEFAULT_FEM_N`."""
    from roughfriction.errors import InputError

    value = n if n is not None else os.environ.get(FEM_N_VARIABLE, DEFAULT_FEM_N)
    try:
        value = int(value)
    except ValueError:
        raise InputError(f"FEM resolution must be an integer, got {value!r}") from None
    if value < 4:
        raise InputError(f"FEM resolution must be >= 4 surface cells per side, got {value}")
    return value


def fem_surface(name: str, n: int, window: int | None = None):
    """The surface an FEM run of built-in surface ``name`` meshes with n x n cells.

    G1–G9 (i.i.d. heights) below their own 128 x 128 grid: an n x n window of their points at
    their own spacing (windows tile the grid row by row; by default the one whose psi is
    nearest the whole surface's), so the FEM meshes the surface's psi; a re-grid to n points
    would be a smoother surface (psi / 4.8 at n = 32). Otherwise, and for the self-affine
    stand-ins, whose windows lose the long wavelengths, the surface re-gridded to n x n
    (``geometry.surface.surface_on_fem_grid``): below 128 a smoother surface, whose psi the
    figures report as ``psi_fem``.
    """
    from roughfriction.geometry.generate import builtin_surface
    from roughfriction.geometry.surface import surface_on_fem_grid

    surface = builtin_surface(name)
    if name not in GAUSSIAN_SURFACES or n >= surface.n:
        return surface_on_fem_grid(surface, n)
    return surface_window(surface, n, window)


def surface_window(surface, n: int, window: int | None = None, measured: bool = False):
    """Window ``window`` (0-based, row by row) of the n x n windows of ``surface`` at its own
    spacing (``geometry.surface.windows``); None: the one whose psi is nearest the whole
    surface's.

    ``measured`` (a scan read from a file): each window loses its own least-squares plane before
    the choice, and a UserWarning says when the chosen one's periodic seam is a step of its own
    (``geometry.statistics.periodic_seam_warning``). Built-in surfaces' windows are kept as cut
    (``measured`` False).
    """
    import warnings

    from roughfriction.errors import InputError
    from roughfriction.geometry.statistics import periodic_seam_warning, surface_statistics
    from roughfriction.geometry.surface import Surface, detrend_plane, windows
    from roughfriction.material import Material

    candidates = windows(surface, n)
    if measured:
        candidates = [Surface(detrend_plane(one.heights), one.spacing, one.name)
                      for one in candidates]
    if window is None:
        psi = [surface_statistics(one, Material()).psi for one in (surface, *candidates)]
        window = int(np.argmin(np.abs(np.array(psi[1:]) - psi[0])))
    if not 0 <= window < len(candidates):
        raise InputError(f"{surface.name} has {len(candidates)} windows of {n} x {n} points, "
                         f"not {window + 1}")
    chosen = candidates[window]
    seam = periodic_seam_warning(chosen) if measured else None
    if seam:
        warnings.warn(f"window {window + 1} of {seam}", UserWarning, stacklevel=2)
    return chosen


def scatter_windows(name: str, n: int) -> list[int]:
    """Indices (0-based, row by row) of up to :data:`SCATTER_WINDOWS` n x n windows of
    surface ``name`` on its grid's diagonal (no two share a row or column of points); none if
    the FEM meshes the whole surface (:func:`fem_surface`)."""
    from roughfriction.geometry.generate import builtin_surface

    per_side = builtin_surface(name).n // n
    if name not in GAUSSIAN_SURFACES or per_side < 2:
        return []
    rows = np.unique(np.round(np.linspace(0, per_side - 1, min(SCATTER_WINDOWS, per_side))))
    return [int(row) * (per_side + 1) for row in rows]


def window_cases(name: str, load: float, n: int) -> list:
    """Sliding FEM cases of the :func:`scatter_windows` of ``name`` at F* = ``load``."""
    from roughfriction.case import FemCase, Loading

    return [FemCase(fem_surface(name, n, window), Loading(load))
            for window in scatter_windows(name, n)]


def curve_case(name: str, n: int):
    """The run of built-in surface ``name`` on n x n cells drawn in Figs. 21 and 29: at
    F* = :data:`CURVE_LOAD`, sliding in uniform steps of :data:`CURVE_SLIDE_INCREMENT`."""
    from dataclasses import replace

    case = fem_case(name, CURVE_LOAD, n)
    return replace(case, solver=replace(case.solver, first_slide=CURVE_SLIDE_INCREMENT,
                                        max_slide_increment=CURVE_SLIDE_INCREMENT))


def fem_case(name: str, load: float, n: int, normal_only: bool = False):
    """The FEM case of built-in surface ``name`` on n x n cells (:func:`fem_surface`), at
    F* = ``load`` [-], with the default material, mesh and solver options."""
    from roughfriction.case import FemCase, Loading

    return FemCase(fem_surface(name, n), Loading(load, normal_only))
