"""Fig. 4: topographical contour plot of surface 2L (stand-in)."""

from roughfriction.scripts.surface_views import surface_contour

SURFACE = "2L"


def make():
    return surface_contour(SURFACE)
