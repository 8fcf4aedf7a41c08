"""Fig. 27: mu_s vs F* for surface 8L: FEM, multi-scale, LET."""

from functools import partial

from roughfriction.scripts.comparison import load_sweep, load_sweep_cases
from roughfriction.studies.paper import LOAD_SWEEP_SURFACES

SURFACE = LOAD_SWEEP_SURFACES[1]
fem_cases = partial(load_sweep_cases, SURFACE)
make = partial(load_sweep, SURFACE)
