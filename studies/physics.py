"""The physics version: the SHA-256 of the code of the modules that compute FEM results,
without comments and docstrings. It keys the run cache (``studies.cache``) and stamps every
results file (``studies.results_file``): editing the documentation keeps a version, editing a
statement or a constant makes a new one."""

from __future__ import annotations

import ast
import hashlib
import importlib.util
from pathlib import Path

#: The modules whose code determines an FEM result. Declared, not inferred: output, progress,
#: reading and study code change freely without discarding runs. Every module of the solver
#: package is either here or in :data:`SOLVER_OUTPUT_MODULES` (a test checks it), so that a new
#: module is classified before it lands.
PHYSICS_MODULES = (
    "roughfriction.material", "roughfriction.case", "roughfriction.geometry.surface",
    "roughfriction.geometry.mesh", "roughfriction.geometry.adaptive",
    "roughfriction.solver.block", "roughfriction.solver.contact",
    "roughfriction.solver.contact_faces", "roughfriction.solver.contact_quadrature",
    "roughfriction.solver.contact_state", "roughfriction.solver.contact_measures",
    "roughfriction.solver.contact_law", "roughfriction.solver.equilibrium",
    "roughfriction.solver.newton", "roughfriction.solver.newton_options",
    "roughfriction.solver.reduced_assembly",
    "roughfriction.solver.reduced_system",
    "roughfriction.solver.linear",
    "roughfriction.solver.periodic", "roughfriction.solver.plasticity",
    "roughfriction.solver.solid", "roughfriction.solver.stepping", "roughfriction.solver.run",
    "roughfriction.solver.results",
)
#: Modules of the solver package that do not change results (field output, progress, the
#: memory gate, the timed stages).
SOLVER_OUTPUT_MODULES = ("roughfriction.solver", "roughfriction.solver.fields",
                         "roughfriction.solver.progress", "roughfriction.solver.memory",
                         "roughfriction.solver.stages")
#: Other modules the physics modules import that do not change results (errors, file
#: writing); any other import of a physics module must itself be one (a test checks it).
OUTPUT_IMPORTS = ("roughfriction.errors", "roughfriction.files",
                  "roughfriction.geometry.mesh_file", "roughfriction.solver.memory")

# --- keys ------------------------------------------------------------------------------------


def physics_sources() -> dict[str, Path]:
    """The source file of each of :data:`PHYSICS_MODULES` (located through their packages,
    without importing them)."""
    sources = {}
    for name in PHYSICS_MODULES:
        package, _, module = name.rpartition(".")
        folder = importlib.util.find_spec(package).submodule_search_locations[0]
        sources[name] = Path(folder) / f"{module}.py"
    return sources


def code_without_documentation(source: str) -> str:
    """The abstract syntax tree of Python ``source`` as text, without its comments (the parser
    drops them), docstrings (module, class, function) and line numbers."""
    tree = ast.parse(source)
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if (body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
                    and isinstance(body[0].value.value, str)):
                node.body = body[1:] or [ast.Pass()]
    return ast.dump(tree)


def physics_version(sources: dict[str, Path] | None = None) -> str:
    """SHA-256 of the names and code (:func:`code_without_documentation`) of the physics
    modules (``sources``: module name -> file, default :func:`physics_sources`; read from the
    files, not git)."""
    digest = hashlib.sha256()
    for name, path in sorted((sources or physics_sources()).items()):
        code = code_without_documentation(Path(path).read_text()).encode()
        digest.update(f"{name}\0{len(code)}\0".encode())
        digest.update(code)
    return digest.hexdigest()


#: Hex digits of the physics version in a table's stamp or a message.
STAMP_LENGTH = 12


def physics_stamp(version: str) -> str:
    """The short form of a physics version (its first :data:`STAMP_LENGTH` hex digits)."""
    return version[:STAMP_LENGTH]
