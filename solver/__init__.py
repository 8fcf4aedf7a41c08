"""Deterministic FEM (dolfinx 0.5): one case, from mesh to mu_s — a rough elastic-plastic block
pressed and slid by a rigid flat.

Read in this order (the paper's procedure):

* ``run``          build the block, preload, slide to inception, report
* ``block``        the dolfinx mesh of the gmsh block (gmshio, fixed slab partition)
* ``stepping``     load path: adaptive preload and tangential steps, sliding inception
* ``equilibrium``  Newton on the reduced, force-controlled (bordered) system; Uzawa updates
* ``solid``        trilinear hexahedra, SRI, weak forms; ``plasticity`` the J2 return map
* ``contact``      augmented-Lagrangian contact and tau_c-capped friction at Gauss points of
  the surface faces
* ``periodic``     u = P u_red (periodic sides, fixed bottom, hanging nodes); ``linear`` MUMPS /
  CG + GAMG
* ``results``      step records and summary; ``progress`` progress records; ``fields`` XDMF

The case (surface, loading, material, mesh and solver options) is ``roughfriction.case.FemCase``;
the block is laid out and held in gmsh by ``roughfriction.geometry.mesh``. ``plasticity``,
``results`` and ``progress`` import without dolfinx.
"""
