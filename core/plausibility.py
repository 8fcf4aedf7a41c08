"""Plausibility of what a user gives and of what comes out: the guards against unit slips in the
material, and the flags on results outside the models' range.

Guards, not physics: they refuse or flag, never change a value, so this module is outside the
run cache's physics key. The front doors (the command line and ``studies.api``) call them."""

from __future__ import annotations

import re
from dataclasses import dataclass

from roughfriction.errors import InputError
from roughfriction.material import Material


@dataclass(frozen=True)
class Range:
    """An interval of plausible values of one quantity, in its SI unit.

    Attributes
    ----------
    low, high : float
        Bounds [unit].
    unit : str
        The SI unit the value is read in ("Pa").
    shown : str
        The bounds as a reader knows them ("1 GPa to 1200 GPa").
    """

    low: float
    high: float
    unit: str
    shown: str


#: Metals' Young's modulus [Pa]: lead 16 GPa, osmium 550 GPa, with margin on both sides.
YOUNGS_MODULUS_RANGE = Range(1e9, 1.2e12, "Pa", "1 GPa to 1200 GPa")
#: Metals' yield strength [Pa]: annealed pure metals from ~10 MPa, maraging steels ~2.5 GPa.
YIELD_STRENGTH_RANGE = Range(1e6, 1e10, "Pa", "1 MPa to 10 GPa")
#: Largest yield strain S_y / E of a metal [-] (a few 1e-3; 0.05 is rubber-like).
MAX_YIELD_STRAIN = 0.05
#: F* = F_n / (A_n S_y) [-] at which the mean nominal pressure reaches the hardness of a
#: plastically loaded surface (about 2.8 S_y): beyond it the surface is in complete contact and
#: neither model's asperity picture applies.
HARDNESS_LOAD_STAR = 2.8
#: Contact area ratio A_r / A_n [-] from which a result is complete contact.
COMPLETE_CONTACT_RATIO = 0.99
#: Pressure units of a case file's material values, in pascals.
PRESSURE_UNITS = {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "GPa": 1e9}
_PRESSURE = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-z]+)?\s*")
#: Material entries that are pressures (Poisson's ratio is the other).
PRESSURE_FIELDS = ("E", "Sy", "Et", "tau_c")


def parse_pressure(name: str, value) -> float:
    """A case file's material value ``name`` [Pa]: a number in pascals, or a string with a unit
    of :data:`PRESSURE_UNITS` ("800MPa", "210 GPa"); else InputError naming the key."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        return float(value)
    match = _PRESSURE.fullmatch(value) if isinstance(value, str) else None
    if match is None or match.group(2) not in PRESSURE_UNITS:
        raise InputError(f"material {name} = {value!r}: give a number in Pa (e.g. 8e8) or one "
                         f"with a unit ({', '.join(PRESSURE_UNITS)}), e.g. \"800MPa\"")
    return float(match.group(1)) * PRESSURE_UNITS[match.group(2)]


def material_from_table(table: dict) -> Material:
    """The :class:`Material` of a case file's ``[material]`` table (pressures through
    :func:`parse_pressure`, ``nu`` a number), checked by :func:`check_material`."""
    values = {}
    for name, value in table.items():
        if name in PRESSURE_FIELDS:
            values[name] = parse_pressure(name, value)
        elif isinstance(value, int | float) and not isinstance(value, bool):
            values[name] = float(value)
        else:
            raise InputError(f"material {name} = {value!r}: give a number")
    material = Material(**values)
    check_material(material)
    return material


def _outside(name: str, value: float, allowed: Range, example: str) -> str | None:
    """One line when ``value`` [``allowed.unit``] is outside ``allowed``, else None."""
    if allowed.low <= value <= allowed.high:
        return None
    return (f"{name} = {value:g} {allowed.unit} is not a metal's ({allowed.shown}): material "
            f"values are in {allowed.unit} (SI), e.g. {example}")


def material_problems(material: Material) -> list[str]:
    """What in ``material`` is no metal's: E or S_y outside their ranges (a unit slip: E = 210
    for 210 GPa), a yield strain S_y / E above :data:`MAX_YIELD_STRAIN`. One line each."""
    problems = [_outside("E", material.E, YOUNGS_MODULUS_RANGE, "E = 210e9 for 210 GPa"),
                _outside("Sy", material.Sy, YIELD_STRENGTH_RANGE, "Sy = 8e8 for 800 MPa")]
    problems = [problem for problem in problems if problem]
    if not problems and material.Sy / material.E > MAX_YIELD_STRAIN:
        problems.append(f"yield strain Sy / E = {material.Sy / material.E:.3g} > "
                        f"{MAX_YIELD_STRAIN:g}: no metal yields that late; check E and Sy")
    return problems


def check_material(material: Material) -> Material:
    """``material``, unless :func:`material_problems` finds something (InputError listing all,
    each with its fix)."""
    problems = material_problems(material)
    if problems:
        raise InputError("; ".join(problems))
    return material


def material_record(material: Material) -> dict:
    """The material as printed beside every result: E, nu, S_y, E_t, tau_c [Pa, -]."""
    return {"E": material.E, "nu": material.nu, "Sy": material.Sy, "Et": material.Et,
            "tau_c": material.tau_c}


def result_warnings(load_star: float, area_ratios) -> list[str]:
    """Flags on a result outside the models' range: F* above :data:`HARDNESS_LOAD_STAR`, and
    complete contact (an area ratio A_r / A_n of ``area_ratios``, None skipped, at least
    :data:`COMPLETE_CONTACT_RATIO`). One line each; empty when the result is in range."""
    flags = []
    if load_star > HARDNESS_LOAD_STAR:
        flags.append(f"F* = {load_star:g} > {HARDNESS_LOAD_STAR:g}: the mean nominal pressure "
                     "exceeds the hardness (about 2.8 Sy), out of both models' range (F* is "
                     "F_n / (A_n Sy), dimensionless)")
    ratios = [ratio for ratio in area_ratios if ratio is not None]
    if ratios and max(ratios) >= COMPLETE_CONTACT_RATIO:
        flags.append(f"A_r/A_n = {max(ratios):.3g}: complete contact, where the asperity "
                     "models do not apply and mu_s is not a rough-surface friction coefficient "
                     "(check the heights' unit and --fill)")
    return flags
