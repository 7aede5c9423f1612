"""Units and dimensions: the unit table, compound unit text, SI unit text and names in words.

Dimensions are exponents of (kg, m, s, rad); plane angle is a dimension so that a torque
per angle (N*m/rad) differs from a torque (N*m). Every unit converts to SI by a factor.
"""

from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass

from .ir import Dim


@dataclass(frozen=True, slots=True)
class Unit:
    """A named unit: SI value of one of it, its dimension and its name in words."""

    factor: float
    dim: Dim
    word: str


LENGTH = Dim(length=1)
MASS = Dim(mass=1)
TIME = Dim(time=1)
ANGLE = Dim(angle=1)
NONE = Dim()
FORCE = Dim(mass=1, length=1, time=-2)
PRESSURE = Dim(mass=1, length=-1, time=-2)
TORQUE = Dim(mass=1, length=2, time=-2)

UNITS: dict[str, Unit] = {
    "m": Unit(1.0, LENGTH, "metre"),
    "mm": Unit(1e-3, LENGTH, "millimetre"),
    "cm": Unit(1e-2, LENGTH, "centimetre"),
    "km": Unit(1e3, LENGTH, "kilometre"),
    "kg": Unit(1.0, MASS, "kilogram"),
    "s": Unit(1.0, TIME, "second"),
    "ms": Unit(1e-3, TIME, "millisecond"),
    "min": Unit(60.0, TIME, "minute"),
    "h": Unit(3600.0, TIME, "hour"),
    "N": Unit(1.0, FORCE, "newton"),
    "kN": Unit(1e3, FORCE, "kilonewton"),
    "mN": Unit(1e-3, FORCE, "millinewton"),
    "Pa": Unit(1.0, PRESSURE, "pascal"),
    "kPa": Unit(1e3, PRESSURE, "kilopascal"),
    "MPa": Unit(1e6, PRESSURE, "megapascal"),
    "GPa": Unit(1e9, PRESSURE, "gigapascal"),
    "J": Unit(1.0, TORQUE, "joule"),
    "W": Unit(1.0, Dim(mass=1, length=2, time=-3), "watt"),
    "Hz": Unit(1.0, Dim(time=-1), "hertz"),
    "rad": Unit(1.0, ANGLE, "radian"),
    "deg": Unit(math.pi / 180.0, ANGLE, "degree"),
    "rev": Unit(2.0 * math.pi, ANGLE, "revolution"),
    "rpm": Unit(2.0 * math.pi / 60.0, Dim(angle=1, time=-1), "revolution per minute"),
}

# Spellings people type for units, mapped to the unit they mean (for "did you mean" hints).
ALIASES: dict[str, str] = {
    "meter": "m", "meters": "m", "metre": "m", "metres": "m",
    "kilogram": "kg", "kilograms": "kg", "kgs": "kg",
    "sec": "s", "secs": "s", "second": "s", "seconds": "s",
    "newton": "N", "newtons": "N", "Nm": "N*m", "nm": "N*m",
    "degree": "deg", "degrees": "deg", "degs": "deg",
    "radian": "rad", "radians": "rad", "rads": "rad",
    "g": "kg", "gram": "kg", "grams": "kg",
}

_FACTOR = re.compile(r"([A-Za-z]+)(?:\^(-?\d+))?")


def parse_unit(text: str) -> tuple[float, Dim]:
    """SI factor and dimension of a compound unit such as "N*m/rad" or "m/s^2".

    `text` is a UNIT token, so it is well formed: factors joined by '*' or '/', each with an
    optional integer power; '/' divides by the one factor that follows it."""
    factor, dim = 1.0, NONE
    for op, piece in _split_unit(text):
        match = _FACTOR.fullmatch(piece)
        assert match and match.group(1) in UNITS, text
        unit = UNITS[match.group(1)]
        power = int(match.group(2) or 1) * (-1 if op == "/" else 1)
        factor *= unit.factor ** power
        dim = dim_mul(dim, dim_pow(unit.dim, power))
    return factor, dim


def _split_unit(text: str) -> list[tuple[str, str]]:
    pieces = re.split(r"([*/])", text)
    ops = ["*"] + pieces[1::2]
    return list(zip(ops, pieces[0::2]))


def dim_mul(a: Dim, b: Dim) -> Dim:
    return Dim(a.mass + b.mass, a.length + b.length, a.time + b.time, a.angle + b.angle)


def dim_div(a: Dim, b: Dim) -> Dim:
    return Dim(a.mass - b.mass, a.length - b.length, a.time - b.time, a.angle - b.angle)


def dim_pow(a: Dim, power: int) -> Dim:
    return Dim(a.mass * power, a.length * power, a.time * power, a.angle * power)


def dim_scale(a: Dim, power: float) -> Dim | None:
    """`a` raised to a real power, or None when an exponent would not be a whole number."""
    exponents = [e * power for e in (a.mass, a.length, a.time, a.angle)]
    if any(abs(e - round(e)) > 1e-9 for e in exponents):
        return None
    return Dim(*(int(round(e)) for e in exponents))


# Preferred SI text for common dimensions; others are spelled in base units.
_SI_TEXT: dict[Dim, str] = {
    NONE: "1", LENGTH: "m", MASS: "kg", TIME: "s", ANGLE: "rad",
    Dim(mass=1, length=2): "kg*m^2",
    Dim(mass=1, length=2, time=-2, angle=-1): "N*m/rad",
    TORQUE: "N*m",
    Dim(mass=1, length=2, time=-1, angle=-1): "N*m*s/rad",
    Dim(mass=1, length=3, time=-2): "N*m^2",
    FORCE: "N",
    Dim(mass=1, time=-2): "N/m",
    PRESSURE: "N/m^2",
    Dim(mass=1, length=-1): "kg/m",
    Dim(time=-1, angle=1): "rad/s",
    Dim(time=-2, angle=1): "rad/s^2",
    Dim(length=1, time=-1): "m/s",
    Dim(length=1, time=-2): "m/s^2",
    Dim(time=-1): "1/s",
    Dim(length=2): "m^2",
    Dim(length=3): "m^3",
    Dim(length=4): "m^4",
    Dim(mass=1, length=2, time=-3): "W",
    Dim(mass=1, length=2, time=-1): "N*m*s",
}

_WORDS: dict[Dim, str] = {
    LENGTH: "length", MASS: "mass", TIME: "time", ANGLE: "angle",
    Dim(mass=1, length=2): "moment of inertia",
    Dim(mass=1, length=2, time=-2, angle=-1): "torque per angle",
    TORQUE: "torque",
    Dim(mass=1, length=2, time=-1, angle=-1): "torque per angular rate",
    Dim(mass=1, length=3, time=-2): "bending stiffness",
    FORCE: "force",
    Dim(mass=1, time=-2): "force per length",
    PRESSURE: "pressure",
    Dim(mass=1, length=-1): "mass per length",
    Dim(time=-1, angle=1): "angular rate",
    Dim(time=-2, angle=1): "angular acceleration",
    Dim(length=1, time=-1): "velocity",
    Dim(length=1, time=-2): "acceleration",
    Dim(time=-1): "frequency",
    Dim(length=2): "area",
    Dim(length=3): "volume",
    Dim(length=4): "second moment of area",
    Dim(mass=1, length=2, time=-3): "power",
}


def si_text(dim: Dim) -> str:
    """SI unit text of a dimension, e.g. "N*m/rad"; "1" when dimensionless."""
    if dim in _SI_TEXT:
        return _SI_TEXT[dim]
    named = zip(("kg", "m", "s", "rad"), (dim.mass, dim.length, dim.time, dim.angle))
    up = [_power(u, e) for u, e in named if e > 0]
    named = zip(("kg", "m", "s", "rad"), (dim.mass, dim.length, dim.time, dim.angle))
    down = [_power(u, -e) for u, e in named if e < 0]
    return "*".join(up or ["1"]) + "".join("/" + d for d in down)


def _power(unit: str, exponent: int) -> str:
    return unit if exponent == 1 else f"{unit}^{exponent}"


def describe(dim: Dim) -> str:
    """A dimension in words with its SI unit: "torque per angle (N*m/rad)"."""
    if dim == NONE:
        return "a plain number (no unit)"
    word = _WORDS.get(dim, "a quantity")
    return f"{word} ({si_text(dim)})"


def unit_suggestion(name: str) -> str:
    """The unit a misspelt unit name most likely meant, or ""."""
    if name in ALIASES:
        return ALIASES[name]
    if len(name) < 3:  # too short to guess from: 'k' is more likely a missing '*'
        return ""
    close = difflib.get_close_matches(name, list(UNITS), n=1, cutoff=0.6)
    return close[0] if close else ""
