"""Figure registry and output: each ``scripts/figNN.py`` declares what it needs and draws it.

A figure module defines ``make() -> (matplotlib Figure, dict of equal-length columns)``;
``make_figure`` writes ``figures/figNN.png`` and the data behind it, ``figures/figNN.csv``,
each atomically (a killed run never leaves a half-written file under the final name).
"""

from __future__ import annotations

import importlib
import os
import tempfile
from pathlib import Path

import numpy as np

FIGURES = ("fig3", "fig4", "fig5", "fig6", "fig12", "fig13", "fig14", "fig17", "fig18", "fig19")
FIGURE_DIR = Path("figures")


def new_axes(width: float = 5.0, height: float = 3.6):
    """A figure with one axes, sized to read well at README width."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 10, "axes.grid": True, "grid.alpha": 0.3})
    fig, ax = plt.subplots(figsize=(width, height), constrained_layout=True)
    return fig, ax


def _atomic_write(path: Path, write) -> None:
    """Call ``write(tmp_path)`` then rename the temporary file onto ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    try:
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file the usual mode
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_table(path: Path, columns: dict[str, np.ndarray]) -> None:
    """Write equal-length columns as CSV; the header names carry the units."""
    arrays = [np.asarray(v) for v in columns.values()]
    if len({a.shape for a in arrays}) != 1 or arrays[0].ndim != 1:
        raise ValueError(f"{path.name}: columns must be 1-D and of equal length")
    rows = zip(*arrays, strict=True)
    lines = [",".join(columns)]
    lines += [",".join(f"{v:.10g}" if isinstance(v, float | np.floating) else str(v) for v in r)
              for r in rows]
    _atomic_write(path, lambda tmp: Path(tmp).write_text("\n".join(lines) + "\n"))


def make_figure(name: str, directory: Path = FIGURE_DIR) -> Path:
    """Draw figure ``name`` and write its PNG and CSV into ``directory``; return the PNG path."""
    import matplotlib.pyplot as plt

    fig, columns = importlib.import_module(f"scripts.{name}").make()
    png = directory / f"{name}.png"
    _atomic_write(png, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    plt.close(fig)
    write_table(directory / f"{name}.csv", columns)
    return png
