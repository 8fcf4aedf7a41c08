"""The public Python API: load or generate a surface, evaluate the theory, build a FEM case (or
load it from a case file) and run it, with an error estimate on request; read a run back
(examples in docs/api.md).

Each name here is also an attribute of the package, imported on first use: ``import
roughfriction as rf; rf.theory(rf.load_surface("G5"), 0.155)``. The functions are the command
line's own (``studies.fem_input``, ``studies.fem_request``): the same guards, the same errors,
:class:`InputError` (one line) for input the user can fix, :class:`ConvergenceError` for an FEM
run that did not converge. The FEM stack is imported by :func:`run_fem`, and mpi4py and PETSc by
the memory check of a case built with ``n``.
"""

from __future__ import annotations

import warnings
from pathlib import Path

from roughfriction.case import FemCase, MeshOptions, SolverOptions
from roughfriction.errors import ConvergenceError, InputError
from roughfriction.geometry.generate import builtin_names, gaussian_surface, self_affine_surface
from roughfriction.geometry.readers import ReaderOptions, load_surface
from roughfriction.geometry.surface import Surface
from roughfriction.material import Material
from roughfriction.multiscale.theory import TheoryResult, evaluate_theory
from roughfriction.plausibility import check_material
from roughfriction.studies.fem_input import (
    MeshedSurface,
    build_case,
    case_from_config,
    read_config,
    surface_as_meshed,
)
from roughfriction.studies.post import RunFile, read_run
from roughfriction.studies.refinement import LadderLimits

__all__ = [
    # surfaces
    "Surface", "load_surface", "ReaderOptions", "builtin_names", "gaussian_surface",
    "self_affine_surface",
    # theory
    "Material", "theory", "TheoryResult",
    # FEM
    "FemCase", "MeshOptions", "SolverOptions", "fem_case", "load_case", "meshed_surface",
    "run_fem", "LadderLimits",
    # results
    "read_run", "RunFile",
    # errors
    "InputError", "ConvergenceError",
]


def theory(surface: Surface, load_star: float, material: Material | None = None, *,
           variant: str = "A") -> TheoryResult:
    """Multi-scale (Sect. 4.2), CKE (Eq. 8) and LET (Eq. 20) static friction of ``surface`` at
    the dimensionless normal load F* = F_n / (A_n S_y) [-] (Eq. 10), for ``material`` (default:
    the paper's); what ``roughfriction multiscale`` prints."""
    return evaluate_theory(surface, load_star, check_material(material or Material()),
                           variant=variant)


def fem_case(surface: Surface, load_star: float, *, n: int | None = None,
             window: int | str | None = None, normal_only: bool = False,
             material: Material | None = None, mesh: MeshOptions | None = None,
             solver: SolverOptions | None = None, measured: bool = False) -> FemCase:
    """The FEM case of ``surface`` at F* = ``load_star`` [-], as ``roughfriction fem`` builds it.

    Parameters
    ----------
    surface : Surface
        Heights and spacing [m].
    load_star : float
        F* = F_n / (A_n S_y) [-] (Eq. 10), checked before any re-gridding.
    n : int, optional
        Surface cells per side of the FEM grid (default: the surface's points per side); a run
        that would not fit in this machine's memory is refused before re-gridding.
    window : int or "best", optional
        With ``n`` below the surface's points: mesh window 1, 2, ... (row by row) of n x n
        points at the surface's own spacing, or the one whose psi is nearest the surface's
        (``--window``); None re-grids the surface (:func:`meshed_surface`).
    normal_only : bool
        Preload only (no mu_s).
    material, mesh, solver : Material, MeshOptions, SolverOptions, optional
        Defaults: the paper's material, the default mesh and solver options.
    measured : bool
        ``surface`` is a scan read from a file: a window loses its least-squares plane, and the
        periodic seam of the whole scan is checked (as the command does for a file).
    """
    case, meshed = build_case(surface, load_star, n=n, window=window, normal_only=normal_only,
                              material=material, mesh=mesh, solver=solver, measured=measured)
    _warn(meshed)
    return case


def load_case(path, surface: Surface, *, load: float | None = None, n: int | None = None,
              window: int | str | None = None, elastic: bool | None = None,
              normal_only: bool | None = None, measured: bool = False) -> FemCase:
    """The FEM case of ``surface`` that the TOML case file ``path`` describes, as
    ``roughfriction fem SURFACE --config PATH`` builds it.

    The file holds ``load``, ``n``, ``elastic``, ``normal_only`` and the tables ``[mesh]``,
    ``[solver]`` and ``[material]`` (SI units, or pressures with a unit: ``Sy = "800MPa"``);
    unknown keys and materials that are no metal's are refused. ``load``, ``n``, ``elastic``
    and ``normal_only`` given here replace the file's, as the command's flags do; ``window``
    and ``measured`` are those of :func:`fem_case`.
    """
    case, meshed = case_from_config(read_config(path), surface, load=load, n=n, window=window,
                                    elastic=elastic, normal_only=normal_only, measured=measured)
    _warn(meshed)
    return case


def meshed_surface(surface: Surface, n: int | None = None, window: int | str | None = None,
                   material: Material | None = None, *, measured: bool = False) -> Surface:
    """The surface the FEM meshes on n x n cells: window ``window`` (1, 2, ... or "best") at the
    surface's own spacing, or (``window`` None) the surface re-gridded over its scan length
    (``geometry.surface.surface_on_fem_grid``), with a warning giving psi (for ``material``)
    before and after when that makes it smoother; also warned: an RMS slope beyond the
    small-strain FEM (``measured``: see :func:`fem_case`)."""
    meshed = surface_as_meshed(surface, n, window, material or Material(), measured)
    _warn(meshed)
    return meshed.surface


def _warn(meshed: MeshedSurface) -> None:
    """Each note and warning on a meshed surface as a UserWarning, from the caller's caller."""
    for line in (*meshed.notes, *meshed.warnings):
        warnings.warn(line, UserWarning, stacklevel=3)


def run_fem(case: FemCase, output=None, *, tol: float | None = None,
            limits: LadderLimits | None = None, overwrite: bool = False, comm=None,
            progress=None, xdmf_directory=None) -> dict:
    """Preload ``case`` and (unless normal-only) slide it to inception: ``roughfriction fem``;
    with ``tol`` or ``limits``, on meshes 1x, 2x, 4x, ... finer until the estimated relative
    error of mu_s (normal-only: of A_r/A_n) is at most ``tol`` (``--tol``).

    Parameters
    ----------
    case : FemCase
        From :func:`fem_case` or :func:`load_case`.
    output : str or pathlib.Path, optional
        HDF5 results file (read back with :func:`read_run`; of a ladder, its finest level),
        written on rank 0 and checked before the run. If it holds this very request, converged
        and computed by this code, its summary is returned without a run; any other existing
        file is refused unless ``overwrite``.
    tol : float, optional
        Relative error to reach, in (0, 1) [-].
    limits : LadderLimits, optional
        What the ladder may spend (``max_level``, ``max_memory_gb``, ``max_time_s``) and how
        it refines (``ladder``: "adaptive" or "uniform"); without ``tol`` every level through
        ``max_level`` runs (``LadderLimits(max_level=1)`` is ``--refine``). The memory limit
        is at most what is available to ``comm``'s ranks.
    comm : mpi4py.MPI.Comm, optional
        Communicator (default ``MPI.COMM_WORLD``: under ``mpirun`` every rank calls this).
    progress : callable, optional
        Receives each progress record and line (``str()`` is its line); default: stderr on
        rank 0, as the command prints it.
    xdmf_directory : str or pathlib.Path, optional
        Write the fields (end of preload, inception; of level 0) to ``fields.xdmf`` there.

    Returns
    -------
    dict
        The summary ``roughfriction fem --json`` prints: the run's (``mu_s``,
        ``area_ratio_normal``, ..., ``psi_meshed``, ``material``, ``warnings``); of a ladder,
        its finest level's with ``mu_s_error`` (certified), ``mu_s_coarse``, ``levels``, ...

    Raises
    ------
    InputError
        A bad tolerance or limit, an output that cannot be written or exists, too little
        memory: before the run.
    ConvergenceError
        The run did not converge (after writing its partial results to ``output``); a ladder
        stopped short of ``tol`` by a limit (``ToleranceNotMet``, after writing its finest
        level).
    """
    from mpi4py import MPI
    from roughfriction.studies.fem_request import (
        FemOutputs,
        Voice,
        ladder_labels,
        request_digest,
        requested_ladder,
        run_request,
    )

    comm = comm or MPI.COMM_WORLD
    ladder = requested_ladder(tol, limits, comm)
    outputs = FemOutputs(None if output is None else Path(output),
                         request_digest(case, ladder_labels(ladder)),
                         fields=None if xdmf_directory is None else Path(xdmf_directory))
    voice = None if progress is None else Voice(lambda one_case: progress, progress)
    return run_request(case, outputs, ladder, comm, overwrite, voice)
