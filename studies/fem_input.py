"""The input of a FEM request: the case, from keyword settings or a TOML case file, with every
guard that both front doors (``studies.api`` and ``roughfriction fem``) pass.

A case file holds ``load``, ``n``, ``elastic``, ``normal_only`` and the tables ``[mesh]``,
``[solver]`` (the fields of ``MeshOptions`` and ``SolverOptions``) and ``[material]`` (SI units,
or pressures with a unit: ``Sy = "800MPa"``); unknown keys are refused. The guards run in this
order, each before any work that the next would waste: the case file's keys and values, the
material's plausibility (``plausibility.check_material``), F* (``case.check_load_star``), the
grid size and the memory its run needs, the window; then the surface is cut or re-gridded, with
one line for each thing the user should know about it (:class:`MeshedSurface`).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, fields

from roughfriction.case import FemCase, Loading, MeshOptions, SolverOptions
from roughfriction.errors import InputError
from roughfriction.geometry.statistics import (
    periodic_seam_warning,
    small_strain_slope,
    surface_statistics,
)
from roughfriction.geometry.surface import Surface, surface_on_fem_grid, validate_grid_points
from roughfriction.material import Material
from roughfriction.plausibility import check_material, material_from_table
from roughfriction.studies.paper import surface_window

#: A case file's tables and the options each one sets.
CONFIG_TABLES = {"mesh": MeshOptions, "solver": SolverOptions, "material": Material}
#: A case file's top-level keys (each also a keyword of :func:`case_from_config`).
CONFIG_KEYS = {"load", "n", "elastic", "normal_only"}


@dataclass(frozen=True)
class InputNames:
    """How a front door names its inputs in the messages of a refusal.

    Attributes
    ----------
    load, n, window : str
        The normal load F*, the grid size and the window.
    case_file : str
        The TOML case file.
    overwrite, output, fields : str
        Replacing an existing file, the results file, the fields' folder.
    """

    load: str
    n: str
    window: str
    case_file: str
    overwrite: str
    output: str
    fields: str


#: The Python API's names (the keywords of ``fem_case``, ``load_case`` and ``run_fem``).
PYTHON_NAMES = InputNames(load="load=F*", n="n", window="window", case_file="the case file",
                          overwrite="overwrite=True", output="output",
                          fields="xdmf_directory")


@dataclass(frozen=True)
class MeshedSurface:
    """The surface an FEM case meshes, with what its user should be told about it.

    Attributes
    ----------
    surface : Surface
        Heights [m] on the FEM grid.
    notes : tuple of str
        What was done to the surface (a re-gridding, with psi before and after), one line each.
    warnings : tuple of str
        What makes a result on it doubtful (an RMS slope beyond the small-strain FEM, a
        periodic seam that is a step of its own), one line each.
    """

    surface: Surface
    notes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()

    def lines(self) -> list[str]:
        """The notes and warnings as the command prints them: ``note: ...``, ``warning: ...``."""
        return [f"note: {line}" for line in self.notes] + [f"warning: {line}"
                                                           for line in self.warnings]


def read_config(path) -> dict:
    """The case file at ``path`` as a dict (empty for None); unknown keys are refused."""
    if path is None:
        return {}
    try:
        with open(path, "rb") as file:
            config = tomllib.load(file)
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise InputError(f"cannot read case file {path}: {error}") from None
    unknown = set(config) - CONFIG_KEYS - set(CONFIG_TABLES)
    for table, kind in CONFIG_TABLES.items():
        known = {f.name for f in fields(kind)}
        unknown |= {f"{table}.{key}" for key in config.get(table, {}) if key not in known}
    if unknown:
        raise InputError(f"unknown keys in {path}: {', '.join(sorted(unknown))}")
    return config


def case_from_config(config: dict, surface: Surface, *, load=None, n=None, window=None,
                     elastic=None, normal_only=None, measured: bool = False, comm=None,
                     finest_factor: int = 1,
                     names: InputNames = PYTHON_NAMES) -> tuple[FemCase, MeshedSurface]:
    """The case of a case file (:func:`read_config`) with ``load``, ``n``, ``elastic`` and
    ``normal_only`` given here (not None) over the file's; ``window`` and the rest as in
    :func:`build_case`. Returns the case and its :class:`MeshedSurface`."""
    def setting(name, given):
        return given if given is not None else config.get(name)

    load, n = setting("load", load), setting("n", n)
    if load is None:
        raise InputError(f"the normal load is required: {names.load} (or load = ... in "
                         f"{names.case_file})")
    solver = dict(config.get("solver", {}))
    if setting("elastic", elastic) is not None:
        solver["elastic"] = bool(setting("elastic", elastic))
    try:
        options = (material_from_table(config.get("material", {})),
                   MeshOptions(**config.get("mesh", {})), SolverOptions(**solver))
    except TypeError as error:
        raise InputError(f"bad case settings: {error}") from None
    return build_case(surface, load, n=n, window=window,
                      normal_only=bool(setting("normal_only", normal_only)), material=options[0],
                      mesh=options[1], solver=options[2], measured=measured, comm=comm,
                      finest_factor=finest_factor, names=names)


def build_case(surface: Surface, load_star, *, n=None, window=None, normal_only: bool = False,
               material: Material | None = None, mesh: MeshOptions | None = None,
               solver: SolverOptions | None = None, measured: bool = False, comm=None,
               finest_factor: int = 1,
               names: InputNames = PYTHON_NAMES) -> tuple[FemCase, MeshedSurface]:
    """The FEM case of ``surface`` at F* = ``load_star`` [-], and its :class:`MeshedSurface`.

    Checks, before anything is re-gridded: F* (``case.check_load_star``), the material
    (``plausibility.check_material``), ``n`` and the memory of a run on ``n * finest_factor``
    cells per side on ``comm``'s ranks (``solver.memory.check_memory``; default
    ``MPI.COMM_SELF``; with ``n`` only). ``window``, ``measured``: :func:`surface_as_meshed`;
    ``names``: how the messages name the inputs.
    """
    loading = Loading(load_star, bool(normal_only))
    material = check_material(material or Material())
    mesh = mesh or MeshOptions()
    if n is not None:
        n = validate_grid_points(n)
        check_run_memory(n * finest_factor, mesh, comm)
    meshed = surface_as_meshed(surface, n, window, material, measured, names)
    return FemCase(meshed.surface, loading, material, mesh, solver or SolverOptions()), meshed


def check_run_memory(n: int, mesh: MeshOptions, comm=None) -> None:
    """Refuse (:class:`InputError`) an n x n run that would not fit in the memory available to
    ``comm``'s ranks (default ``MPI.COMM_SELF``), before anything is allocated."""
    from mpi4py import MPI
    from roughfriction.solver.memory import check_memory

    check_memory(n, mesh, comm or MPI.COMM_SELF)


def surface_as_meshed(surface: Surface, n: int | None, window, material: Material,
                      measured: bool = False, names: InputNames = PYTHON_NAMES) -> MeshedSurface:
    """The surface the FEM meshes on n x n cells, with its notes and warnings.

    ``window`` (1, 2, ... row by row, or "best": the one whose psi is nearest the whole
    surface's; :func:`window_index`): an n x n window at the surface's own spacing, of a
    ``measured`` scan detrended (``studies.paper.surface_window``, which warns of its seam).
    None: the surface re-gridded over its scan length (``surface_on_fem_grid``), noted with psi
    for ``material`` before and after (:func:`regrid_note`). Warned: an RMS slope beyond the
    small-strain FEM, and for a whole ``measured`` scan a periodic seam that is a step.
    """
    if n is not None:
        n = validate_grid_points(n)
    if window is None:
        meshed = surface_on_fem_grid(surface, n)
        notes = tuple(line for line in (regrid_note(surface, meshed, material),) if line)
    else:
        if n is None or n >= surface.n:
            raise InputError(f"{names.window} needs {names.n} below the surface's {surface.n} "
                             "points per side")
        index = window_index(window, names)
        meshed, notes = surface_window(surface, n, index, measured=measured), ()
    found = (small_strain_slope(meshed)[1],
             periodic_seam_warning(meshed) if measured and window is None else None)
    return MeshedSurface(meshed, notes, tuple(line for line in found if line))


def window_index(window, names: InputNames = PYTHON_NAMES) -> int | None:
    """The 0-based index of window ``window`` (a number 1, 2, ... or its text), None for
    "best"; else :class:`InputError`."""
    if window == "best":
        return None
    try:
        if isinstance(window, bool) or not isinstance(window, int | str):
            raise ValueError
        index = int(window)
    except ValueError:
        raise InputError(f"{names.window} takes 'best' or a window number 1, 2, ..., got "
                         f"{window!r}") from None
    if index < 1:
        raise InputError(f"{names.window} counts from 1, got {index}")
    return index - 1


def regrid_note(surface: Surface, meshed: Surface, material: Material) -> str | None:
    """One line when ``meshed`` is ``surface`` re-gridded over its scan length (coarser: a
    smoother surface; finer: Fourier-interpolated between its points), with the psi of both
    for ``material``; None when it is the surface as is."""
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
