"""Fig. 21: F_t/F_n vs u_x/omega_0 for G1–G9 (FEM), omega_0 the interference under the normal
preload only: the flat's approach from first touch, max(z) - h at the end of the preload."""

from functools import partial

from roughfriction.scripts.fem_views import tangential_curves
from roughfriction.studies.paper import GAUSSIAN_SURFACES, curve_case


def fem_cases(n):
    return [curve_case(name, n) for name in GAUSSIAN_SURFACES]


make = partial(tangential_curves, normalised=True)
