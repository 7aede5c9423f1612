"""Syntax expressions -> IR expressions in SI units, with their dimensions checked.

What a bare name means depends on where the expression stands (`Context`): parameters and
units everywhere; hinges, sliders, time and dotted state quantities (`rod.b.x`) only in
outputs. Errors are reported and the offending subexpression yields None, so one pass
reports every problem without cascades.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

from .errors import Reporter, at, did_you_mean
from .evaluate import EvaluationError, Typed, binary, call, evaluate, is_constant, negate, \
    param_indices
from .ir import FUNCTIONS, Dim, Expr, HingeAngle, Num, SliderPosition, Span, Time
from .names import SymbolTable
from .state_refs import point_argument, resolve_dotted
from .syntax import AstExpr, BinaryOp, CallExpr, NameRef, NumberLit, Quantity, UnaryOp
from .units import ANGLE, NONE, UNITS, describe, dim_div, dim_mul, dim_scale, parse_unit


FULL_TURN = 2 * math.pi


def plain_number(node: AstExpr) -> tuple[str, float] | None:
    """(text, value) of a number written without a unit, with its signs (`90`, `-90`);
    None for anything else."""
    negative = False
    while isinstance(node, UnaryOp):
        negative ^= node.op == "-"
        node = node.arg
    if not isinstance(node, NumberLit):
        return None
    return ("-" if negative else "") + node.text, -node.value if negative else node.value


def warn_plain_angle(report: Reporter, node: AstExpr, lead: str) -> None:
    """W005 when a plain number stands for an angle (so it is in radians) but looks like
    degrees: more than a full turn, or a whole number other than 0. `lead` starts the
    message: "latch is an angle:"."""
    found = plain_number(node)
    if found is None:
        return
    text, value = found
    whole = text.lstrip("-").isdigit()
    if value == 0 or not (abs(value) > FULL_TURN or whole):
        return
    report.warning("W005", f"{lead} the plain number {text} is taken as {text} rad "
                   f"({math.degrees(value):.4g} deg)", node.span,
                   hint=f"did you mean {text} deg? (write {text} rad to keep radians)")


class Context(Enum):
    CONSTANT = "constant"  # params, attributes, initial values, settings
    OUTPUT = "output"  # may also use the state and time


@dataclass(frozen=True, slots=True)
class ParamInfo:
    """What a declared parameter's name stands for: a ParamRef (free parameter) or the
    expression it was defined by (derived). `end` is where its statement ends."""

    typed: Typed | None  # None when its definition had errors
    span: Span
    end: tuple[int, int]


def compatible(a: Dim, b: Dim) -> Dim | None:
    """The dimension of a + b, or None. A plain number counts as an angle in radians."""
    if a == b:
        return a
    if {a, b} == {ANGLE, NONE}:
        return ANGLE
    return None


class ExprResolver:
    """Resolves syntax expressions against the symbol table and the declared parameters."""

    def __init__(self, symbols: SymbolTable, report: Reporter) -> None:
        self.symbols = symbols
        self.report = report
        self.params: dict[str, ParamInfo] = {}
        self.used_params: set[str] = set()
        self.spatial = False  # a spatial model: its members' state has z (dsl/state_refs.py)

    def resolve(self, node: AstExpr, context: Context) -> Typed | None:
        method = getattr(self, "_resolve_" + type(node).__name__)
        return method(node, context)

    # --- leaves --------------------------------------------------------------------------

    def _resolve_NumberLit(self, node: NumberLit, context: Context) -> Typed | None:
        if not math.isfinite(node.value):
            self.report.error("E007", f"number {node.text} is too large", node.span)
            return None
        return Typed(Num(node.value), NONE)

    def _resolve_Quantity(self, node: Quantity, context: Context) -> Typed | None:
        value = self.resolve(node.value, context)
        if value is None:
            return None
        factor, dim = parse_unit(node.unit)
        return self._folded(Typed(binary("*", value.expr, Num(factor)),
                                  dim_mul(value.dim, dim)), (value.expr,), node)

    def _resolve_NameRef(self, node: NameRef, context: Context) -> Typed | None:
        if len(node.parts) > 1:
            return resolve_dotted(self, node, context is Context.OUTPUT)
        name = node.parts[0].text
        if name == "pi":
            return Typed(Num(math.pi), NONE)
        if name in self.params:
            return self._param(name, node)
        symbol = self.symbols.get(name)
        if context is Context.OUTPUT:
            if name == "t":
                return Typed(Time(), Dim(time=1))
            if symbol is not None and symbol.kind == "hinge":
                return Typed(HingeAngle(symbol.index), ANGLE)
            if symbol is not None and symbol.kind == "slider":
                return Typed(SliderPosition(symbol.index), Dim(length=1))
        if symbol is None and name in UNITS:
            return Typed(Num(UNITS[name].factor), UNITS[name].dim)
        self._misplaced_name(name, node, context)
        return None

    def _param(self, name: str, node: NameRef) -> Typed | None:
        info = self.params[name]
        if (node.span.line, node.span.col) < info.end:
            self.report.error("E015", f"parameter '{name}' is used before its declaration",
                              node.span, notes=[f"declared at {at(info.span)}"])
            return None
        self.used_params.add(name)
        return info.typed

    def _misplaced_name(self, name: str, node: NameRef, context: Context) -> None:
        symbol = self.symbols.get(name)
        span = node.span
        if symbol is None and name != "t":
            self.report.error("E010", f"unknown name '{name}'", span,
                              hint=did_you_mean(name, self.candidates(context)))
            return
        if name == "t":
            message, hint = "time 't' can be used only in outputs", ""
        elif symbol.kind == "param":  # declared by a later statement
            self.report.error("E015", f"parameter '{name}' is used before its declaration",
                              span, notes=[f"declared at {at(symbol.span)}"])
            return
        elif symbol.kind in ("bar", "body", "beam", "ground", "particle"):
            message = f"{symbol.describe()} has no value here; a member's angle can be " \
                "used only in a hinge's angle"
            hint = {"beam": f"for its chord angle in an output, write {name}.chord",
                    "particle": f"a particle does not turn; its position is {name}.x, "
                                f"{name}.y"}.get(symbol.kind,
                                                 f"for its angle in an output, write {name}.phi")
        elif symbol.kind == "system":
            message = "the system has no value of its own"
            hint = "write one of its quantities, e.g. system.momentum_x, system.kinetic_energy"
        elif symbol.kind in ("weld", "spring", "free", "ball", "cylindrical", "universal"):
            message = f"{symbol.describe()} has no value of its own"
            hint = {"weld": f"its loads: {name}.force_x, {name}.force_y, {name}.torque",
                    "spring": f"its force, length and rate: {name}.force, {name}.length, "
                              f"{name}.rate",
                    "cylindrical": f"its angle and position: {name}.angle, {name}.position",
                    "universal": f"its angles: {name}.angle_a, {name}.angle_b"
                    }.get(symbol.kind, "")
        elif symbol.kind in ("hinge", "slider"):
            message = f"{symbol.describe()} can be used only in outputs and cable angles"
            hint = ""
        else:
            message, hint = f"{symbol.describe()} has no value", ""
        self.report.error("E018", message, span, hint=hint)

    def candidates(self, context: Context) -> list[str]:
        names = list(self.params) + list(UNITS) + ["pi"]
        if context is Context.OUTPUT:
            names += self.symbols.names_of_kind("hinge", "slider") + ["t"]
        return names

    # --- operators -----------------------------------------------------------------------

    def _resolve_UnaryOp(self, node: UnaryOp, context: Context) -> Typed | None:
        arg = self.resolve(node.arg, context)
        if arg is None or node.op == "+":
            return arg
        return Typed(negate(arg.expr), arg.dim)

    def _resolve_BinaryOp(self, node: BinaryOp, context: Context) -> Typed | None:
        left = self.resolve(node.left, context)
        right = self.resolve(node.right, context)
        if left is None or right is None:
            return None
        operands = (left.expr, right.expr)
        if node.op in "+-":
            dim = compatible(left.dim, right.dim)
            if dim is None:
                verb = "add" if node.op == "+" else "subtract"
                self.report.error(
                    "E032", f"cannot {verb} {describe(right.dim)} "
                    f"{'to' if node.op == '+' else 'from'} {describe(left.dim)}", node.span,
                    hint=_angle_hint(left.dim, right.dim))
                return None
            if left.dim != right.dim:  # an angle and a plain number: radians
                plain = node.left if left.dim == NONE else node.right
                warn_plain_angle(self.report, plain, "in a sum with an angle,")
            typed = Typed(binary(node.op, left.expr, right.expr), dim)
        elif node.op == "*":
            typed = Typed(binary("*", left.expr, right.expr), dim_mul(left.dim, right.dim))
        elif node.op == "/":
            if right.expr == Num(0.0):  # a constant zero divisor: never a value
                self.report.error("E027", "cannot evaluate: division by zero", node.span,
                                  hint=_zero_hint(node.right))
                return None
            typed = Typed(binary("/", left.expr, right.expr), dim_div(left.dim, right.dim))
        else:
            typed = self._power(node, left, right)
        return None if typed is None else self._folded(typed, operands, node)

    def _folded(self, typed: Typed, operands: tuple[Expr, ...], node) -> Typed | None:
        """`typed`, unless its operands are numbers and it has no value (the builders fold
        numbers, so a node left over means division by zero, a function outside its domain
        or overflow): E027 at `node`."""
        if isinstance(typed.expr, Num) or not all(isinstance(o, Num) for o in operands):
            return typed
        try:
            evaluate(typed.expr, ())
        except EvaluationError as error:
            self.report.error("E027", f"cannot evaluate: {error}", node.span)
            return None
        return typed

    def _power(self, node: BinaryOp, base: Typed, exponent: Typed) -> Typed | None:
        if exponent.dim != NONE:
            self.report.error("E033", f"an exponent must be a plain number, got "
                              f"{describe(exponent.dim)}", node.right.span)
            return None
        if base.dim == NONE:
            return Typed(binary("^", base.expr, exponent.expr), NONE)
        if param_indices(exponent.expr) or not is_constant(exponent.expr):
            self.report.error("E033", "the exponent of a quantity with a unit must be a "
                              "fixed number", node.right.span,
                              hint=f"the base is {describe(base.dim)}")
            return None
        power = self.constant_value(exponent.expr, node.right.span)
        if power is None:
            return None
        dim = dim_scale(base.dim, power)
        if dim is None:
            self.report.error("E033", f"{describe(base.dim)} to the power {power:g} has a "
                              "fractional unit", node.span)
            return None
        return Typed(binary("^", base.expr, Num(power)), dim)

    def constant_value(self, expr: Expr, span: Span) -> float | None:
        try:
            return evaluate(expr, ())
        except EvaluationError as error:
            self.report.error("E027", f"cannot evaluate: {error}", span)
            return None

    # --- functions -----------------------------------------------------------------------

    def _resolve_CallExpr(self, node: CallExpr, context: Context) -> Typed | None:
        name = node.func.text
        if name == SYSTEM_FUNCTION:
            return self._angular_momentum(node, context)
        if name not in FUNCTIONS:
            self.report.error("E016", f"unknown function '{name}'", node.func.span,
                              hint=did_you_mean(name, FUNCTIONS) or
                              "functions: " + ", ".join(FUNCTIONS))
            return None
        if len(node.args) != FUNCTIONS[name]:
            count = FUNCTIONS[name]
            self.report.error("E017", f"{name} takes {count} argument{'s' * (count > 1)}, "
                              f"got {len(node.args)}", node.span)
            return None
        args = [self.resolve(a, context) for a in node.args]
        if any(a is None for a in args):
            return None
        dim = self._call_dim(node, [a.dim for a in args])
        if dim is None:
            return None
        exprs = tuple(a.expr for a in args)
        return self._folded(Typed(call(name, exprs), dim), exprs, node)

    def _angular_momentum(self, node: CallExpr, context: Context) -> Typed | None:
        """`angular_momentum(MEMBER.POINT)`: the system's angular momentum about a point."""
        if context is not Context.OUTPUT:
            self.report.error("E018", "angular_momentum is a state quantity; it can be used "
                              "only in outputs", node.span)
            return None
        if self.spatial:
            self.report.error("E060", "angular_momentum(MEMBER.POINT) is a planar model's: a "
                              "spatial model has system.angular_momentum_x, _y, _z about the "
                              "centre of mass", node.span)
            return None
        if len(node.args) != 1:
            self.report.error("E017", f"angular_momentum takes 1 argument, got "
                              f"{len(node.args)}", node.span)
            return None
        return point_argument(self, node.args[0])

    def _call_dim(self, node: CallExpr, dims: list[Dim]) -> Dim | None:
        name = node.func.text
        if name in ("sin", "cos", "tan"):
            ok, result, wanted = dims[0] in (NONE, ANGLE), NONE, "an angle or a plain number"
        elif name in ("asin", "acos", "atan", "sinh", "cosh", "tanh", "exp", "log"):
            ok, wanted = dims[0] == NONE, "a plain number"
            result = ANGLE if name in ("asin", "acos", "atan") else NONE
        elif name == "sqrt":
            result = dim_scale(dims[0], 0.5)
            ok, wanted = result is not None, "a quantity whose unit has even powers"
        elif name == "abs":
            ok, result, wanted = True, dims[0], ""
        else:  # atan2, min, max: two arguments of one dimension
            common = compatible(dims[0], dims[1])
            ok, wanted = common is not None, "two arguments with the same unit"
            result = ANGLE if name == "atan2" else common
        if not ok:
            got = " and ".join(describe(d) for d in dims)
            self.report.error("E034", f"{name} expects {wanted}, got {got}", node.span)
            return None
        return result


def parse_quantity(text: str) -> tuple[float, Dim]:
    """The SI value and dimension of a constant written as in a model: "1.5 N*m", "90 deg",
    "0.7", "4500 * 0.01835^2 N*m/rad". Only units, `pi` and functions may be named.
    Raises ValueError saying what is wrong."""
    from .names import SymbolTable
    from .parse import parse_expression

    report = Reporter()
    node = parse_expression(text, "<value>", report)
    typed = ExprResolver(SymbolTable(), report).resolve(node, Context.CONSTANT) \
        if node is not None else None
    value = None
    if typed is not None:
        value = ExprResolver(SymbolTable(), report).constant_value(typed.expr, node.span)
    if value is None or report.has_errors:
        raise ValueError(report.errors()[0].message)
    return value, typed.dim


# The one function whose argument is a point, not a value: the system's angular momentum about
# that point (outputs only).
SYSTEM_FUNCTION = "angular_momentum"


def _angle_hint(a: Dim, b: Dim) -> str:
    """When two dimensions differ by the angle alone: divide (or multiply) by rad."""
    ratio = dim_div(a, b)
    if ratio == Dim(angle=1) or ratio == Dim(angle=-1):
        return ("the two differ by rad, which is a unit of its own here: divide the side in "
                "rad by rad (an inertia times an angular rate is in kg*m^2*rad/s; "
                "`J * rod.omega / rad` is in kg*m^2/s, N*m*s)")
    return ""


def _zero_hint(divisor: AstExpr) -> str:
    """Which divisor is zero, when it is not written as 0."""
    if isinstance(divisor, NameRef):
        return f"'{divisor.dotted}' is zero"
    return "" if isinstance(divisor, NumberLit) else "the divisor is zero"
