"""benchmarks.krylov: the PETSc options of a variant go under the iterative solver's prefix,
which the solver's own defaults yield to."""

from benchmarks.krylov import PREFIX, VARIANTS, petsc_options


def test_variant_options_sit_under_the_iterative_prefix():
    assert petsc_options("default") == ""
    assert (petsc_options("lgmres30")
            == f"{PREFIX}ksp_type lgmres {PREFIX}ksp_gmres_restart 30")
    assert all(len(options.split()) % 2 == 0 for options in VARIANTS.values())


def test_the_prefix_is_the_solver_s():
    from mpi4py import MPI
    from roughfriction.solver.linear import LinearSolver

    solver = LinearSolver(MPI.COMM_SELF, "iterative")
    assert solver.ksp.getOptionsPrefix() == PREFIX.lstrip("-")
