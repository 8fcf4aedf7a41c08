"""Fig. 6: topographical contour plot of Gaussian surface G5."""

from roughfriction.scripts.surface_views import surface_contour

SURFACE = "G5"


def make():
    return surface_contour(SURFACE)
