# roughfriction — set-up, tests, figures, benchmarks.
# `make test` installs what it needs (Debian packages + .venv), idempotently and quietly.

SHELL := /bin/bash
VENV  := .venv
PY    := $(VENV)/bin/python
NP    ?= 2

# OpenMPI refuses to run as root without these; single-threaded BLAS beside MPI ranks.
export OMPI_ALLOW_RUN_AS_ROOT := 1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM := 1
export OMP_NUM_THREADS := 1
export OPENBLAS_NUM_THREADS := 1
export XDG_CACHE_HOME ?= $(CURDIR)/.cache
MPIRUN := mpirun -n $(NP) --oversubscribe

DEBIAN_PACKAGES := python3-dolfinx-real python3-petsc4py-real python3-mpi4py python3-gmsh \
	python3-h5py python3-scipy python3-matplotlib python3-venv libopenblas0-serial

.PHONY: setup test lint figures gallery bench bench-multiscale bench-fem bench-windows bench-path \
	bench-error bench-error-quick bench-profile bench-calibration bench-blend-zone stress clean

# --- set-up -----------------------------------------------------------------------------
$(VENV)/.apt-done:
	@missing=$$(dpkg-query -W -f='$${Package} $${Status}\n' $(DEBIAN_PACKAGES) 2>/dev/null \
	    | awk '$$4 != "installed" {print $$1}'; \
	  for p in $(DEBIAN_PACKAGES); do dpkg-query -W $$p >/dev/null 2>&1 || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages: $$(echo $$missing | tr '\n' ' ')"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null; \
	fi
	@mkdir -p $(VENV) && touch $@

$(VENV)/pyvenv.cfg: $(VENV)/.apt-done
	@/usr/bin/python3 -m venv --system-site-packages $(VENV)

# pip must never replace Debian's numpy stack (dolfinx and h5py are built against it): pin the
# versions Debian installed.
$(VENV)/.installed: pyproject.toml $(VENV)/pyvenv.cfg
	@/usr/bin/python3 -c 'import numpy, scipy, matplotlib, h5py; \
	  print("\n".join(f"{m.__name__}=={m.__version__}" for m in (numpy, scipy, matplotlib, h5py)))' \
	  > $(VENV)/constraints.txt
	@# Debian registers h5py as "h5py._debian_h5py_serial", which pip does not recognise as h5py:
	@# declare it to pip, or a dependency on h5py pulls a wheel that clashes with dolfinx's HDF5.
	@site=$$($(PY) -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])'); \
	  version=$$(/usr/bin/python3 -c 'import h5py; print(h5py.__version__)'); \
	  mkdir -p $$site/h5py-$$version.dist-info; \
	  printf 'Metadata-Version: 2.1\nName: h5py\nVersion: %s\n' $$version \
	    > $$site/h5py-$$version.dist-info/METADATA; \
	  echo debian > $$site/h5py-$$version.dist-info/INSTALLER; \
	  : > $$site/h5py-$$version.dist-info/RECORD
	@$(PY) -m pip install -q --disable-pip-version-check -c $(VENV)/constraints.txt -e '.[dev]'
	@touch $@

setup: $(VENV)/.installed

# --- tests ------------------------------------------------------------------------------
test: setup
	@$(PY) -m pytest -q --color=no -m "not mpi"
	@# a broken MPI install must fail here: collecting no MPI test (status 5) is a failure too
	@$(MPIRUN) $(PY) -m pytest -q --color=no -m mpi -p no:cacheprovider

lint: setup
	@$(VENV)/bin/ruff check .

# --- figures ----------------------------------------------------------------------------
# The figures are registered once, in scripts/figures.py (THEORY_FIGURES, FEM_FIGURES); the
# targets below read the two lists from it.
registry = $(shell python3 -c 'import ast, sys; tree = ast.parse(open("scripts/figures.py").read()); \
  print(*next(ast.literal_eval(node.value) for node in tree.body if isinstance(node, ast.Assign) \
  and getattr(node.targets[0], "id", None) == sys.argv[1]))' $(1))
THEORY_FIGURES := $(call registry,THEORY_FIGURES)
# FEM figures (fig14: theory with FEM points), on N x N surface grids under mpirun. Runs are kept
# in results/runs/ (the run cache): a figure never recomputes a finished run, and a killed
# `make figures` resumes where it stopped. A run that cannot start (an inverted mesh) does not
# stop the others: the batch names it at the end and fails (`make -k figures` draws the rest).
N ?= 32
FEM_FIGURES := $(call registry,FEM_FIGURES)
.PHONY: $(THEORY_FIGURES) $(FEM_FIGURES) fem-runs
$(THEORY_FIGURES): setup
	@$(VENV)/bin/roughfriction figure $@

$(FEM_FIGURES): setup
	@$(MPIRUN) $(VENV)/bin/roughfriction figure $@ --n $(N)

# Every FEM figure's runs in one batch, so that the loads of a surface share one preload.
fem-runs: setup
	@$(MPIRUN) $(VENV)/bin/roughfriction figure runs --n $(N)

# ... then the paper's statements about them, checked against their CSVs: figures/claims.md
figures: $(THEORY_FIGURES) fem-runs $(FEM_FIGURES)
	@$(VENV)/bin/roughfriction figure claims

# Copy the figures the README shows into docs/figures/ (committed; figures/ is not).
gallery: figures
	@cp $(addprefix figures/,$(addsuffix .png,$(THEORY_FIGURES) $(FEM_FIGURES))) \
	  figures/claims.md docs/figures/

# --- benchmarks -------------------------------------------------------------------------
bench-multiscale: setup
	@$(PY) -m benchmarks multiscale

# The headline cases $(BENCH_CASES) with N = $(BENCH_N) on $(NP) ranks -> results/bench/fem.csv
# (a row per case, N and rank count; `make bench-fem NP=1 BENCH_N="32 64" BENCH_CASES=G5:0.155`
# adds serial rows). All of them at N = 128 take hours on 2 cores.
BENCH_N ?= 32 64 128
BENCH_CASES ?= G5:0.155 G5:0.93 2L:0.5 G1:1.86
# Then the large surface G5-512 (G5's statistics on 512 x 512 points) at N = $(LARGE_N), the
# rows that check the memory estimate and the sliding inception as surfaces grow (~30 min).
LARGE_N ?= 256 512
LARGE_CASES ?= G5-512:0.155
# Then the levels of the error ladder (`roughfriction fem --tol`), adaptive and uniform, of
# $(LADDER_CASES) on N = $(LADDER_N) up to level $(LADDER_LEVEL) (2x) -> results/bench/ladder.csv
# (a row per level: dofs, wall time, mu_s; ~40 min on 2 cores).
LADDER_CASES ?= G5:0.155
LADDER_N ?= 128
LADDER_LEVEL ?= 1
# Then `roughfriction fem --tol $(TOL)` on $(TOL_CASES) at N = $(TOL_N), each after one plain
# elasticity solve of its block, its wall time counted in those -> results/bench/tolerance.csv.
TOL ?= 0.03
TOL_N ?= 128
TOL_CASES ?= G5:0.155 G1:0.155 G9:0.155 2L:0.155 G5:0.93
bench-fem: setup
	@$(PY) -m benchmarks fem --n $(BENCH_N) --ranks $(NP) --case $(BENCH_CASES)
	@$(PY) -m benchmarks fem --n $(LARGE_N) --ranks $(NP) --case $(LARGE_CASES)
	@$(PY) -m benchmarks ladder --n $(LADDER_N) --ranks $(NP) --case $(LADDER_CASES) \
	  --max-level $(LADDER_LEVEL)
	@$(PY) -m benchmarks tol --n $(TOL_N) --ranks $(NP) --tol $(TOL) --case $(TOL_CASES)
	@mkdir -p docs/bench && cp results/bench/fem.csv results/bench/ladder.csv \
	  results/bench/tolerance.csv docs/bench/

# The adaptive against the uniform ladder, levels 1x-4x, on $(WINDOW_CASES)'s $(WINDOW_N)^2 windows
# $(WINDOWS) -> results/bench/ladder_windows.csv, copied to docs/bench/ (verification.md's table
# "Adaptive against uniform levels"; ~7 min on 2 cores).
WINDOW_CASES ?= G5:0.155 G5:0.93
WINDOW_N ?= 8
WINDOWS ?= 1 2 3
bench-windows: setup
	@$(PY) -m benchmarks ladder --n $(WINDOW_N) --window $(WINDOWS) --ranks $(NP) \
	  --case $(WINDOW_CASES) --max-level 2 --csv results/bench/ladder_windows.csv
	@mkdir -p docs/bench && cp results/bench/ladder_windows.csv docs/bench/

# The load path's error (benchmarks/fem.py): the headline cases on the default path and on a
# 4x finer one (largest preload and sliding increments / 4), at N = 64 (`PATH_N=32` is quicker).
PATH_N ?= 64
bench-path: setup
	@$(PY) -m benchmarks path --n $(PATH_N) --ranks $(NP) --case $(BENCH_CASES)
	@mkdir -p docs/bench && cp results/bench/path.csv docs/bench/

# Run time against error (benchmarks/convergence.py): G5 at F* = 0.155 and 0.93, 2L at 0.5 and
# G1 at 1.86 on their own 128^2 grids, on mesh levels $(ERROR_LEVELS) (1x, 2x) and with each knob
# alone on 1x, through the run cache on $(NP) ranks -> results/bench/error.{csv,png}, copied to
# docs/bench/. `make bench-error-quick`: the same on 16^2 windows, to results/bench/quick/.
ERROR_LEVELS ?= 0 1
bench-error: setup
	@$(MPIRUN) $(PY) -m benchmarks error --levels $(ERROR_LEVELS)
	@mkdir -p docs/bench && cp results/bench/error.csv results/bench/error.png docs/bench/

bench-error-quick: setup
	@$(MPIRUN) $(PY) -m benchmarks error --quick

# Where one FEM run's time goes (benchmarks/profile.py): seconds per phase (residual assembly,
# return map, contact law, reduced tangent, linear solves) and Krylov iterations per kind of
# solve -> results/bench/profile_*.json. `make bench-profile PROFILE_CASE=G1:1.86 N=32`;
# `make bench-profile N=64 MEMORY_CSV=docs/bench/memory.csv` also puts this version's column of
# the memory table into docs/bench/memory.csv (G5, F* = 0.155, N = 64 on 2 ranks);
# `PROFILE_LEVEL=1` profiles the case on a mesh 2x finer (level 1 of its uniform ladder).
PROFILE_CASE ?= G5:0.155
PROFILE_LEVEL ?= 0
bench-profile: setup
	@$(MPIRUN) $(PY) -m benchmarks profile $(firstword $(subst :, ,$(PROFILE_CASE))) \
	  --load $(lastword $(subst :, ,$(PROFILE_CASE))) --n $(N) --level $(PROFILE_LEVEL) \
	  $(if $(MEMORY_CSV),--memory-csv $(MEMORY_CSV))

# The calibration set of the certificate (benchmarks/calibration_set.py): uniform ladders
# 1x-8x of seven 16^2 windows (G1-G9, 2L, 8L) at F* 0.06-1.86 -> docs/bench/calibration_ladders.csv,
# resumable (a level already there with today's physics is skipped; hours on 2 cores), then the
# certificate judged on it and its factors fitted (benchmarks/calibration.py) ->
# docs/bench/calibration.csv. `CALIBRATION_LEVELS=0,1,2` stops at 4x.
CALIBRATION_LEVELS ?= 0,1,2,3
bench-calibration: setup
	@mkdir -p docs/bench
	@$(MPIRUN) $(PY) -m benchmarks.calibration_set docs/bench/calibration_ladders.csv \
	  $(CALIBRATION_LEVELS)
	@$(PY) -m benchmarks.calibration docs/bench/calibration_ladders.csv docs/bench/calibration.csv

# The coarse blend zone against the fine one (benchmarks/blend_zone.py): the calibration set's
# windows and loads on all-zone 2x and 4x levels whose blend zone below the fine layers has
# the previous level's cells -> docs/bench/blend_zone.csv (resumable, stamped); the uniform
# levels of docs/bench/calibration_ladders.csv are the fine zone's. Then the certificate judged
# on the coarse 2x values against the uniform references -> docs/bench/calibration_coarse.csv.
BLEND_LEVELS ?= 1,2
bench-blend-zone: setup
	@mkdir -p docs/bench
	@$(MPIRUN) $(PY) -m benchmarks.blend_zone docs/bench/blend_zone.csv $(BLEND_LEVELS)
	@$(PY) -m benchmarks.calibration docs/bench/calibration_ladders.csv \
	  docs/bench/calibration_coarse.csv docs/bench/blend_zone.csv

bench: bench-multiscale bench-fem bench-windows bench-path bench-error

# Stress matrix (benchmarks/stress.py): G1-G9 (psi 1.3-26) x F* 0.01-2.5, ST400 test3; on G5:
# penalty, step size, tolerances, material extremes; G5 at F* 0.155 on 1, 2 and 4 ranks (each
# its own mpirun) and 5 times on $(NP) ranks, each in an empty run cache. N = $(N) ->
# results/bench/stress.{csv,md}, copied to docs/bench/ unless a run failed silently or the
# rank counts or repeats disagree (then the command exits 1).
stress: setup
	@rm -rf results/bench/stress_runs
	@for np in 1 2 4; do mpirun -n $$np --oversubscribe $(PY) -m benchmarks stress \
	  --n $(N) --rank-run || echo "rank run on $$np rank(s) failed (its row in stress.md says why)"; done
	@$(MPIRUN) $(PY) -m benchmarks stress --n $(N)
	@mkdir -p docs/bench && cp results/bench/stress.csv results/bench/stress.md docs/bench/

# The benchmark tables of README.md, docs/benchmarks.md and docs/verification.md, regenerated in
# place from the files in docs/bench/, each with the physics stamp of its rows
# (benchmarks/doc_tables.py). `make docs CHECK=1` writes nothing and fails on a stale table or
# on a stamp that is not today's physics (unless the table says so, or docs/bench/equivalence.csv
# carries the stamp to today's).
.PHONY: docs
docs: setup
ifndef CHECK
	@$(PY) -m roughfriction.scripts.scenes docs/bench/figure_scenes.csv
endif
	@$(PY) -m benchmarks.doc_tables $(if $(CHECK),--check)

clean:
	rm -rf results .cache .pytest_cache
