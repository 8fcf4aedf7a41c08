"""From heights to mu_s: the static friction coefficient of one rough surface, two ways.

A literate demo: read it top to bottom, or run it (serially, a few seconds)::

    python docs/demo.py [OUTPUT_DIR]

The problem
-----------
An elastic-plastic metal block whose top is a rough surface z(x, y) [m] is pressed by a rigid
flat with the normal force F_n [N], given as the dimensionless load F* = F_n / (A_n S_y) [-]
(the paper's Eq. 10; A_n [m^2] the nominal area, S_y [Pa] the yield strength). The flat is
then slid sideways at constant F_n until every contact point slips; the largest tangential
force F_t,max [N] gives the static friction coefficient mu_s = F_t,max / F_n [-].

Two answers are computed here for one surface:

1. the multi-scale theory of Wang, Xu & Jackson (Tribol. Lett. 66 (2018) 146): the surface
   split into sinusoidal scales by FFT, each scale's contact stacked on the next, junction
   growth under the shear cap tau_c (docs/theory.md), NumPy only, milliseconds;
2. the deterministic FEM (dolfinx): a hexahedral block of J2 plastic metal whose top nodes
   carry the heights, the contact of the flat at every surface node, preloaded and slid to
   sliding inception (docs/method.md), seconds on this small grid.

The surface is generated, not measured: i.i.d. Gaussian heights with the RMS of the paper's G5
(0.1 um at 1 um spacing, plasticity index psi ~ 13). The theory takes the whole surface; the FEM
meshes a 12 x 12 window of it at its own spacing, with nearly the same psi, so that its run
takes a few seconds.

Output: the surface statistics, the theory's mu_s beside CKE and LET, the FEM's load path at
sliding, and mu_s of the FEM beside the theory. The only file written is the FEM's results
file ``demo_fem.h5`` in OUTPUT_DIR (default: a temporary directory, removed at the end); read
it again with ``roughfriction post OUTPUT_DIR/demo_fem.h5``.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import roughfriction as rf

# The statistics of Eqs. 11-18 and 21 are not part of the API's short list of names; they are
# what ``roughfriction surface stats`` prints.
from roughfriction.geometry.statistics import surface_statistics

# ## The inputs
#
# SI units throughout: lengths in metres, pressures in pascals; the load is dimensionless.

RMS_HEIGHT = 0.1e-6  # nominal standard deviation of the heights [m] (G5 of Table 1)
POINTS_PER_SIDE = 64  # surface points per side [-]
SPACING = 1e-6  # grid spacing h [m]: a 63 um scan
SEED = 7  # seed of numpy.random.default_rng [-]
LOAD_STAR = 0.155  # F* = F_n / (A_n S_y) [-] (Eq. 10), the load of the paper's Fig. 22
FEM_CELLS_PER_SIDE = 12  # the FEM meshes a 12 x 12 window of the surface [-]
RESULTS_NAME = "demo_fem.h5"  # the FEM's results file, in OUTPUT_DIR
MICROMETRE = 1e-6  # [m], for printing
NANOMETRE = 1e-9  # [m], for printing


def describe_surface(surface: rf.Surface, material: rf.Material) -> None:
    """Print the roughness statistics of ``surface`` (Eqs. 11-18, 21) for ``material``.

    Parameters
    ----------
    surface : roughfriction.Surface
        Heights [m] on a square grid of spacing h [m].
    material : roughfriction.Material
        The material; the plasticity index psi [-] depends on E' [Pa] and S_y [Pa].
    """
    statistics = surface_statistics(surface, material)
    print(f"surface {surface.name!r}: {surface.n} x {surface.n} points, spacing "
          f"{surface.spacing / MICROMETRE:g} um, scan length "
          f"{surface.scan_length / MICROMETRE:g} um")
    print(f"  R_q {statistics.rq / MICROMETRE:.4f} um (Eq. 21), RMS slope "
          f"{surface.rms_slope:.3f}, bandwidth alpha {statistics.alpha:.3f} (Eq. 14)")
    print(f"  summit height std sigma_s {statistics.sigma_s / MICROMETRE:.4f} um (Eq. 12), "
          f"summit radius R {statistics.R / MICROMETRE:.3f} um (Eq. 18)")
    print(f"  plasticity index psi {statistics.psi:.2f} (Eq. 11)")


def main(output_directory: Path) -> None:
    """Generate a surface, evaluate the theory, run the FEM into ``output_directory``, read the
    run back and print mu_s of both.

    Parameters
    ----------
    output_directory : pathlib.Path
        Existing folder for the FEM's results file :data:`RESULTS_NAME`.
    """
    # ## 1. The surface
    #
    # ``gaussian_surface`` draws independent normal heights [m] (the paper's Sect. 2.2) and
    # removes their mean; the realised R_q scatters about the nominal RMS.
    surface = rf.gaussian_surface(RMS_HEIGHT, n=POINTS_PER_SIDE, spacing=SPACING, seed=SEED,
                                  name="demo")
    # The paper's material: E = 200 GPa, nu = 0.3, S_y = 1 GPa, linear hardening E_t = 0.02 E,
    # shear strength tau_c = S_y / sqrt(3) [Pa]. Pass your own as rf.Material(E=..., ...).
    material = rf.Material()
    print(f"material: E {material.E / 1e9:g} GPa, nu {material.nu:g}, S_y "
          f"{material.Sy / 1e9:g} GPa, tau_c {material.tau_c / 1e6:.0f} MPa")
    describe_surface(surface, material)

    # ## 2. The multi-scale theory
    #
    # ``theory`` decomposes the surface into scales (Eq. 35), loads them one on another
    # (Eqs. 22-23) and lets the junctions grow under tau_c (Eq. 36); beside it the statistical
    # CKE (Eq. 8) and LET (Eq. 20) models, flagged when (psi, F*) is outside their range.
    theory = rf.theory(surface, LOAD_STAR, material)
    print(f"\ntheory at F* = {LOAD_STAR:g}: mu_s {theory.mu_s:.4f}, A_r/A_n "
          f"{theory.area_ratio_normal:.4f} before and {theory.area_ratio_sliding:.4f} at sliding")
    print(f"  CKE {theory.mu_cke:.4f} (in its range: {theory.cke_valid}), "
          f"LET {theory.mu_let:.4f} (in its range: {theory.let_valid})")

    # ## 3. The FEM case
    #
    # ``fem_case`` builds what ``roughfriction fem`` runs: with ``window="best"`` an
    # n x n window of the surface at its own spacing, the one whose psi is nearest the whole
    # surface's (without a window a smaller n would re-grid the surface: a smoother one). The
    # mesh and solver options are the defaults (rf.MeshOptions, rf.SolverOptions).
    case = rf.fem_case(surface, LOAD_STAR, n=FEM_CELLS_PER_SIDE, window="best",
                       material=material)
    psi_meshed = surface_statistics(case.surface, material).psi
    print(f"\nFEM case: a {case.surface.n} x {case.surface.n} window of {surface.name!r} "
          f"(psi {psi_meshed:.2f}), {case.surface.n} surface cells per side")

    # ## 4. The FEM run
    #
    # ``run_fem`` meshes the block, presses the flat down until it carries F_n, slides it in
    # adaptive steps at constant F_n until every contact node slips (sliding inception), and
    # writes the HDF5 results file. Its progress lines (one per load step, on stderr by
    # default) are silenced here; the steps are read back from the file below. Serial here;
    # under ``mpirun -n 2`` every rank runs this script and rank 0 writes the file.
    results_path = output_directory / RESULTS_NAME
    started = time.perf_counter()
    rf.run_fem(case, results_path, overwrite=True, progress=lambda record: None)
    print(f"  ran in {time.perf_counter() - started:.1f} s, results in {results_path}")

    # ## 5. Reading the run back
    #
    # ``read_run`` needs h5py only (no dolfinx): the case as asked for (``inputs``), the
    # summary (``summary``), one entry per converged load step (``steps``, SI units) and the
    # contact maps (``maps``).
    run = rf.read_run(results_path)
    steps = run.steps
    print("  sliding steps: slide [nm], F_t/F_n [-], A_r/A_n [-], slipping/contact nodes")
    for index in range(len(steps["phase"])):
        if steps["phase"][index] != "tangential":
            continue
        print(f"    {steps['slide'][index] / NANOMETRE:7.2f}"
              f"  {steps['tangential_force'][index] / steps['normal_force'][index]:.4f}"
              f"  {steps['area_ratio'][index]:.4f}"
              f"  {steps['slipping_nodes'][index]}/{steps['contact_nodes'][index]}")

    # ## 6. mu_s, FEM beside theory
    summary = run.summary
    print(f"\nmu_s at F* = {LOAD_STAR:g}")
    print(f"  theory mu_s {theory.mu_s:.4f}  (multi-scale, the whole {surface.n} x "
          f"{surface.n} surface, psi {theory.psi:.2f})")
    print(f"  FEM mu_s    {summary['mu_s']:.4f}  (the {run.n} x {run.n} window on its own "
          f"grid, psi {psi_meshed:.2f})")

    # ## 7. How far to trust the FEM number
    #
    # A mesh on the surface's own grid resolves a contact patch of one or two cells coarsely,
    # and there it over-estimates mu_s against finer meshes of the same surface (G5 at
    # F* = 0.155 on its own 128 x 128 grid: 10 % above the 2x mesh; docs/benchmarks.md, "Run
    # time against error"). That is the FEM's discretisation error, not its gap to the theory.
    # The summary's ``reliable`` flag says whether the contact patches hold at least 4 grid
    # cells each; ``roughfriction fem ... --tol 0.03`` refines the mesh around the contact
    # until the estimated error of mu_s is 3 %.
    print(f"\nreliable: {summary['reliable']} ({summary['cells_per_patch']:.1f} grid cells per "
          "contact patch; reliable needs 4 or more)")
    print("  a small own grid over-estimates mu_s against a finer mesh of the same surface:")
    print("  read it with its error estimate, roughfriction fem ... --tol 0.03")


if __name__ == "__main__":
    if len(sys.argv) > 2:
        sys.exit(f"usage: python {sys.argv[0]} [OUTPUT_DIR]")
    if len(sys.argv) == 2:
        chosen = Path(sys.argv[1])
        chosen.mkdir(parents=True, exist_ok=True)
        main(chosen)
    else:
        with tempfile.TemporaryDirectory(prefix="roughfriction_demo_") as temporary:
            main(Path(temporary))
        print(f"\n(the results file went with its temporary directory: python {sys.argv[0]} "
              "OUTPUT_DIR keeps it)")
