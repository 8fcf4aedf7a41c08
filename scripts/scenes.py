"""What each FEM figure runs, read from the runs it declares (``fem_cases(n)``).

    python -m roughfriction.scripts.scenes docs/bench/figure_scenes.csv   # (make docs)

A row per FEM figure: its surfaces and loads, whether its runs stop at the preload (normal-only
figures) or slide, its meshes (1x: the figure's grid; 2x: the same surface twice as fine, for
the error bars), the runs it declares and those left to compute when the figures are made
together (``figures.compute_fem_runs``: a normal-only case is answered by the sliding run of
the same case, and a run declared by an earlier figure is not run again).
"""

from __future__ import annotations

import sys
from pathlib import Path

from roughfriction.scripts.figures import FEM_FIGURES, figure_module, needed_cases, sliding_keys

#: Columns of the table.
COLUMNS = ("figure", "shows", "surfaces", "loads", "loading", "meshes", "runs", "new_runs")


def loads_text(loads) -> str:
    """Sorted distinct loads F* as text: ``0.06, 0.155`` [-]."""
    return ", ".join(f"{load:g}" for load in sorted(set(loads)))


def meshes_text(cases, n: int) -> str:
    """``1x`` or ``1x; 2x at F* = 0.06, 0.155``: the figure's grid, and the loads also run on
    a 2x finer mesh (a case whose surface has more than n cells per side)."""
    refined = [case.loading.load_star for case in cases if case.surface.n > n]
    return "1x" + (f"; 2x at F* = {loads_text(refined)}" if refined else "")


def shows(module) -> str:
    """What a figure shows: the first line of its module docstring without ``Fig. NN:``."""
    first = module.__doc__.strip().splitlines()[0]
    text = first.split(":", 1)[1].strip() if first.startswith("Fig.") else first
    if text.count("(") > text.count(")"):  # a parenthesis the next line closes
        text = text[:text.rindex("(")]
    return text.strip().rstrip(".,;")


def scene_rows(n: int | None = None) -> list[dict]:
    """A row per FEM figure (:data:`COLUMNS`), in the order the figures are made."""
    from roughfriction.studies.cache import physics_version, run_key
    from roughfriction.studies.paper import fem_resolution

    n = fem_resolution(n)
    physics = physics_version()
    declared = {name: figure_module(name).fem_cases(n) for name in FEM_FIGURES}
    sliding = sliding_keys([case for cases in declared.values() for case in cases], physics)
    seen: set[str] = set()
    rows = []
    for name, cases in declared.items():
        keys = {run_key(case, physics) for case in needed_cases(cases, sliding, physics)}
        normal_only = {case.loading.normal_only for case in cases}
        rows.append({
            "figure": name,
            "shows": shows(figure_module(name)),
            "surfaces": " ".join(dict.fromkeys(case.surface.name for case in cases)),
            "loads": loads_text(case.loading.load_star for case in cases),
            "loading": ("normal only: stops at the preload" if normal_only == {True}
                        else "sliding" if normal_only == {False} else "normal and sliding"),
            "meshes": meshes_text(cases, n),
            "runs": len(cases),
            "new_runs": len(keys - seen),
        })
        seen |= keys
    return rows


def write_scenes(path: Path, n: int | None = None) -> Path:
    """Write :func:`scene_rows` as CSV (atomically); return ``path``."""
    from roughfriction.studies.tables import csv_text, write_text

    write_text(Path(path), csv_text(scene_rows(n), COLUMNS))
    return Path(path)


def main(argv: list[str] | None = None) -> int:
    """``python -m roughfriction.scripts.scenes PATH``: write the table to PATH."""
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print("usage: python -m roughfriction.scripts.scenes PATH", file=sys.stderr)
        return 2
    print(f"wrote {write_scenes(Path(argv[0]))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
