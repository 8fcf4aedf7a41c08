"""roughfriction: static friction between rough metal surfaces, by FEM and by multi-scale theory.

The package's layers, each importing only those below it::

    roughfriction.scripts      command line and the paper's figures        (folder scripts/)
    roughfriction.studies      run cache, batches, benchmarks, stress matrix,
                               convergence study, reading results           (folder studies/)
    roughfriction.solver       the FEM of one case: mesh to mu_s (dolfinx)  (folder solver/)
    roughfriction.multiscale   the multi-scale theory, CKE and LET (NumPy)  (folder multiscale/)
    roughfriction.geometry     surfaces, statistics, the gmsh block         (folder geometry/)
    roughfriction              the core: material, case, units, errors     (folder core/)
"""

__version__ = "0.18.1"
