"""Fig. 29: F_t/F_n vs u_x for G1–G9 (FEM), without the normalisation of Fig. 21."""

from functools import partial

from roughfriction.scripts.fem_views import tangential_curves
from roughfriction.scripts.fig21 import fem_cases  # noqa: F401  (the same runs as Fig. 21)

make = partial(tangential_curves, normalised=False)
