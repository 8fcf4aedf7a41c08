"""Guards against unit slips in the material and flags on results outside the models' range
(core/plausibility.py), and where the front doors apply them."""

import json
import re

import pytest
import roughfriction as rf
from roughfriction.errors import InputError
from roughfriction.material import Material
from roughfriction.plausibility import (
    check_material,
    material_from_table,
    parse_pressure,
    result_warnings,
)
from roughfriction.scripts.cli import main


@pytest.mark.parametrize("material, message", [
    (Material(E=210.0, Sy=0.8, Et=4.0), "E = 210 Pa is not a metal's"),
    (Material(E=210e9, Sy=0.8), "Sy = 0.8 Pa is not a metal's (1 MPa to 10 GPa)"),
    (Material(E=2e9, Sy=5e8), "yield strain Sy / E = 0.25"),
])
def test_a_material_no_metal_has_is_refused_with_its_fix(material, message):
    with pytest.raises(InputError, match=re.escape(message)):
        check_material(material)


def test_every_slip_of_a_material_is_named_at_once():
    with pytest.raises(InputError) as refused:
        check_material(Material(E=210.0, Sy=0.8, Et=4.0))
    assert "E = 210e9 for 210 GPa" in str(refused.value)
    assert "Sy = 8e8 for 800 MPa" in str(refused.value)


def test_the_paper_and_common_metals_pass():
    for material in (Material(), Material(E=70e9, nu=0.33, Sy=2.8e8),
                     Material(E=16e9, nu=0.44, Sy=5e6)):
        assert check_material(material) is material


def test_pressures_take_a_unit_or_pascals():
    assert parse_pressure("Sy", "800MPa") == pytest.approx(8e8)
    assert parse_pressure("E", "210 GPa") == pytest.approx(2.1e11)
    assert parse_pressure("E", 2e11) == 2e11
    with pytest.raises(InputError, match=r"material Sy = '800 bar': give a number in Pa"):
        parse_pressure("Sy", "800 bar")
    assert material_from_table({"Sy": "800MPa", "nu": 0.29}) == Material(Sy=8e8, nu=0.29)
    with pytest.raises(InputError, match="material nu = '0.3': give a number"):
        material_from_table({"nu": "0.3"})


def test_results_out_of_the_models_range_are_flagged():
    assert result_warnings(0.155, [0.05, 0.06]) == []
    assert result_warnings(0.155, [None, None]) == []
    high, = result_warnings(5.0, [0.9])
    assert high.startswith("F* = 5 > 2.8")
    full, = result_warnings(0.155, [1.0, None])
    assert full.startswith("A_r/A_n = 1: complete contact")


def test_theory_on_an_own_material_with_its_flags(tmp_path, capsys):
    config = tmp_path / "steel.toml"
    config.write_text('[material]\nE = "210GPa"\nSy = "800MPa"\n')
    assert main(["multiscale", "G5", "--load", "5", "--config", str(config), "--json"]) == 0
    captured = capsys.readouterr()
    record = json.loads(captured.out)
    assert record["material"]["E"] == pytest.approx(2.1e11)
    assert record["material"]["Sy"] == pytest.approx(8e8)
    assert record["psi"] != pytest.approx(rf.theory(rf.load_surface("G5"), 5.0).psi)
    assert [line[:14] for line in record["warnings"]] == ["F* = 5 > 2.8: ", "A_r/A_n = 1: c"]
    assert captured.err.count("warning: ") == 2


def test_surface_stats_takes_the_material_and_refuses_the_gpa_habit(tmp_path, capsys):
    config = tmp_path / "gpa.toml"
    config.write_text("[material]\nE = 210\nSy = 0.8\n")
    assert main(["surface", "stats", "G5", "--config", str(config)]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "E = 210 Pa is not a metal's" in error[0]
    assert main(["surface", "stats", "G5", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["material"]["E"] == Material().E


def test_the_api_refuses_a_material_no_metal_has():
    surface = rf.load_surface("G5")
    with pytest.raises(InputError, match="E = 210 Pa"):
        rf.theory(surface, 0.155, Material(E=210.0, Sy=0.8, Et=4.0))
    with pytest.raises(InputError, match="E = 210 Pa"):
        rf.fem_case(surface, 0.155, n=8, window=1, material=Material(E=210.0, Sy=0.8, Et=4.0))


def test_a_fem_case_file_in_the_gpa_habit_is_refused_before_the_run(tmp_path, monkeypatch,
                                                                     capsys):
    pytest.importorskip("dolfinx")
    from roughfriction.solver import run as solver_run

    monkeypatch.setattr(solver_run, "run", lambda *args, **kwargs: pytest.fail("solved"))
    config = tmp_path / "gpa.toml"
    config.write_text("load = 0.155\n[material]\nE = 210\nSy = 0.8\n")
    assert main(["fem", "G5", "--n", "8", "--window", "1", "--config", str(config),
                 "--output", str(tmp_path / "run.h5")]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "E = 210 Pa is not a metal's" in error[0]
