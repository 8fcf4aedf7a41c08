"""Field output on request (``--xdmf DIR``): one XDMF time series, written at the end of the
preload (t = 0) and at sliding inception (t = 1).

Fields: displacement [m] (P1 vector); von Mises stress [Pa] and equivalent plastic strain [-]
(cell averages over the Gauss points, DG0); contact pressure [Pa], x shear traction [Pa]
and contact state (0 open, 1 stick, 2 slip) on the surface nodes (P1 scalars, zero below the
surface; periodic images copy their master node).

Files a killed run cannot corrupt: the series is written in a hidden folder of the directory
(``.fields.*``) and moved onto ``fields.h5`` and ``fields.xdmf`` when it is closed, so earlier
fields files stay as they were until a run's fields are complete. A run stopped by an exception
removes its folder; a killed one leaves it behind (delete it).
"""

from __future__ import annotations

import os
import shutil
import tempfile
import weakref
from pathlib import Path

import numpy as np
from dolfinx import fem, io
from roughfriction.files import agreed
from roughfriction.geometry.mesh import Block
from roughfriction.solver.contact import ContactResponse, RigidFlat
from roughfriction.solver.periodic import dof_node_grid_index
from roughfriction.solver.solid import Solid

#: The files of a field series: the heavy data first, so that it is in place when the XDMF
#: file that names it is.
SERIES_FILES = ("fields.h5", "fields.xdmf")


def staging_directory(directory: Path, comm) -> Path:
    """A new hidden folder in ``directory`` (both created on rank 0; the name is shared by every
    rank of ``comm``) where a series is written until it is complete."""
    def make():
        if comm.rank == 0:
            directory.mkdir(parents=True, exist_ok=True)
            return tempfile.mkdtemp(dir=directory, prefix=".fields.")
        return None

    return Path(comm.bcast(agreed(comm, make), root=0))


class FieldWriter:
    """Writes the solid and contact fields to ``DIRECTORY/fields.xdmf`` (heavy data in
    ``DIRECTORY/fields.h5``), in place when :meth:`close` is called.

    Parameters
    ----------
    directory : str or pathlib.Path
        Output directory (created).
    block : Block
        The mesh.
    solid : Solid
        Displacement and plastic state.
    flat : RigidFlat
        The contact nodes.
    """

    def __init__(self, directory, block: Block, solid: Solid, flat: RigidFlat):
        mesh = block.mesh
        self.comm, self.directory = mesh.comm, Path(directory)
        self.staging = staging_directory(self.directory, self.comm)
        self._discard = weakref.finalize(self, shutil.rmtree, self.staging, ignore_errors=True)
        if self.comm.rank != 0:
            self._discard.detach()
        self.solid, self.flat = solid, flat
        self.file = io.XDMFFile(mesh.comm, str(self.staging / "fields.xdmf"), "w")
        self.file.write_mesh(mesh)

        cell_space = fem.FunctionSpace(mesh, ("DG", 0))
        self.von_mises = fem.Function(cell_space, name="von_mises")
        self.plastic_strain = fem.Function(cell_space, name="equivalent_plastic_strain")
        node_space, component_dofs = solid.V.sub(0).collapse()
        self.pressure = fem.Function(node_space, name="contact_pressure")
        self.shear = fem.Function(node_space, name="shear_traction_x")
        self.state = fem.Function(node_space, name="contact_state")

        # Surface nodes of the scalar space and their (i mod N, j mod N) on the surface grid.
        grid = dof_node_grid_index(solid.V, block)[np.asarray(component_dofs) // 3]
        surface = np.flatnonzero(grid[:, 2] == block.num_layers)
        self._surface_dofs = surface
        self._surface_ij = grid[surface, :2] % block.n

    def write(self, time: float, contact: ContactResponse) -> None:
        """Write all fields at ``time`` for the committed state and its contact response."""
        solid = self.solid
        num_cells = solid.num_cells
        self.von_mises.x.array[:num_cells] = solid.cell_von_mises()
        self.plastic_strain.x.array[:num_cells] = solid.cell_plastic_strain()
        maps = self.flat.node_maps(contact)
        nodal = {
            self.pressure: maps["pressure"],
            self.shear: maps["shear_x"],
            self.state: np.where(maps["slip"], 2.0, np.where(maps["contact"], 1.0, 0.0)),
        }
        for function, grid in nodal.items():
            function.x.array[:] = 0.0
            function.x.array[self._surface_dofs] = grid[self._surface_ij[:, 0],
                                                        self._surface_ij[:, 1]]
        for function in (self.von_mises, self.plastic_strain):
            function.x.scatter_forward()
        for function in (solid.displacement, self.von_mises, self.plastic_strain, self.pressure,
                         self.shear, self.state):
            self.file.write_function(function, time)

    def close(self) -> None:
        """Close the series and move its files into the directory (replacing earlier ones)."""
        self.file.close()

        def publish():
            if self.comm.rank == 0:
                for name in SERIES_FILES:
                    os.replace(self.staging / name, self.directory / name)
                self._discard()

        agreed(self.comm, publish)
