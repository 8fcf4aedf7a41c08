"""Fig. 12: equivalent amplitude vs wavelength of the scale decomposition, surface 2L."""

from roughfriction.geometry.generate import builtin_surface
from roughfriction.multiscale.scales import scale_decomposition
from roughfriction.scripts.figures import new_axes

SURFACE = "2L"
UM = 1e-6


def make():
    scales = scale_decomposition(builtin_surface(SURFACE))
    fig, ax = new_axes()
    ax.loglog(scales.wavelength / UM, scales.amplitude / UM, "o", ms=3)
    ax.set_xlabel("wavelength $\\lambda_i$ (µm)")
    ax.set_ylabel("equivalent amplitude $\\Delta_i$ (µm)")
    ax.set_title(f"Scale decomposition, surface {SURFACE} (stand-in)")
    return fig, {"wavelength_m": scales.wavelength, "amplitude_m": scales.amplitude}
