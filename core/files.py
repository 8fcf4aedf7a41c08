"""Files a half-finished run cannot corrupt: everything is written under a temporary name and
renamed onto its final one. Output paths are checked before a run starts, and a failure to
write is agreed on by every MPI rank, so that no rank waits for one that gave up."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from roughfriction.errors import InputError


def atomic_write(path: Path, write) -> None:
    """Call ``write(tmp_path)`` then rename the temporary file onto ``path`` (created with the
    usual file mode; the temporary file is removed if ``write`` fails)."""
    path = Path(path)
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


def _existing_ancestor(path: Path) -> Path:
    """``path`` itself or its nearest ancestor that exists (as any kind of file)."""
    path = Path(os.path.abspath(path))
    while not os.path.lexists(path) and path != path.parent:
        path = path.parent
    return path


def _check_creatable_directory(directory: Path, what: str) -> None:
    """Refuse a directory that cannot be created or written in: an existing one must be
    writable, a missing one needs its nearest existing ancestor to be a writable directory."""
    ancestor = _existing_ancestor(directory)
    if not ancestor.is_dir():
        raise InputError(f"cannot write {what}: {ancestor} is not a directory")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise InputError(f"cannot write {what}: {ancestor} is not writable")


def check_writable_file(path: Path) -> None:
    """Raise :class:`InputError` unless a file can be written at ``path`` by
    :func:`atomic_write` (its folder exists or can be created, and is writable; ``path`` is not
    a directory). Nothing is created."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"cannot write {path}: it is a directory")
    _check_creatable_directory(path.parent, str(path))


def check_writable_directory(directory: Path) -> None:
    """Raise :class:`InputError` unless files can be written in ``directory`` (it exists or can
    be created, and is writable). Nothing is created."""
    _check_creatable_directory(Path(directory), f"in {directory}")


def _one_line(error: OSError) -> str:
    """An operating-system error as one line: the file and the reason."""
    if error.filename and error.strerror:
        return f"cannot write {error.filename}: {error.strerror}"
    return "cannot write: " + " ".join(str(error).split())


def agreed(comm, action):
    """Call ``action()`` on every rank of ``comm`` (an mpi4py communicator) and return its
    value; if it raised :class:`InputError` or ``OSError`` on any rank, raise an
    :class:`InputError` with the first such rank's one-line message on every rank, so that no
    rank waits for one that failed."""
    problem, value = None, None
    try:
        value = action()
    except InputError as error:
        problem = str(error)
    except OSError as error:
        problem = _one_line(error)
    problems = [one for one in comm.allgather(problem) if one is not None]
    if problems:
        raise InputError(problems[0])
    return value
