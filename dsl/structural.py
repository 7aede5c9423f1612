"""Structural values: the whole numbers fixed when a model is checked.

Loop bounds (`for i in 1..N`), indices (`panel[i-1]`, `m[2]`) and array sizes are computed
here, exactly (as fractions), from whole numbers, loop variables and *structural
parameters*. A structural parameter is a `param` declared outside any loop and used in one
of those places (or in the definition of another structural parameter): it is a whole
number without a unit, fixed when the model is checked, and not an entry of the run-time
parameter vector (`Model.structural`; `--set N=20` is refused).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, fields, is_dataclass
from fractions import Fraction

from .errors import Reporter, at
from .ir import Span
from .syntax import (BinaryOp, CallExpr, ForLoop, Ident, ListPick, NameRef, NumberLit,
                     ParamStmt, Quantity, SourceFile, UnaryOp)

MAX_MAGNITUDE = 10 ** 12  # any value computed for a bound or an index
MAX_POWER = 64  # the largest exponent taken exactly


@dataclass(frozen=True, slots=True)
class Structural:
    """A structural parameter: its value (None when its definition has errors), where it
    is declared and where its statement ends (it may be used only after that)."""

    name: str
    value: int | None
    span: Span
    end: tuple[int, int]


class NotFixed(Exception):
    """A bound, index or size that is not a whole number fixed at check time. `node` is the
    offending text; `code` overrides the caller's code (E010, E015); message "" when the
    cause was reported already."""

    def __init__(self, node, message: str, code: str = "", hint: str = "") -> None:
        super().__init__(message)
        self.node = node
        self.message = message
        self.code = code
        self.hint = hint


def exact(node, loop: dict[str, int], structural: dict[str, Structural]) -> Fraction:
    """The exact value of `node`, built from numbers, loop variables (`loop`) and
    structural parameters with + - * / ^, min, max, abs and list picks. Raises NotFixed."""
    method = _EXACT.get(type(node))
    if method is None:
        raise NotFixed(node, "only whole numbers, loop variables and structural parameters "
                       "combined with + - * / ^ can be used here")
    value = method(node, loop, structural)
    if abs(value) > MAX_MAGNITUDE:
        raise NotFixed(node, f"the value is too large (more than {MAX_MAGNITUDE:.0e})")
    return value


def _number(node: NumberLit, loop, structural) -> Fraction:
    return Fraction(node.text)


def _name(node: NameRef, loop, structural) -> Fraction:
    name = node.parts[0].text
    if len(node.parts) > 1 or node.parts[0].indices:
        raise NotFixed(node, f"'{node.dotted}' is not fixed when the model is checked: only "
                       "whole numbers, loop variables and structural parameters can be used "
                       "here")
    if name in loop:
        return Fraction(loop[name])
    if name in structural:
        param = structural[name]
        if (node.span.line, node.span.col) < param.end:
            raise NotFixed(node, f"parameter '{name}' is used before its declaration",
                           "E015", hint=f"it is declared at {at(param.span)}")
        if param.value is None:
            raise NotFixed(node, "")  # its definition's error is reported
        return Fraction(param.value)
    raise NotFixed(node, f"unknown name '{name}': only whole numbers, loop variables and "
                   "structural parameters can be used here", "E010")


def _unary(node: UnaryOp, loop, structural) -> Fraction:
    value = exact(node.arg, loop, structural)
    return -value if node.op == "-" else value


def _binary(node: BinaryOp, loop, structural) -> Fraction:
    left = exact(node.left, loop, structural)
    right = exact(node.right, loop, structural)
    if node.op == "+":
        return left + right
    if node.op == "-":
        return left - right
    if node.op == "*":
        return left * right
    if node.op == "/":
        if right == 0:
            raise NotFixed(node, "division by zero")
        return left / right
    return _power(node, left, right)


def _power(node: BinaryOp, left: Fraction, right: Fraction) -> Fraction:
    """left ^ right for a whole exponent. A power of 1, -1 or 0 keeps its size, so it is
    taken for any whole exponent (`(-1)^i` for every i a loop may count to); any other
    base only for exponents from -MAX_POWER to MAX_POWER."""
    if right.denominator == 1 and abs(left) in (0, 1) and not (left == 0 and right < 0):
        if left == 0:
            return Fraction(1) if right == 0 else Fraction(0)
        return left if right.numerator % 2 else abs(left)
    if right.denominator != 1 or abs(right) > MAX_POWER:
        raise NotFixed(node.right, f"an exponent here is a whole number from -{MAX_POWER} "
                       f"to {MAX_POWER}")
    if left == 0 and right < 0:
        raise NotFixed(node, "division by zero")
    if abs(left) > 1 and abs(right) * max(abs(left).numerator.bit_length(),
                                          abs(left).denominator.bit_length()) > 128:
        raise NotFixed(node, f"the value is too large (more than {MAX_MAGNITUDE:.0e})")
    return left ** int(right)


def _call(node: CallExpr, loop, structural) -> Fraction:
    name = node.func.text
    if name not in ("min", "max", "abs") or len(node.args) != (1 if name == "abs" else 2):
        raise NotFixed(node, "only min(a, b), max(a, b) and abs(a) can be used here")
    args = [exact(arg, loop, structural) for arg in node.args]
    return abs(args[0]) if name == "abs" else min(args) if name == "min" else max(args)


def _pick(node: ListPick, loop, structural) -> Fraction:
    return exact(node.values[pick_index(node, loop, structural) - 1], loop, structural)


def _unit(node: Quantity, loop, structural) -> Fraction:
    raise NotFixed(node, f"a unit ('{node.unit}') cannot be used here: this is a plain "
                   "whole number")


_EXACT = {NumberLit: _number, NameRef: _name, UnaryOp: _unary, BinaryOp: _binary,
          CallExpr: _call, ListPick: _pick, Quantity: _unit}


def whole(node, loop, structural, what: str) -> int:
    """`exact` as an int; NotFixed when it is a fraction. `what` names it in the message."""
    value = exact(node, loop, structural)
    if value.denominator != 1:
        raise NotFixed(node, f"{what} must be a whole number, got {float(value):g}")
    return int(value)


def pick_index(node: ListPick, loop, structural) -> int:
    """The index of `(a, b, c)[k]`, from 1 to the number of values."""
    k = whole(node.index, loop, structural, "the index of a list")
    if not 1 <= k <= len(node.values):
        raise NotFixed(node.index, f"index {k} is out of range: the list has "
                       f"{len(node.values)} values (indices 1 to {len(node.values)})", "E052")
    return k


# --- which parameters are structural --------------------------------------------------------


def structural_params(source: SourceFile, report: Reporter) -> dict[str, Structural]:
    """The structural parameters of `source` with their values, in file order. Errors in
    their definitions are E055 (their value is then None)."""
    loop_vars = {node.var.text for node in walk(source.statements) if isinstance(node, ForLoop)}
    top = {s.name.text: s for s in source.statements
           if isinstance(s, ParamStmt) and not s.name.indices}
    wanted = {name for name in _fixed_names(source.statements) if name not in loop_vars}
    pending = [name for name in wanted if name in top]
    found: set[str] = set()
    while pending:  # the parameters structural ones are defined with are structural too
        name = pending.pop()
        if name in found:
            continue
        found.add(name)
        pending += [ref.parts[0].text for ref in walk((top[name].value,))
                    if isinstance(ref, NameRef) and ref.parts[0].text in top]
    result: dict[str, Structural] = {}
    for name, statement in top.items():
        if name in found:
            value = _structural_value(statement, result, report)
            end = (statement.span.end_line, statement.span.end_col)
            result[name] = Structural(name, value, statement.name.span, end)
    return result


def _structural_value(statement: ParamStmt, known: dict[str, Structural],
                      report: Reporter) -> int | None:
    name = statement.name.text
    lead = f"'{name}' is a structural parameter (used for a loop bound or an index)"
    try:
        return whole(statement.value, {}, known, f"{lead}, so it")
    except NotFixed as problem:
        if problem.message:
            message = problem.message if problem.code == "E015" or "must be a whole" \
                in problem.message else f"{lead}: {problem.message}"
            report.error(problem.code or "E055", message, problem.node.span,
                         hint=problem.hint or f"write a whole number without a unit, e.g. "
                         f"param {name} = 12")
        return None


def _fixed_names(nodes) -> Iterator[str]:
    """Names used where a fixed whole number is needed: loop bounds, indices, list picks."""
    for node in walk(nodes):
        if isinstance(node, ForLoop):
            exprs = (node.start, node.stop)
        elif isinstance(node, Ident):
            exprs = node.indices
        elif isinstance(node, ListPick):
            exprs = (node.index,)
        else:
            continue
        for ref in walk(exprs):
            if isinstance(ref, NameRef) and len(ref.parts) == 1:
                yield ref.parts[0].text


def walk(nodes) -> Iterator:
    """Every syntax node in `nodes` (a sequence), depth first. Iterative."""
    stack = list(reversed(nodes))
    while stack:
        node = stack.pop()
        if isinstance(node, tuple):
            stack.extend(reversed(node))
        elif is_dataclass(node) and not isinstance(node, Span):
            yield node
            stack.extend(reversed([getattr(node, f.name) for f in fields(node)]))


def fixed_message(name: str, value: int) -> str:
    """What to say when a run asks to change structural parameter `name` (`--set N=20`)."""
    return (f"'{name}' is a structural parameter (a loop bound or an index, {name} = {value}): "
            "it is fixed when the model is checked, not a run-time parameter; to change it, "
            f"edit `param {name} = {value}` in the model and run again")
