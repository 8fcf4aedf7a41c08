"""One plain elasticity solve of a case's block: the unit the FEM run's cost is counted in.

    mpirun -n 2 python -m benchmarks.elastic_solve G5 --n 128 [--level 1]

The block of the case at level 0, or of its uniform ladder's level L (mesh, forms and periodic
reduction as a run builds them, with the blend layers its valleys need),
the elastic stiffness P^T K P assembled, a uniform body force, and CG preconditioned by GAMG
(``solver.linear.LinearSolver``'s iterative method: its options and the rigid-body near null
space) to a relative residual of 1e-8. The unit is assembly + preconditioner + solve, the
work of one linear elastic FE solve once the mesh exists; meshing is timed apart (set-up).
Prints one JSON line (rank 0).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

#: Body force density of the solve [N/m^3] (any value: the system is linear).
BODY_FORCE = 1e9


def elastic_solve(case, comm) -> dict:
    """Time one plain CG + GAMG elasticity solve of the level-0 block of ``case``: seconds of
    set-up (mesh, forms, reduction), assembly (P^T K P, body force) and solve (preconditioner
    and Krylov), their ``elastic_solve_s`` = assembly + solve, the Krylov iterations and the
    reduced dofs (collective)."""
    import numpy as np
    import ufl
    from dolfinx import fem
    from dolfinx.fem import petsc as fem_petsc
    from petsc4py import PETSc
    from roughfriction.solver.block import build_block
    from roughfriction.solver.linear import LinearSolver
    from roughfriction.solver.periodic import PeriodicReduction
    from roughfriction.solver.reduced_assembly import ReducedAssembler
    from roughfriction.solver.solid import Solid

    surface = case.surface
    comm.Barrier()
    started = time.perf_counter()
    block = build_block(surface.heights, surface.spacing, case.mesh, comm)
    solid = Solid(block.mesh, case.material, True, case.solver.integration)
    reduction = PeriodicReduction(solid.V, block)
    body_force = fem.Constant(block.mesh, PETSc.ScalarType((0.0, 0.0, -BODY_FORCE)))
    load = fem.form(ufl.inner(body_force, ufl.TestFunction(solid.V)) * ufl.dx)
    solid.elastic_tangent_forms_on(np.empty(0, dtype=np.int32))  # compiled here, untimed
    comm.Barrier()
    assembly_started = time.perf_counter()
    assembler = ReducedAssembler(solid.V, reduction)
    stiffness = assembler.create_matrix()
    assembler.add(stiffness, solid.elastic_tangent_forms_on)
    stiffness.assemble()
    stiffness.setNearNullSpace(reduction.near_nullspace(solid.V.tabulate_dof_coordinates()))
    full = fem_petsc.assemble_vector(load)
    full.ghostUpdate(PETSc.InsertMode.ADD_VALUES, PETSc.ScatterMode.REVERSE)
    rhs, displacement = reduction.create_reduced_vector(), reduction.create_reduced_vector()
    reduction.restrict(full, rhs)
    comm.Barrier()
    solve_started = time.perf_counter()
    solver = LinearSolver(comm, "iterative")
    solver.set_operator(stiffness)
    solver.solve(rhs, displacement)
    comm.Barrier()
    finished = time.perf_counter()
    reduction.expand(displacement, solid.displacement)
    result = {"top_displacement_m": top_displacement(solid, block.depth, comm),
              "setup_s": assembly_started - started,
              "assembly_s": solve_started - assembly_started,
              "solve_s": finished - solve_started,
              "elastic_solve_s": finished - assembly_started,
              "krylov_iterations": solver.last_iterations,
              "reduced_dofs": 3 * reduction.num_reduced_global, "ranks": comm.size}
    for item in (solver, stiffness, full, rhs, displacement, assembler, reduction):
        item.destroy()
    return result


def top_displacement(solid, depth: float, comm) -> float:
    """Mean vertical displacement of the nodes at and above the mean plane, z >= 0 [m] (on a
    flat block its surface) (collective)."""
    z = solid.V.tabulate_dof_coordinates()[:, 2]
    owned = solid.V.dofmap.index_map.size_local
    top = z[:owned] >= -1e-9 * depth
    u_z = solid.displacement.x.array.reshape(-1, 3)[:owned, 2]
    return comm.allreduce(float(u_z[top].sum())) / comm.allreduce(int(top.sum()))


def main(argv: list[str] | None = None) -> int:
    """Time the solve of a built-in surface re-gridded to n x n (``--n``), on its uniform
    ladder's level ``--level``, and print it."""
    from mpi4py import MPI
    from roughfriction.solver.run import with_blend_layers_needed
    from roughfriction.studies.paper import fem_case
    from roughfriction.studies.refinement import level_case

    parser = argparse.ArgumentParser(prog="python -m benchmarks.elastic_solve",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("surface")
    parser.add_argument("--n", type=int, default=128)
    parser.add_argument("--level", type=int, default=0,
                        help="the uniform ladder's level L, a mesh 2^L times finer (default 0)")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    case = with_blend_layers_needed(fem_case(args.surface, 0.155, args.n), lambda record: None)
    result = elastic_solve(level_case(case, args.level), MPI.COMM_WORLD)
    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps({"surface": args.surface, "n": args.n, "level": args.level, **result}),
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
