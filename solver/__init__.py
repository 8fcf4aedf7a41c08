"""Deterministic FEM (dolfinx 0.5): one case, from mesh to mu_s — a rough elastic-plastic block
pressed and slid by a rigid flat.

Read in this order (the paper's procedure):

* ``run``          build the block, preload, slide to inception, report
* ``block``        the dolfinx mesh of the gmsh block (gmshio, fixed slab partition)
* ``stepping``     load path: adaptive preload and tangential steps, sliding inception
* ``equilibrium``  the iterate (u_red, h), converged steps, path predictor
* ``newton``       a load step's Newton solves and Uzawa updates (``LoadStep``; ``newton_options``)
* ``reduced_system`` R, K on u = P u_red and the bordered (force-controlled) solve (PETSc)
* ``solid``        trilinear hexahedra, SRI, weak forms; ``plasticity`` the J2 return map
* ``contact``      the contact response to a trial, its history and multipliers; its faces
  (``contact_faces``), quadrature and gathers (``contact_quadrature``), state types
  (``contact_state``) and measures: forces, areas, maps (``contact_measures``)
* ``contact_law``  pressure and tau_c-capped friction at points, with their tangents (NumPy)
* ``periodic``     u = P u_red (periodic sides, fixed bottom, hanging nodes); ``linear`` MUMPS /
  CG + GAMG
* ``results``      step records and summary; ``progress`` progress records; ``fields`` XDMF

The case (surface, loading, material, mesh and solver options) is ``roughfriction.case.FemCase``;
the block is laid out and held in gmsh by ``roughfriction.geometry.mesh``. ``plasticity``,
``results`` and ``progress`` import without dolfinx.
"""
