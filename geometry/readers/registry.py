"""The registry of height-map readers: :data:`READERS`, one :class:`Reader` per format, and the
reader a file is read with (by ``fmt``, else by its suffix). A new format is a module of this
package defining its ``Reader`` and one entry of :data:`READERS`."""

from __future__ import annotations

from pathlib import Path

from roughfriction.errors import InputError
from roughfriction.geometry.readers.instrument import INSTRUMENT
from roughfriction.geometry.readers.npy import NPY
from roughfriction.geometry.readers.reader import Reader
from roughfriction.geometry.readers.text import MATRIX, TEXT, XYZ

#: Every reader; its name is the ``fmt`` that forces it, its suffixes choose it.
READERS: tuple[Reader, ...] = (NPY, TEXT, MATRIX, XYZ, INSTRUMENT)
#: The formats ``ReaderOptions.fmt`` accepts.
FORMATS = tuple(reader.name for reader in READERS)
#: Lower-case file suffix -> the reader chosen for it.
SUFFIXES = {suffix: reader for reader in READERS for suffix in reader.suffixes}


def reader_for(path: Path, fmt: str | None = None) -> Reader:
    """The reader named ``fmt`` (InputError listing the formats for an unknown one), or, with
    None, the one registered for ``path``'s suffix (InputError listing the known suffixes when
    none is)."""
    if fmt is not None:
        reader = next((reader for reader in READERS if reader.name == fmt), None)
        if reader is None:
            raise InputError(f"unknown format {fmt!r}; known: {', '.join(FORMATS)}")
        return reader
    reader = SUFFIXES.get(path.suffix.lower())
    if reader is None:
        what = f"suffix {path.suffix!r}" if path.suffix else "no suffix"
        raise InputError(f"{path.name}: no reader for files with {what}; known suffixes: "
                         f"{', '.join(sorted(SUFFIXES))}")
    return reader
