"""Studies over many FEM runs: the run cache, batches, benchmarks, the stress matrix, the
convergence study and reading results files. Knows no command line; imports the FEM only where
a run is computed."""
