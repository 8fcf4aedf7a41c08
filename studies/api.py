"""The public Python API: load or generate a surface, evaluate the theory, run one FEM case, read
a run back (examples in docs/api.md).

Each name here is also an attribute of the package, imported on first use: ``import
roughfriction as rf; rf.theory(rf.load_surface("G5"), 0.155)``. The functions pass the command
line's guards and raise its errors: :class:`InputError` (one line) for input the user can fix,
:class:`ConvergenceError` for an FEM run that did not converge. The FEM stack (dolfinx, mpi4py)
is imported by :func:`run_fem` only.
"""

from __future__ import annotations

import warnings
from pathlib import Path

from roughfriction.case import FemCase, Loading, MeshOptions, SolverOptions
from roughfriction.errors import ConvergenceError, InputError
from roughfriction.files import agreed, check_results_file
from roughfriction.geometry.generate import builtin_names, gaussian_surface, self_affine_surface
from roughfriction.geometry.readers import load_surface
from roughfriction.geometry.statistics import surface_statistics
from roughfriction.geometry.surface import Surface, surface_on_fem_grid, validate_grid_points
from roughfriction.material import Material
from roughfriction.multiscale.theory import TheoryResult, evaluate_theory
from roughfriction.plausibility import check_material
from roughfriction.studies.paper import surface_window
from roughfriction.studies.post import RunFile, read_run

__all__ = [
    # surfaces
    "Surface", "load_surface", "builtin_names", "gaussian_surface", "self_affine_surface",
    # theory
    "Material", "theory", "TheoryResult",
    # FEM
    "FemCase", "MeshOptions", "SolverOptions", "fem_case", "meshed_surface", "run_fem",
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
             solver: SolverOptions | None = None) -> FemCase:
    """The FEM case of ``surface`` at F* = ``load_star`` [-], as ``roughfriction fem`` builds it.

    Parameters
    ----------
    surface : Surface
        Heights and spacing [m].
    load_star : float
        F* = F_n / (A_n S_y) [-] (Eq. 10), checked before any re-gridding.
    n : int, optional
        Surface cells per side of the FEM grid (default: the surface's points per side).
    window : int or "best", optional
        With ``n`` below the surface's points: mesh window 1, 2, ... (row by row) of n x n
        points at the surface's own spacing, or the one whose psi is nearest the surface's
        (``--window``); None re-grids the surface (:func:`meshed_surface`).
    normal_only : bool
        Preload only (no mu_s).
    material, mesh, solver : Material, MeshOptions, SolverOptions, optional
        Defaults: the paper's material, the default mesh and solver options.
    """
    loading = Loading(load_star, normal_only)
    material = check_material(material or Material())
    return FemCase(meshed_surface(surface, n, window, material), loading, material,
                   mesh or MeshOptions(), solver or SolverOptions())


def meshed_surface(surface: Surface, n: int | None = None, window: int | str | None = None,
                   material: Material | None = None) -> Surface:
    """The surface the FEM meshes on n x n cells: window ``window`` (1, 2, ... or "best") at the
    surface's own spacing, or (``window`` None) the surface re-gridded over its scan length
    (``geometry.surface.surface_on_fem_grid``), with a warning giving psi (for ``material``)
    before and after when that makes it smoother."""
    if n is not None:
        n = validate_grid_points(n)
    if window is not None:
        return _window(surface, n, window)
    meshed = surface_on_fem_grid(surface, n)
    note = regrid_note(surface, meshed, material or Material())
    if note:
        warnings.warn(note, stacklevel=3)
    return meshed


def regrid_note(surface: Surface, meshed: Surface, material: Material) -> str | None:
    """One line when ``meshed`` is ``surface`` re-gridded over its scan length (coarser: a
    smoother surface; finer: Fourier-interpolated between its points), with the psi of both
    for ``material``; None when it is the surface as is. Both front doors say it."""
    if meshed.n == surface.n:
        return None
    psi = [surface_statistics(one, material).psi for one in (surface, meshed)]
    name, change = surface.name or "surface", f"psi {psi[0]:.3g} -> {psi[1]:.3g}"
    if meshed.n < surface.n:
        return (f"{name} re-gridded from {surface.n} to {meshed.n} points per side over its "
                f"scan length: {change} (a smoother surface); window 'best' (--window best) "
                f"meshes a {meshed.n} x {meshed.n} window at its own spacing")
    return (f"{name} Fourier-interpolated from {surface.n} to {meshed.n} points per side: "
            f"{change}, heights made up between the measured points ({meshed.n ** 2} surface "
            f"cells, {meshed.n ** 2 / surface.n ** 2:.3g}x the surface's own grid); the measured "
            "surface on a finer mesh is --tol (or --refine)")


def _window(surface: Surface, n: int | None, window: int | str) -> Surface:
    """Window ``window`` ("best" or 1, 2, ... row by row) of n x n points of ``surface``."""
    if n is None or n >= surface.n:
        raise InputError(f"a window needs n below the surface's {surface.n} points per side")
    if window == "best":
        return surface_window(surface, n)
    if isinstance(window, bool) or not isinstance(window, int) or window < 1:
        raise InputError(f"window takes 'best' or a window number 1, 2, ..., got {window!r}")
    return surface_window(surface, n, window - 1)


def run_fem(case: FemCase, output=None, *, overwrite: bool = False, comm=None, progress=None,
            xdmf_directory=None):
    """Preload ``case`` and (unless normal-only) slide it to inception: ``roughfriction fem``.

    Parameters
    ----------
    case : FemCase
        From :func:`fem_case`.
    output : str or pathlib.Path, optional
        HDF5 results file (read back with :func:`read_run`), written on rank 0 and checked
        before the run; an existing file is replaced only with ``overwrite``.
    comm : mpi4py.MPI.Comm, optional
        Communicator (default ``MPI.COMM_WORLD``: under ``mpirun`` every rank calls this).
    progress : callable, optional
        Receives each progress record (``str()`` is its line); default: stderr on rank 0.
    xdmf_directory : str or pathlib.Path, optional
        Write the fields (end of preload, inception) to ``fields.xdmf`` there.

    Returns
    -------
    solver.run.FemRun
        ``.result.mu_s``, ``.result.summary()`` (the command's JSON), ``.maps``.

    Raises
    ------
    InputError
        An output that cannot be written or exists, too little memory: before the run.
    ConvergenceError
        The run did not converge (after writing its partial results to ``output``).
    """
    from mpi4py import MPI
    from roughfriction.solver.run import run
    from roughfriction.studies.results_file import save_run

    comm = comm or MPI.COMM_WORLD
    if output is not None:
        output = agreed(comm, lambda: writable_output(Path(output), overwrite))
    fem = run(case, comm, progress, xdmf_directory)
    if output is not None:
        psi = surface_statistics(case.surface, case.material).psi
        save_run(output, case, fem, comm, extra={"psi_meshed": psi})
    if not fem.result.converged:
        where = f" (partial results in {output})" if output is not None else ""
        raise ConvergenceError(f"FEM run did not converge: {fem.result.message}{where}")
    return fem


def writable_output(path: Path, overwrite: bool) -> Path:
    """``path``, once a results file can be written there without replacing one unless
    ``overwrite`` (:func:`roughfriction.files.check_results_file`); else InputError."""
    check_results_file(path)
    if path.exists() and not overwrite:
        raise InputError(f"results file {path} exists; pass overwrite=True to replace it")
    return path
