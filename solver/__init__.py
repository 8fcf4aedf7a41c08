"""Deterministic FEM (dolfinx 0.5): a rough elastic-plastic block pressed and slid by a rigid flat.

Read in this order (the paper's procedure):

* ``options``      FemCase = Surface + Loading + Material + MeshOptions + SolverOptions
* ``run``          build the block, preload, slide to inception, report
* ``stepping``     load path: adaptive preload and tangential steps, sliding inception
* ``equilibrium``  Newton on the reduced, force-controlled (bordered) system; Uzawa updates
* ``solid``        trilinear hexahedra, SRI, weak forms; ``plasticity`` the J2 return map
* ``contact``      node-based augmented-Lagrangian contact and tau_c-capped friction
* ``periodic``     u = P u_red (periodic sides, fixed bottom); ``linear`` MUMPS / CG + GAMG
* ``results``      step records, summary, HDF5; ``fields`` XDMF on request
* ``command``      the ``fem`` command line; ``benchmark`` G5 timings for several N
* ``cache``        the run cache: each run once, keyed by its inputs and the physics sources
* ``post``         reading a results file with h5py (``roughfriction post``, the figures)
* ``convergence``  run time against error (``make bench-error``); ``stress`` the stress matrix
  (``make stress``); ``batch`` runs them through the cache, group by group

``material``, ``plasticity``, ``options``, ``results``, ``command``, ``cache``, ``post``,
``batch``, ``convergence`` and ``stress`` import without dolfinx.
"""
