"""`input` statements: external loads a run or a co-simulation drives (docs/language.md,
Inputs).

    input T_motor torque on h1              # N*m on hinge h1: +T on member b, -T on member a
    input F_push force on panel1.tip = (0, 2) N   # N, ground frame: inputs F_push.x, F_push.y
                                                  # (and F_push.z in a spatial model)

Each component becomes two entries of the parameter vector, its value at t = 0 (the
default, else 0) and its rate `<component>.rate` (0), so u(t) = value + rate t: constant
unless the run changes them (a time table, an FMU's inputs).
"""

from __future__ import annotations

from .attributes import AttributeReader
from .errors import did_you_mean, join_names
from .evaluate import param_indices
from .ir import Dim, Input, InputKind, Param, ParamKind, Span
from .joints import attachment
from .members import read_vector
from .names import SymbolTable
from .syntax import AttachmentRef, InputStmt, VectorLit
from .units import FORCE, TORQUE, dim_div, si_text


def resolve_input(statement: InputStmt, symbols: SymbolTable, reader: AttributeReader
                  ) -> Input | None:
    """The checked input with its parameter entries; None (reported) on errors."""
    name = statement.name.text
    if statement.kind == "torque":
        hinge = _hinge(statement, symbols, reader)
        if hinge is None:
            return None
        values = _torque_default(statement, reader)
        if values is None:
            return None
        components, dim, where = (name,), TORQUE, (hinge, None)
    else:
        if statement.point is None:
            reader.report.error("E047", f"a force input acts on a point: write "
                                f"'{statement.target.text}.POINT'", statement.target.span,
                                hint=f"e.g. input {name} force on {statement.target.text}.b")
            return None
        ref = AttachmentRef(statement.target, statement.point, _joined(statement))
        found = attachment(ref, symbols, reader)
        if found is None:
            return None
        if found[0].kind == "ground":
            reader.report.error("E047", "a force input on the ground moves nothing",
                                statement.target.span, hint="apply it to a body or a beam")
            return None
        values = _force_default(statement, reader)
        if values is None:
            return None
        axes = "xyz" if reader.spatial else "xy"
        components, dim, where = tuple(f"{name}.{axis}" for axis in axes), FORCE, \
            (None, found[1])
    slots = []
    for component, value in zip(components, values):
        ref = reader.vector.add(Param(component, value, dim, si_text(dim), ParamKind.INPUT,
                                      statement.name.span))
        reader.vector.add(Param(f"{component}.rate", 0.0, dim_div(dim, Dim(time=1)),
                                f"{si_text(dim)}/s", ParamKind.INPUT, statement.name.span))
        slots.append(ref.index)
    return Input(name, InputKind(statement.kind), where[0], where[1], components, tuple(slots),
                 statement.span)


def _hinge(statement: InputStmt, symbols: SymbolTable, reader: AttributeReader) -> int | None:
    target = statement.target
    symbol = symbols.get(target.text)
    if symbol is None or symbol.kind != "hinge" or statement.point is not None:
        hinges = symbols.names_of_kind("hinge")
        what = f"'{target.text}' is {symbol.describe()}, not a hinge" if symbol \
            else f"unknown hinge '{target.text}'"
        if statement.point is not None and symbol is not None and symbol.kind == "hinge":
            what = "a torque input acts on a hinge, not on a point"
        reader.report.error("E047", f"torque input '{statement.name.text}': {what}",
                            _joined(statement) if statement.point else target.span,
                            hint=did_you_mean(target.text, hinges)
                            or f"hinges: {join_names(hinges)}" if hinges
                            else "a torque input acts on a hinge; the model has none")
        return None
    return symbol.index


def _constant(statement: InputStmt, reader: AttributeReader, expr, span, what) -> float | None:
    if param_indices(expr):
        reader.report.error("E047", f"{what} is a number with its unit, not an expression of "
                            "parameters", span, hint="the input itself can be set per run "
                            f"(--set {statement.name.text}=...)")
        return None
    return reader.value(expr, span, what)


def _torque_default(statement: InputStmt, reader: AttributeReader) -> tuple[float] | None:
    if statement.default is None:
        return (0.0,)
    what = f"input '{statement.name.text}'"
    typed = reader.quantity(statement.default, TORQUE, what)
    if typed is None:
        return None
    value = _constant(statement, reader, typed.expr, statement.default.span, what)
    return None if value is None else (value,)


def _force_default(statement: InputStmt, reader: AttributeReader
                   ) -> tuple[float, ...] | None:
    """The force's components at t = 0 (x, y and in a spatial model z; 0 without one)."""
    axes = "xyz" if reader.spatial else "xy"
    if statement.default is None:
        return (0.0,) * len(axes)
    what = f"input '{statement.name.text}'"
    default = statement.default
    if not isinstance(default, VectorLit):
        example = "(0, 0, 1) N" if reader.spatial else "(0, 1) N"
        reader.report.error("E023", f"{what} is a force: give all {len(axes)} components, "
                            f"e.g. {example}", default.span)
        return None
    vector = read_vector(_Expressions(reader), default, FORCE, what, tuple(axes))
    if vector is None:
        return None
    values = [_constant(statement, reader, expr, component.span, what)
              for expr, component in zip(vector, default.components)]
    return None if None in values else tuple(values)


class _Expressions:
    """read_vector's reader for a value that is not an attribute: its units and checks,
    its components left as expressions (the input adds its own parameter entries)."""

    def __init__(self, reader: AttributeReader) -> None:
        self.resolver = reader.resolver
        self.expect = reader.expect
        self.spatial = reader.spatial
        self.report = reader.report

    def enter(self, entry, expr, dim, span):
        return expr


def _joined(statement: InputStmt):
    """The span of `MEMBER.POINT` (or the target alone)."""
    first, last = statement.target.span, (statement.point or statement.target).span
    return Span(first.file, first.line, first.col, last.end_line, last.end_col)
