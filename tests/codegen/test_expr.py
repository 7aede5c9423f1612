"""IR expressions to sympy, node by node."""

from __future__ import annotations

import math

import pytest
import sympy

from depsim.codegen.expr import ConstantScope, number, to_sympy
from depsim.dsl import ir

P = (sympy.Symbol("a", real=True), sympy.Symbol("b", real=True))
T = sympy.Symbol("t", real=True)
SCOPE = ConstantScope(P, T)


def value(expr: ir.Expr, a: float = 0.3, b: float = 0.7) -> float:
    return float(to_sympy(expr, SCOPE).xreplace({P[0]: a, P[1]: b}))


@pytest.mark.parametrize("name, arity", sorted(ir.FUNCTIONS.items()))
def test_every_function(name, arity):
    args = (ir.ParamRef(0), ir.ParamRef(1))[:arity]
    reference = {"abs": abs, "min": min, "max": max}.get(name) or getattr(math, name)
    assert value(ir.Call(name, args)) == pytest.approx(reference(*(0.3, 0.7)[:arity]), rel=1e-14)


@pytest.mark.parametrize("op, expected", [("+", 1.0), ("-", -0.4), ("*", 0.21),
                                          ("/", 0.3 / 0.7), ("^", 0.3**0.7)])
def test_binary_operators(op, expected):
    assert value(ir.Binary(op, ir.ParamRef(0), ir.ParamRef(1))) == pytest.approx(expected)


def test_unary_minus_and_parameters():
    assert to_sympy(ir.Unary("-", ir.ParamRef(1)), SCOPE) == -P[1]
    assert to_sympy(ir.Time(), SCOPE) == T


def test_numbers():
    assert number(2.0) == 2 and isinstance(number(2.0), sympy.Integer)
    assert number(math.radians(90)) == sympy.pi / 2
    assert number(60 * math.pi / 180) == sympy.pi / 3
    assert number(-math.pi) == -sympy.pi
    assert isinstance(number(0.01835), sympy.Float) and float(number(0.01835)) == 0.01835
    assert isinstance(number(math.pi / 2 + 1e-9), sympy.Float)
    assert float(number(1e300)) == 1e300


def test_state_references_are_not_constants():
    with pytest.raises(TypeError, match="state reference"):
        to_sympy(ir.HingeAngle(0), SCOPE)
