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


#: Suffixes of a results file (HDF5).
RESULTS_SUFFIXES = (".h5", ".hdf5")


def _probe_directory(directory: Path, what: str) -> None:
    """Refuse ``directory`` unless it exists, is a directory and a file can be created in it
    (a file is made and removed: permission bits do not tell, e.g. in /proc or on a read-only
    mount)."""
    if not directory.exists():
        raise InputError(f"cannot write {what}: folder {directory} does not exist (create it "
                         "first, or name another path)")
    if not directory.is_dir():
        raise InputError(f"cannot write {what}: {directory} is not a directory")
    try:
        fd, probe = tempfile.mkstemp(dir=directory, prefix=".roughfriction-probe-")
    except OSError as error:
        raise InputError(f"cannot write {what}: {error.strerror or error} in {directory}") \
            from None
    os.close(fd)
    os.unlink(probe)


def check_writable_file(path: Path) -> None:
    """Raise :class:`InputError` unless a file can be written at ``path`` by
    :func:`atomic_write`: its folder exists and takes a new file, and ``path`` is not a
    directory. Leaves nothing behind."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"cannot write {path}: it is a directory")
    _probe_directory(Path(os.path.abspath(path)).parent, str(path))


def check_results_file(path: Path) -> None:
    """:func:`check_writable_file`, for an HDF5 results file: its suffix must be one of
    :data:`RESULTS_SUFFIXES`."""
    path = Path(path)
    check_writable_file(path)
    if path.suffix.lower() not in RESULTS_SUFFIXES:
        raise InputError(f"results file {path}: an HDF5 file is written, name it "
                         f"{path.with_suffix('.h5').name} ({' or '.join(RESULTS_SUFFIXES)})")


def check_writable_directory(directory: Path) -> None:
    """Raise :class:`InputError` unless files can be written in ``directory``: it exists and
    takes a new file, or it is missing and its parent does. Leaves nothing behind."""
    directory = Path(os.path.abspath(directory))
    if directory.exists():
        _probe_directory(directory, f"in {directory}")
    else:
        _probe_directory(directory.parent, f"in {directory}")


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
