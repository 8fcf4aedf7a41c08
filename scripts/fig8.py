"""Fig. 8: FEM contact under the normal load for surface 8L (stand-in) at F* = 0.06 and 0.12."""

from roughfriction.scripts.fem_views import contact_maps as make  # noqa: F401
from roughfriction.studies.paper import CONTACT_MAP_LOADS, fem_case

SURFACE = "8L"


def fem_cases(n):
    return [fem_case(SURFACE, load, n, normal_only=True) for load in CONTACT_MAP_LOADS]
