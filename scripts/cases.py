"""The surfaces and loads of the paper's comparison figures, declared once."""

import numpy as np

#: Table 1 Gaussian surfaces (Figs. 20–25).
GAUSSIAN_SURFACES = tuple(f"G{k}" for k in range(1, 10))
#: Loads F* of Figs. 22–25 (mu_s vs psi).
PSI_SWEEP_LOADS = (0.155, 0.62, 0.93, 1.86)
#: Surfaces of Figs. 26–28 (mu_s vs F*).
LOAD_SWEEP_SURFACES = ("2L", "8L", "G5")
#: Loads F* of Figs. 26–28: ten values spanning the paper's range, log-spaced.
LOAD_SWEEP = tuple(float(f"{v:.3g}") for v in np.geomspace(0.05, 2.0, 10))
