"""Fig. 25: mu_s vs psi for G1–G9 at F* = 1.86: FEM, multi-scale, CKE, LET."""

from functools import partial

from roughfriction.scripts.comparison import psi_sweep, psi_sweep_cases
from roughfriction.studies.paper import PSI_SWEEP_LOADS

LOAD = PSI_SWEEP_LOADS[3]
fem_cases = partial(psi_sweep_cases, LOAD)
make = partial(psi_sweep, LOAD)
