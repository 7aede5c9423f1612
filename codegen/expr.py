"""IR expression trees to sympy, node by node. Model text is never parsed or sympified here:
every sympy node is built from the matching IR node."""

from __future__ import annotations

import math
import operator
from typing import Callable, Protocol

import sympy

from depsim.dsl import ir

# One sympy constructor per function name the checker allows (ir.FUNCTIONS).
FUNCTIONS: dict[str, Callable[..., sympy.Expr]] = {
    "sin": sympy.sin, "cos": sympy.cos, "tan": sympy.tan,
    "asin": sympy.asin, "acos": sympy.acos, "atan": sympy.atan, "atan2": sympy.atan2,
    "sinh": sympy.sinh, "cosh": sympy.cosh, "tanh": sympy.tanh,
    "sqrt": sympy.sqrt, "exp": sympy.exp, "log": sympy.log, "abs": sympy.Abs,
    "min": sympy.Min, "max": sympy.Max,
}
assert FUNCTIONS.keys() == ir.FUNCTIONS.keys(), "codegen and the checker disagree on functions"

BINARY: dict[str, Callable[[sympy.Expr, sympy.Expr], sympy.Expr]] = {
    "+": operator.add, "-": operator.sub, "*": operator.mul, "/": operator.truediv,
    "^": sympy.Pow,
}

# Integral values below this magnitude become exact sympy Integers (keeps theta**2 exact).
_EXACT_INTEGER_LIMIT = 2**31
# Whole degrees up to this magnitude, converted to rad by the checker, become exact k*pi/180,
# so that cos(90 deg) is 0 and angles cancel exactly.
_EXACT_DEGREE_LIMIT = 3600


class Scope(Protocol):
    """What an expression may refer to: the parameter symbols, time and the state."""

    p: tuple[sympy.Symbol, ...]
    t: sympy.Symbol

    def body_coord(self, body: int, coord: str) -> sympy.Expr: ...
    def point_coord(self, member: ir.Member, point: str, axis: str) -> sympy.Expr: ...
    def hinge_angle(self, hinge: int, rate: bool) -> sympy.Expr: ...
    def slider_position(self, slider: int, rate: bool) -> sympy.Expr: ...
    def beam_quantity(self, beam: int, kind: str) -> sympy.Expr: ...
    def joint_load(self, kind: str, index: int, quantity: str) -> sympy.Expr: ...
    def system_quantity(self, quantity: str, point: ir.Attachment | None) -> sympy.Expr: ...


def number(value: float) -> sympy.Expr:
    """A numeric literal: an exact Integer when integral, exact k*pi/180 when it is a whole
    number of degrees (to within 4 ulp), else a double Float."""
    if float(value).is_integer() and abs(value) < _EXACT_INTEGER_LIMIT:
        return sympy.Integer(int(value))
    degrees = round(math.degrees(value)) if abs(value) < math.radians(_EXACT_DEGREE_LIMIT) else 0
    if degrees and math.isclose(value, math.radians(degrees), rel_tol=4 * 2.0**-53, abs_tol=0):
        return sympy.pi * sympy.Rational(degrees, 180)
    return sympy.Float(value)


def to_sympy(expr: ir.Expr, scope: Scope) -> sympy.Expr:
    """Convert one IR expression tree to a sympy expression (one branch per node class)."""
    match expr:
        case ir.Num(value):
            return number(value)
        case ir.ParamRef(index):
            return scope.p[index]
        case ir.Unary("-", arg):
            return -to_sympy(arg, scope)
        case ir.Binary(op, left, right):
            return BINARY[op](to_sympy(left, scope), to_sympy(right, scope))
        case ir.Call(func, args):
            return FUNCTIONS[func](*(to_sympy(arg, scope) for arg in args))
        case ir.Time():
            return scope.t
        case ir.BodyCoord(body, coord):
            return scope.body_coord(body, coord)
        case ir.PointCoord(member, point, axis):
            return scope.point_coord(member, point, axis)
        case ir.HingeAngle(hinge, rate):
            return scope.hinge_angle(hinge, rate)
        case ir.SliderPosition(slider, rate):
            return scope.slider_position(slider, rate)
        case ir.BeamQuantity(beam, kind):
            return scope.beam_quantity(beam, kind)
        case ir.JointLoad(kind, index, quantity):
            return scope.joint_load(kind, index, quantity)
        case ir.SystemQuantity(quantity, point):
            return scope.system_quantity(quantity, point)
    raise TypeError(f"not an IR expression node: {expr!r}")


class ConstantScope:
    """The scope of constant expressions (element attributes): parameters only."""

    def __init__(self, p: tuple[sympy.Symbol, ...], t: sympy.Symbol):
        self.p = p
        self.t = t

    def _state(self, *_args: object) -> sympy.Expr:
        raise TypeError("state reference in a constant expression (the checker should reject it)")

    body_coord = point_coord = hinge_angle = slider_position = beam_quantity = _state
    joint_load = system_quantity = _state
