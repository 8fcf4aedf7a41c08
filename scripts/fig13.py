"""Fig. 13: amplitude/wavelength ratio vs wavelength, surface 2L."""

from roughfriction.geometry.generate import builtin_surface
from roughfriction.multiscale.scales import scale_decomposition
from roughfriction.scripts.figures import new_axes

SURFACE = "2L"
UM = 1e-6


def make():
    scales = scale_decomposition(builtin_surface(SURFACE))
    ratio = scales.amplitude / scales.wavelength
    fig, ax = new_axes()
    ax.loglog(scales.wavelength / UM, ratio, "o", ms=3)
    ax.set_xlabel("wavelength $\\lambda_i$ (µm)")
    ax.set_ylabel("$\\Delta_i / \\lambda_i$ (–)")
    ax.set_title(f"Amplitude/wavelength, surface {SURFACE} (stand-in)")
    return fig, {"wavelength_m": scales.wavelength, "amplitude_over_wavelength": ratio}
