"""The block as a gmsh ``.msh`` file, for the gmsh GUI (``fem --msh``): output, so kept apart
from the physics of :mod:`geometry.mesh` (whose source keys the run cache)."""

from __future__ import annotations

from pathlib import Path

from roughfriction.errors import InputError
from roughfriction.geometry.mesh import BlockNodes, add_block_to_gmsh, gmsh_model


def write_msh(nodes: BlockNodes, path: str | Path) -> Path:
    """Write the block as a gmsh mesh file (binary MSH 4.1, whose coordinates read back exactly
    where text rounds the last digit; ``gmsh PATH`` opens it): written beside ``path`` and
    renamed onto it, so a failed write leaves no partial file under that name.

    Raises
    ------
    InputError
        If ``path`` does not end in ``.msh`` or cannot be written.
    """
    path = Path(path)
    if path.suffix != ".msh":
        raise InputError(f"a gmsh mesh file name ends in .msh, got {path}")
    partial = path.with_name(f".{path.stem}.partial.msh")  # gmsh picks the format by suffix
    try:
        partial.write_bytes(b"")
    except OSError as error:
        raise InputError(f"cannot write the mesh to {path}: {error.strerror}") from None
    try:
        with gmsh_model() as gmsh:
            add_block_to_gmsh(gmsh, nodes)
            gmsh.option.setNumber("Mesh.Binary", 1)
            gmsh.write(str(partial))
        if partial.stat().st_size == 0:
            raise InputError(f"gmsh could not write the mesh to {path}")
        partial.replace(path)
    finally:
        partial.unlink(missing_ok=True)
    return path
