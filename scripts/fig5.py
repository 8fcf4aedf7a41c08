"""Fig. 5: three-dimensional plot of Gaussian surface G5."""

from roughfriction.scripts.surface_views import surface_3d

SURFACE = "G5"


def make():
    return surface_3d(SURFACE)
