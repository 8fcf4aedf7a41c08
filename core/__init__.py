"""roughfriction: static friction between rough metal surfaces, by FEM and by multi-scale theory.

The package's layers, each importing only those below it::

    roughfriction.scripts      command line and the paper's figures        (folder scripts/)
    roughfriction.studies      run cache, error ladder, reading results,
                               the API                                      (folder studies/)
    roughfriction.solver       the FEM of one case: mesh to mu_s (dolfinx)  (folder solver/)
    roughfriction.multiscale   the multi-scale theory, CKE and LET (NumPy)  (folder multiscale/)
    roughfriction.geometry     surfaces, statistics, the gmsh block         (folder geometry/)
    roughfriction              the core: material, case, units, errors     (folder core/)

The public Python API (``load_surface``, ``theory``, ``fem_case``, ``run_fem``, ``read_run``, ...;
docs/api.md) lives in :mod:`roughfriction.studies.api`, the layer that sees all the others; its
names are attributes of this package too, imported on first use, so that ``import roughfriction``
stays cheap and the core imports no upper layer when it is imported.
"""

from roughfriction.version import __version__  # noqa: F401  (re-exported)

#: Names of :mod:`roughfriction.studies.api` offered as ``roughfriction.<name>``.
API_NAMES = (
    "Surface", "load_surface", "ReaderOptions", "builtin_names", "gaussian_surface",
    "self_affine_surface",
    "Material", "theory", "TheoryResult",
    "FemCase", "MeshOptions", "SolverOptions", "fem_case", "load_case", "meshed_surface",
    "run_fem", "LadderLimits",
    "read_run", "RunFile",
    "InputError", "ConvergenceError",
)


def __getattr__(name: str):
    """``roughfriction.<name>`` for a name of the API: imported from
    :mod:`roughfriction.studies.api` when first asked for (PEP 562)."""
    if name in API_NAMES:
        from roughfriction.studies import api

        value = getattr(api, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *API_NAMES})
