"""Numbers from constant expression trees, and the small algebra the resolver builds with.

`evaluate` computes a constant `Expr` (Num, ParamRef, Unary, Binary, Call) for given
parameter values. The builders (`add`, `mul`, ...) fold constant parts as they go, so an
attribute written as a plain quantity (`90 deg`) becomes a single `Num` in SI units.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from .ir import (BeamQuantity, Binary, BodyCoord, Call, Dim, Expr, HingeAngle, JointLoad, Num,
                 ParamRef, PointCoord, SliderPosition, SystemQuantity, Time, Unary)



@dataclass(frozen=True, slots=True)
class Typed:
    """A resolved expression (SI) and its dimension."""

    expr: Expr
    dim: Dim


class EvaluationError(ValueError):
    """A constant expression has no finite value (division by zero, log of a negative
    number, overflow) or is not constant (refers to the state or time)."""


_FUNCTIONS: dict[str, Callable[..., float]] = {
    "sin": math.sin, "cos": math.cos, "tan": math.tan, "asin": math.asin, "acos": math.acos,
    "atan": math.atan, "atan2": math.atan2, "sinh": math.sinh, "cosh": math.cosh,
    "tanh": math.tanh, "sqrt": math.sqrt, "exp": math.exp, "log": math.log, "abs": abs,
    "min": min, "max": max,
}

_OPERATORS: dict[str, Callable[[float, float], float]] = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
    "/": lambda a, b: a / b,
    "^": math.pow,
}

_STATE_NODES = (Time, BodyCoord, PointCoord, HingeAngle, SliderPosition, BeamQuantity, JointLoad,
                SystemQuantity)


def evaluate(expr: Expr, params_values: Sequence[float]) -> float:
    """The value (SI) of a constant expression; `params_values[i]` is the value of
    `ParamRef(i)`. Raises EvaluationError when there is no finite value."""
    try:
        value = _value(expr, params_values)
    except (ArithmeticError, ValueError, TypeError) as error:
        raise EvaluationError(_reason(error)) from None
    if not math.isfinite(value):
        raise EvaluationError("the result is not a finite number")
    return value


def _reason(error: Exception) -> str:
    if isinstance(error, ZeroDivisionError):
        return "division by zero"
    if isinstance(error, OverflowError):
        return "the result is too large"
    if isinstance(error, EvaluationError):
        return str(error)
    return "a function is outside its domain (e.g. log of 0, sqrt of a negative number)"


def _value(expr: Expr, params: Sequence[float]) -> float:
    if isinstance(expr, Num):
        return expr.value
    if isinstance(expr, ParamRef):
        return float(params[expr.index])
    if isinstance(expr, Unary):
        assert expr.op == "-", expr.op
        return -_value(expr.arg, params)
    if isinstance(expr, Binary):
        return _OPERATORS[expr.op](_value(expr.left, params), _value(expr.right, params))
    if isinstance(expr, Call):
        return float(_FUNCTIONS[expr.func](*(_value(a, params) for a in expr.args)))
    assert isinstance(expr, _STATE_NODES), expr
    raise EvaluationError(f"{type(expr).__name__} is not a constant")


def param_indices(expr: Expr) -> set[int]:
    """Indices of the parameters an expression refers to."""
    found: set[int] = set()
    _walk(expr, lambda node: found.add(node.index) if isinstance(node, ParamRef) else None)
    return found


def is_constant(expr: Expr) -> bool:
    """True when the expression refers to neither time nor the state."""
    state: list[Expr] = []
    _walk(expr, lambda node: state.append(node) if isinstance(node, _STATE_NODES) else None)
    return not state


def _walk(expr: Expr, visit: Callable[[Expr], object]) -> None:
    stack = [expr]
    while stack:
        node = stack.pop()
        visit(node)
        if isinstance(node, Unary):
            stack.append(node.arg)
        elif isinstance(node, Binary):
            stack.extend((node.left, node.right))
        elif isinstance(node, Call):
            stack.extend(node.args)


# --- builders that fold constants ------------------------------------------------------------


def _fold(expr: Expr) -> Expr:
    """Replace an expression without parameters or state by its Num value, when it has one."""
    if isinstance(expr, Num) or param_indices(expr) or not is_constant(expr):
        return expr
    try:
        return Num(evaluate(expr, ()))
    except EvaluationError:
        return expr  # left for the checker to report where the value is needed


def binary(op: str, left: Expr, right: Expr) -> Expr:
    """`left op right`, dropping additions of zero and multiplications by one."""
    if op in "+-" and right == Num(0.0):
        return left
    if op == "+" and left == Num(0.0):
        return right
    if op in "*/" and right == Num(1.0):
        return left
    if op == "*" and left == Num(1.0):
        return right
    return _fold(Binary(op, left, right))


def negate(arg: Expr) -> Expr:
    if isinstance(arg, Num):
        return Num(-arg.value)
    if isinstance(arg, Unary):
        return arg.arg
    return Unary("-", arg)


def call(func: str, args: tuple[Expr, ...]) -> Expr:
    return _fold(Call(func, args))
