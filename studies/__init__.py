"""Studies over many FEM runs: the run cache, the error ladder, reading results files and the
Python API (the benchmarks are in the repository's benchmarks/, not installed). Knows no
command line; imports the FEM only where a run is computed."""
