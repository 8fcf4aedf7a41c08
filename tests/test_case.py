"""Tests of roughfriction.case: the plausibility guards every FEM case passes."""

import numpy as np
import pytest
from roughfriction.case import MAX_LOAD_STAR, MAX_RMS_SLOPE, FemCase, Loading
from roughfriction.errors import InputError
from roughfriction.geometry.generate import builtin_names, builtin_surface
from roughfriction.geometry.surface import Surface


@pytest.mark.parametrize("load", [1e9, 1.55e8, 155.0, MAX_LOAD_STAR * 1.01])
def test_an_implausible_load_is_refused_in_one_line(load):
    """A pressure in Pa or MPa given as F* is refused, not run to a mu_s of 1e-10."""
    with pytest.raises(InputError, match=r"normal load F\* = .* > 100") as error:
        Loading(load)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("load", [0.01, 1.86, 2.5, 11.85, MAX_LOAD_STAR])
def test_the_loads_of_the_paper_and_the_stress_matrix_are_accepted(load):
    assert Loading(load).load_star == load


@pytest.mark.parametrize("load", [0.0, -0.1, float("nan"), float("inf"), "heavy"])
def test_a_load_that_is_not_a_positive_number_is_refused(load):
    with pytest.raises(InputError, match=r"normal load F\* must be"):
        Loading(load)


def test_a_case_with_heights_in_micrometres_taken_as_metres_is_refused():
    """The Python route to a case skips the reader's unit check; the case itself refuses it."""
    surface = builtin_surface("G5")
    in_micrometres = Surface(surface.heights * 1e6, surface.spacing, "G5 in um")
    with pytest.raises(InputError, match="RMS slope .* > 10: heights and spacing must both be "
                       "in metres") as error:
        FemCase(in_micrometres, Loading(0.155))
    assert "\n" not in str(error.value)


def test_every_built_in_surface_is_a_plausible_case():
    steepest = max(builtin_surface(name).rms_slope for name in builtin_names())
    assert 1.0 < steepest < MAX_RMS_SLOPE  # 63M, the steepest, is accepted
    for name in builtin_names():
        FemCase(builtin_surface(name), Loading(0.155))


def test_a_slope_just_above_the_limit_is_refused_and_just_below_accepted():
    i = np.indices((8, 8))[0].astype(float)
    spacing = 1e-6
    FemCase(Surface(0.99 * MAX_RMS_SLOPE * spacing * i, spacing), Loading(0.1))
    with pytest.raises(InputError, match="RMS slope"):
        FemCase(Surface(1.01 * MAX_RMS_SLOPE * spacing * i, spacing), Loading(0.1))


def test_a_zone_refinement_enters_the_case_inputs_by_its_digest():
    import json
    from dataclasses import asdict, replace

    from roughfriction.case import MeshOptions, ZoneRefinement

    case = FemCase(Surface(np.zeros((4, 4)), 1e-6), Loading(0.155))
    # unrefined: the keys of before (cache keys of earlier runs stay valid)
    unrefined = asdict(MeshOptions())
    assert unrefined.pop("refinement") is None
    assert unrefined.pop("blend_zone") == "fine"  # the default blend zone adds no key either
    assert case.inputs()["mesh"] == unrefined
    coarse = replace(case, mesh=MeshOptions(blend_zone="coarse"))
    assert coarse.inputs()["mesh"] == {**unrefined, "blend_zone": "coarse"}
    zone = np.zeros((4, 4), bool)
    zone[1, 2] = True
    refined = [replace(case, mesh=MeshOptions(refinement=ZoneRefinement(2, mask)))
               for mask in (zone, zone.T)]
    inputs = [json.loads(json.dumps(c.inputs()))["mesh"]["refinement"] for c in refined]
    assert inputs[0]["level"] == 2 and inputs[0]["zone_cells"] == 1
    assert inputs[0]["zone_sha256"] != inputs[1]["zone_sha256"]


@pytest.mark.parametrize("level, zone", [(-1, np.ones((4, 4))), (1.5, np.ones((4, 4))),
                                         (True, np.ones((4, 4))), (1, np.ones((4, 2))),
                                         (1, [[True]])])
def test_bad_zone_refinements_are_refused(level, zone):
    from roughfriction.case import ZoneRefinement

    with pytest.raises(InputError):
        ZoneRefinement(level, zone)
