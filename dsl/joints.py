"""Joints and what refers to them: hinges, sliders, cables and initial values.

A hinge's IR needs its initial values, which come from `initial` blocks anywhere in the
file, so hinges and sliders are first read into drafts (dicts of fields) and completed by
`resolve` once every statement has been read.
"""

from __future__ import annotations

from .attributes import SPECS, AttributeReader, read_block
from .errors import did_you_mean, join_names
from .evaluate import binary, call
from .hinge_angle import hinge_angle
from .ir import Attachment, Cable, CableTerm, Expr, Limit, Num
from .linear import LinearForm, NotLinear, linearize
from .members import read_vector
from .names import MEMBER_KINDS, Symbol, SymbolTable, element_name
from .syntax import AttachmentRef, CableStmt, JointStmt, VectorLit
from .units import NONE, si_text

def attachment(ref: AttachmentRef, symbols: SymbolTable, reader: AttributeReader
               ) -> tuple[Symbol, Attachment] | None:
    """MEMBER.POINT: the member's symbol and the IR attachment."""
    report = reader.report
    symbol = symbols.get(ref.member.text)
    if symbol is None or symbol.kind not in MEMBER_KINDS:
        members = symbols.names_of_kind(*MEMBER_KINDS)
        what = f"'{ref.member.text}' is {symbol.describe()}, not a member" if symbol \
            else f"unknown member '{ref.member.text}'"
        report.error("E012", what, ref.member.span,
                     hint=did_you_mean(ref.member.text, members)
                     or f"members: {join_names(members)}")
        return None
    points = symbols.points.get(symbol.name, {})
    if ref.point.text not in points:
        report.error("E013", f"{symbol.describe()} has no point '{ref.point.text}'",
                     ref.point.span, hint=did_you_mean(ref.point.text, points)
                     or f"its points: {join_names(points)}")
        return None
    return symbol, Attachment(symbol.member, ref.point.text, ref.span)


def _joint_ends(statement: JointStmt, symbols: SymbolTable, reader: AttributeReader):
    a = attachment(statement.a, symbols, reader)
    b = attachment(statement.b, symbols, reader)
    if a is None or b is None:
        return None
    if a[0].name == b[0].name:
        reader.report.error("E040", f"{statement.kind} '{statement.name.text}' joins "
                            f"{a[0].describe()} to itself", statement.b.span,
                            hint="a joint connects two different members")
        return None
    return a, b


def resolve_hinge(statement: JointStmt, symbols: SymbolTable, reader: AttributeReader
                  ) -> dict | None:
    """The hinge's fields except its initial values; None when it has errors."""
    name = statement.name.text
    owner = f"hinge '{name}'"
    ends = _joint_ends(statement, symbols, reader)
    found = read_block(statement.block, "hinge", owner, statement.name.span, reader.report)
    specs = {spec.name: spec for spec in SPECS["hinge"]}
    fields: dict = {spec: None for spec in specs if spec != "angle"}
    angle = hinge_angle(statement, None, ends, symbols, reader) if ends else None
    for key, item in found.items():  # in written order, so entries follow the file
        if key == "angle":
            angle = hinge_angle(statement, item, ends, symbols, reader) if ends else None
        else:
            fields[key] = reader.scalar(item, specs[key], f"{name}.{key}")
    for key, spec in specs.items():  # attributes with a default get a parameter entry
        if key not in found and spec.default is not None:
            fields[key] = reader.enter(f"{name}.{key}", Num(spec.default), spec.dim,
                                       statement.name.span)
            if fields[key] is not None and spec.limit:
                reader.limits.append(Limit(f"{name}.{key}", fields[key], spec.limit,
                                           si_text(spec.dim), statement.name.span))
    _check_hinge_limits(name, found, fields, reader)
    if ends is None or angle is None or any(fields[k] is None for k in found if k != "angle"):
        return None
    fields.update(name=name, a=ends[0][1], b=ends[1][1], sign=angle[0], offset=angle[1],
                  span=statement.span)
    return fields


def _check_hinge_limits(name: str, found, fields, reader: AttributeReader) -> None:
    for needs_latch in ("latch_stiffness", "latch_damping"):
        if needs_latch in found and "latch" not in found:
            reader.report.error("E028", f"{needs_latch} is given without a latch angle",
                                found[needs_latch].span, hint="add: latch = 90 deg")
    specs = {spec.name: spec for spec in SPECS["hinge"]}
    for key, kind, bound in (("stop_min", "below", "stop_max"),
                             ("static_friction", "at_least", "friction")):
        if fields.get(key) is None or fields.get(bound) is None:
            continue
        later = max(found[key], found[bound], key=lambda item: (item.span.line, item.span.col))
        reader.check_limit(Limit(f"{name}.{key}", fields[key], kind, si_text(specs[key].dim),
                                 later.span, fields[bound], f"{name}.{bound}"))


def resolve_slider(statement: JointStmt, symbols: SymbolTable, reader: AttributeReader
                   ) -> dict | None:
    """The slider's fields except its initial values; None when it has errors."""
    name = statement.name.text
    found = read_block(statement.block, "slider", f"slider '{name}'", statement.name.span,
                       reader.report)
    ends = _joint_ends(statement, symbols, reader)
    axis = None
    item = found.get("axis")
    if item is not None and not isinstance(item.value, VectorLit):
        reader.report.error("E023", "axis takes a direction vector, e.g. axis = (1, 0)",
                            item.value.span)
    elif item is not None:
        axis = read_vector(reader, item.value, NONE, "axis",
                           (f"{name}.axis_x", f"{name}.axis_y"))
        if axis is not None:
            size = binary("+", call("abs", (axis[0],)), call("abs", (axis[1],)))
            if not reader.check_limit(Limit(f"{name}.axis", size, "nonzero", "",
                                            item.value.span)):
                axis = None
    if ends is None or axis is None:
        return None
    return dict(name=name, a=ends[0][1], b=ends[1][1], axis=axis, span=statement.span)


def resolve_cable(statement: CableStmt, symbols: SymbolTable, reader: AttributeReader,
                  hinge_index: dict[str, int]) -> Cable | None:
    name = statement.name.text
    found = read_block(statement.block, "cable", f"cable '{name}'", statement.name.span,
                       reader.report)
    stiffness = None
    if "stiffness" in found:
        spec = next(s for s in SPECS["cable"] if s.name == "stiffness")
        stiffness = reader.scalar(found["stiffness"], spec, f"{name}.stiffness")
    terms = _cable_terms(found["angles"], symbols, reader, hinge_index) \
        if "angles" in found else None
    if stiffness is None or terms is None:
        return None
    return Cable(name, stiffness, tuple(terms), statement.span)


def _cable_terms(item, symbols: SymbolTable, reader: AttributeReader,
                 hinge_index: dict[str, int]) -> list[CableTerm] | None:
    report = reader.report
    example = "a linear combination of hinge angles, like 2*h1 - h2"
    if isinstance(item.value, VectorLit):
        report.error("E023", f"angles takes {example}", item.value.span)
        return None
    try:
        form = linearize(item.value, element_name(symbols))
    except NotLinear as error:
        report.error("E044", f"cable angles must be {example}", error.node.span)
        return None
    for constant in form.constants:
        report.error("E044", f"cable angles must be {example}; a constant term is not "
                     "allowed", constant.node.span)
    ok = _all_hinges(form, symbols, reader) and not form.constants and form.terms
    if not ok:
        if not form.terms and not form.constants:
            report.error("E044", f"cable angles must be {example}", item.value.span)
        return None
    terms = [_coefficient(name, form, reader, hinge_index) for name in form.terms]
    return None if None in terms else terms


def _all_hinges(form: LinearForm, symbols: SymbolTable, reader: AttributeReader) -> bool:
    ok = True
    for name, terms in form.terms.items():
        symbol = symbols.get(name)
        if symbol is not None and symbol.kind == "hinge":
            continue
        ok = False
        span = terms[0].node.span
        if symbol is None:
            hinges = symbols.names_of_kind("hinge")
            reader.report.error("E010", f"unknown name '{name}'", span,
                                hint=did_you_mean(name, hinges) or
                                f"cable angles combine hinges: {join_names(hinges)}")
        else:
            reader.report.error("E043", f"{symbol.describe()} is not a hinge; cable angles "
                                "combine hinge angles", span)
    return ok


def _coefficient(name: str, form: LinearForm, reader: AttributeReader,
                 hinge_index: dict[str, int]) -> CableTerm | None:
    """The hinge's coefficient: the sum of its signed terms, each times its factors."""
    total: Expr | None = None
    for term in form.terms[name]:
        value: Expr = Num(float(term.sign))
        for op, factor in term.factors:
            typed = reader.quantity(factor, NONE, "a cable coefficient")
            if typed is None:
                return None
            value = binary(op, value, typed.expr)
        total = value if total is None else binary("+", total, value)
    assert total is not None
    return CableTerm(hinge_index[name], total)
