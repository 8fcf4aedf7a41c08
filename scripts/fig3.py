"""Fig. 3: three-dimensional plot of surface 2L (stand-in)."""

from roughfriction.scripts.surface_views import surface_3d

SURFACE = "2L"


def make():
    return surface_3d(SURFACE)
