"""Quantities with units at the edges, SI inside.

Inputs may be plain numbers (SI: m, N, Pa, N/m^3, m/N; angles in degrees) or
strings with units (``"60 in"``, ``"25 psi"``, ``"15 ton"``, ``"127 pcf"``).
A mass where a force is expected (``"15 ton"``, ``"30000 lb"``) is read as
force under standard gravity, likewise a density where a unit weight is
expected. ``ton`` is the short ton (2000 lb).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import lru_cache

STANDARD_GRAVITY = 9.80665  # m/s^2

_DECIMAL_COMMA = re.compile(r"\d\s*,\s*\d")  # "1,5 kPa", "133,5 kN", "0,05", "133,500 N"


class InputError(ValueError):
    """Invalid user input; ``field`` names the offending key or flag."""

    def __init__(self, field: str, message: str):
        super().__init__(f"{field}: {message}")
        self.field = field
        self.message = message


@dataclass(frozen=True)
class Kind:
    """A kind of quantity and its SI unit (pint syntax)."""

    name: str
    si_unit: str


LENGTH = Kind("length", "m")
FORCE = Kind("force", "N")
PRESSURE = Kind("pressure", "Pa")
UNIT_WEIGHT = Kind("unit weight", "N/m**3")
FLEXIBILITY = Kind("flexibility", "m/N")
ANGLE = Kind("angle", "deg")
DIMENSIONLESS = Kind("number", "")


@lru_cache(maxsize=1)
def registry():
    import pint

    ureg = pint.UnitRegistry()
    ureg.define("pcf = pound_force / foot ** 3")
    ureg.define("psf = pound_force / foot ** 2")
    return ureg


def to_si(value, kind: Kind, field: str) -> float:
    """``value`` (number or string with units) as a float in SI units of ``kind``.

    Angles are returned in degrees (the interface unit); convert with ``math.radians``.
    """
    if isinstance(value, bool):
        raise InputError(field, f"expected a {kind.name}, got {value!r}")
    if isinstance(value, (int, float)):
        result = float(value)
    elif isinstance(value, str):
        if _DECIMAL_COMMA.search(value):
            raise InputError(field, f"use a decimal point, not a comma (and no thousands separators): {value!r}")
        try:
            result = float(value)  # a bare number is SI (degrees for angles)
        except ValueError:
            result = _parse(value, kind, field)
    else:
        raise InputError(field, f"expected a {kind.name} (number or string with units), got {value!r}")
    if not math.isfinite(result):
        raise InputError(field, f"must be finite, got {value!r}")
    return result


def _parse(text: str, kind: Kind, field: str) -> float:
    import pint

    ureg = registry()
    try:
        q = ureg.Quantity(text.strip())
    except (pint.errors.PintError, ValueError, AttributeError, TypeError, SyntaxError):
        raise InputError(field, f"cannot read {text!r} as a {kind.name}") from None
    if kind is ANGLE:
        if q.dimensionless:
            # a bare number is degrees; an explicit unit (deg, rad) is honoured
            return float(q.to("degree").magnitude) if str(q.units) != "dimensionless" else float(q.magnitude)
        raise InputError(field, f"{text!r} is not an angle")
    if kind is DIMENSIONLESS:
        if q.dimensionless:
            return float(q.to("").magnitude)
        raise InputError(field, f"{text!r} must be a plain number")
    target = ureg.Quantity(1.0, kind.si_unit).dimensionality
    if q.dimensionality == target:
        return float(q.to(kind.si_unit).magnitude)
    g = ureg.Quantity(STANDARD_GRAVITY, "m/s**2")
    if (q * g).dimensionality == target:  # mass for a force, density for a unit weight
        return float((q * g).to_base_units().magnitude)
    if (q / g).dimensionality == target:  # m/kg for a flexibility given per mass
        return float((q / g).to_base_units().magnitude)
    raise InputError(field, f"{text!r} is not a {kind.name} (expected units like {kind.si_unit})")
