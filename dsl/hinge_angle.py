"""A hinge's `angle = ±(B - A) + offset`: its sign and offset from the written expression.

Member names stand for their absolute angles and `ground` (and a particle) for 0. The
expression must be linear with coefficient ±1 on B (the member joined second) and the
opposite on A; the ground's (or a particle's) term may be left out. Everything else is the offset (an angle; a plain number is
taken in radians).
"""

from __future__ import annotations

from .attributes import AttributeReader
from .errors import did_you_mean
from .evaluate import binary, negate
from .expressions import plain_number
from .ir import Expr, Num
from .linear import LinearForm, NotLinear, Term, linearize
from .names import MEMBER_KINDS, Symbol, SymbolTable, element_name
from .syntax import AttributeItem, JointStmt, VectorLit
from .units import ANGLE, NONE

_FORM = "hinge angle must be ±(B - A) + offset"
_NO_ANGLE = ("ground", "particle")  # their angle is 0: their term may be left out


def hinge_angle(statement: JointStmt, item: AttributeItem | None, ends,
                symbols: SymbolTable, reader: AttributeReader) -> tuple[int, Expr] | None:
    """(sign, offset) of the hinge angle; (1, 0) when `angle` is not given."""
    (a, _), (b, _) = ends
    if item is None:
        return 1, Num(0.0)
    example = f"e.g. angle = {b.name} - {a.name} + 180 deg"
    if isinstance(item.value, VectorLit):
        reader.report.error("E023", f"{_FORM}, not a vector", item.value.span, hint=example)
        return None
    try:
        form = linearize(item.value, element_name(symbols))
    except NotLinear as error:
        reader.report.error("E041", _FORM, error.node.span, hint=example)
        return None
    if not _only_joined(form, a, b, statement, symbols, reader):
        return None
    sign = _sign(form, a, b)
    if sign is None:
        reader.report.error("E041", f"{_FORM}, with B = {b.name} and A = {a.name} "
                            "(the members in the order joined)", item.value.span, hint=example)
        return None
    offset = _offset(form.constants, reader)
    if offset is None:
        return None
    if form.constants:
        offset = reader.enter(f"{statement.name.text}.offset", offset, ANGLE, item.value.span)
    return (sign, offset) if offset is not None else None


def _only_joined(form: LinearForm, a: Symbol, b: Symbol, statement: JointStmt,
                 symbols: SymbolTable, reader: AttributeReader) -> bool:
    ok = True
    for name, terms in form.terms.items():
        if name in (a.name, b.name):
            continue
        ok = False
        symbol = symbols.get(name)
        span = terms[0].node.span
        joined = f"hinge '{statement.name.text}' joins {a.name} and {b.name}"
        if symbol is None:
            reader.report.error("E012", f"unknown member '{name}'", span,
                                hint=did_you_mean(name, [a.name, b.name]
                                                  + symbols.names_of_kind(*MEMBER_KINDS)))
        elif symbol.kind in MEMBER_KINDS:
            reader.report.error("E042", f"{joined}; the angle of {symbol.describe()} cannot "
                                "appear in its angle", span)
        else:
            reader.report.error("E042", f"{symbol.describe()} has no angle; {joined}", span)
    return ok


def _net_sign(terms: list[Term]) -> int | None:
    """The coefficient of a name written with + and - and plain whole numbers as factors
    (`-1 * (B - A)`, what `(-1)^i * (B - A)` is in a for loop), or None otherwise."""
    total = 0.0
    for term in terms:
        coefficient = float(term.sign)
        for op, factor in term.factors:
            number = plain_number(factor)
            if number is None or not number[0].lstrip("-").isdigit() or number[1] == 0:
                return None
            coefficient = coefficient * number[1] if op == "*" else coefficient / number[1]
        total += coefficient
    return int(total) if total.is_integer() else None


def _sign(form: LinearForm, a: Symbol, b: Symbol) -> int | None:
    ca = _net_sign(form.terms.get(a.name, []))
    cb = _net_sign(form.terms.get(b.name, []))
    if ca is None or cb is None:
        return None
    if a.kind in _NO_ANGLE:
        sign, ok = cb, ca in (0, -cb)
    elif b.kind in _NO_ANGLE:
        sign, ok = -ca, cb in (0, -ca)
    else:
        sign, ok = cb, ca == -cb
    return sign if ok and sign in (1, -1) else None


def _offset(constants: list[Term], reader: AttributeReader) -> Expr | None:
    """The sum of the constant terms, an angle in rad."""
    total: Expr = Num(0.0)
    for term in constants:
        typed = reader.quantity(term.node, ANGLE, "hinge angle offset")
        if typed is None:
            return None
        value = typed.expr
        for op, factor in term.factors:
            scale = reader.quantity(factor, NONE, "a factor of the hinge angle offset")
            if scale is None:
                return None
            value = binary(op, value, scale.expr)
        total = binary("+", total, value if term.sign > 0 else negate(value))
    return total
