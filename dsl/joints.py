"""Connectors and what refers to them: hinges, sliders, welds, free joints, point-to-point
springs, cables.

A joint's IR needs its initial values, which come from `initial` blocks anywhere in the
file, so hinges, sliders and free joints are first read into drafts (dicts of fields) and
completed by `resolve` once every statement has been read.
"""

from __future__ import annotations

from .attributes import SPECS, AttributeReader, read_block
from .errors import did_you_mean, join_names
from .evaluate import binary, call
from .hinge_angle import hinge_angle
from .ir import Attachment, Cable, CableTerm, Expr, Limit, Num, Spring, SpringActs, Weld
from .linear import LinearForm, NotLinear, linearize
from .members import read_vector
from .names import MEMBER_KINDS, Symbol, SymbolTable, element_name
from .syntax import AttachmentRef, CableStmt, JointStmt, NameRef, VectorLit
from .units import ANGLE, NONE, si_text

# Hinge attributes that apply a torque on the hinge angle (or lock it): a particle has no
# angle and takes no torque, so a hinge at one has none of them.
TORQUE_ATTRIBUTES = ("stiffness", "preload", "friction", "static_friction", "damping", "latch",
                     "latch_stiffness", "latch_damping", "stop_min", "stop_max", "release")

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
    axis_ok = True
    for key, item in found.items():  # in written order, so entries follow the file
        if key == "angle":
            angle = hinge_angle(statement, item, ends, symbols, reader) if ends else None
        elif key == "axis":
            fields["axis"] = read_axis(item, name, reader)
            axis_ok = fields["axis"] is not None
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
    if ends is not None and not _torque_free(statement, ends, found, reader):
        return None
    particle = particle_end(ends) if ends is not None else None
    if reader.spatial and particle is not None:
        reader.report.error("E048", f"hinge '{name}' joins {particle.describe()}, which has no "
                            "orientation to carry a hinge axis in a spatial model",
                            statement.span, hint="join the particle by a ball joint (it turns "
                                                 "freely there) or a weld")
        return None
    if reader.spatial and "axis" not in found:
        reader.report.error("E021", f"{owner} of a spatial model is missing the attribute "
                            "'axis'", statement.name.span,
                            hint="add: axis = (0, 0, 1), the axis's direction in the frame of "
                                 f"{statement.a.member.text}")
        return None
    if ends is None or angle is None or not axis_ok \
            or any(fields[k] is None for k in found if k not in ("angle", "axis")):
        return None
    fields.update(name=name, a=ends[0][1], b=ends[1][1], sign=angle[0], offset=angle[1],
                  span=statement.span)
    return fields


def read_axis(item, name: str, reader: AttributeReader, attribute: str = "axis"
              ) -> tuple[Expr, ...] | None:
    """A spatial joint's axis (`attribute`): a direction vector (any length but zero), as
    the entries NAME.ATTRIBUTE_x, _y, _z; None after an error (E060 in a planar model, whose
    hinges all turn about z)."""
    if not reader.spatial:
        reader.report.error("E060", "a hinge of a planar model turns about z: it takes no axis",
                            item.name.span, hint="declare the model spatial (`model NAME "
                                                 "spatial`) for hinges about other axes")
        return None
    if not isinstance(item.value, VectorLit):
        reader.report.error("E023", f"{attribute} takes a direction vector, e.g. {attribute} "
                            "= (0, 0, 1)", item.value.span)
        return None
    axis = read_vector(reader, item.value, NONE, attribute,
                       tuple(f"{name}.{attribute}_{k}" for k in "xyz"))
    if axis is None:
        return None
    size = binary("+", binary("+", call("abs", (axis[0],)), call("abs", (axis[1],))),
                  call("abs", (axis[2],)))
    if not reader.check_limit(Limit(f"{name}.{attribute}", size, "nonzero", "",
                                    item.value.span)):
        return None
    return axis


def particle_end(ends) -> Symbol | None:
    """The symbol of a particle among a connector's two ends, or None."""
    return next((symbol for symbol, _ in ends if symbol.kind == "particle"), None)


def _torque_free(statement: JointStmt, ends, found, reader: AttributeReader) -> bool:
    """E048 for each torque attribute of a hinge at a particle (it has no angle)."""
    particle = particle_end(ends)
    if particle is None:
        return True
    for key in TORQUE_ATTRIBUTES:
        if key in found:
            reader.report.error("E048", f"hinge '{statement.name.text}' joins "
                                f"{particle.describe()}, which has no angle: the hinge "
                                f"carries no torque, so it cannot have '{key}'",
                                found[key].name.span,
                                hint="join a body (with an inertia) to give the hinge a "
                                     "spring, friction, a latch or stops")
    return not any(key in found for key in TORQUE_ATTRIBUTES)


def _check_hinge_limits(name: str, found, fields, reader: AttributeReader,
                        kind: str = "hinge") -> None:
    """E028: a latch's stiffness or damping without the latch, stops out of order, static
    friction below the kinetic (a hinge's or, kind "slider", a slider's)."""
    what, example = ("angle", "90 deg") if kind == "hinge" else ("position", "0.5 m")
    for needs_latch in ("latch_stiffness", "latch_damping"):
        if needs_latch in found and "latch" not in found:
            reader.report.error("E028", f"{needs_latch} is given without a latch {what}",
                                found[needs_latch].span, hint=f"add: latch = {example}")
    specs = {spec.name: spec for spec in SPECS[kind]}
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
    axis = _slider_axis(found.get("axis"), name, reader)
    toolkit = _slider_toolkit(statement, found, reader)
    if ends is not None and ends[0][0].kind == "particle":
        reader.report.error("E048", f"slider '{name}': {ends[0][0].describe()} has no angle, "
                            "so it cannot carry the slider's axis", statement.a.span,
                            hint="join the particle second: `joins RAIL.POINT to "
                                 f"{ends[0][0].name}.cm`")
        return None
    if ends is None or axis is None or toolkit is None:
        return None
    return dict(name=name, a=ends[0][1], b=ends[1][1], axis=axis, span=statement.span,
                **toolkit)


def _slider_toolkit(statement: JointStmt, found, reader: AttributeReader) -> dict | None:
    """A slider's springs, friction, latch, stops and hold-down along its axis (SPECS), by
    attribute name, absent ones None; its slip_rate has an entry (its default) only when it
    has friction. None when one has an error (reported)."""
    name = statement.name.text
    specs = {spec.name: spec for spec in SPECS["slider"] if spec.name != "axis"}
    fields: dict = dict.fromkeys(specs)
    for key, item in found.items():  # in written order, so entries follow the file
        if key in specs:
            fields[key] = reader.scalar(item, specs[key], f"{name}.{key}")
    spec = specs["slip_rate"]
    if "slip_rate" not in found and ({"friction", "static_friction"} & found.keys()):
        fields["slip_rate"] = reader.enter(f"{name}.slip_rate", Num(spec.default), spec.dim,
                                           statement.name.span)
        if fields["slip_rate"] is not None:
            reader.limits.append(Limit(f"{name}.slip_rate", fields["slip_rate"], spec.limit,
                                       si_text(spec.dim), statement.name.span))
    _check_hinge_limits(name, found, fields, reader, "slider")
    if any(fields[key] is None for key in found if key in specs):
        return None
    return fields


def _slider_axis(item, name: str, reader: AttributeReader) -> tuple[Expr, ...] | None:
    """A slider's axis: a direction vector (any length but zero); None after an error."""
    axis = None
    if item is not None and not isinstance(item.value, VectorLit):
        reader.report.error("E023", "axis takes a direction vector, e.g. axis = (1, 0)",
                            item.value.span)
    elif item is not None:
        axis = read_vector(reader, item.value, NONE, "axis",
                           (f"{name}.axis_x", f"{name}.axis_y", f"{name}.axis_z"))
        if axis is not None:
            size = call("abs", (axis[0],))
            for component in axis[1:]:
                size = binary("+", size, call("abs", (component,)))
            if not reader.check_limit(Limit(f"{name}.axis", size, "nonzero", "",
                                            item.value.span)):
                axis = None
    return axis


def resolve_weld(statement: JointStmt, symbols: SymbolTable, reader: AttributeReader
                 ) -> Weld | None:
    """A weld: its points held together and, between members with angles, its relative
    angle (attribute `angle`, default 0); None when it has errors."""
    name = statement.name.text
    found = read_block(statement.block, "weld", f"weld '{name}'", statement.name.span,
                       reader.report)
    ends = _joint_ends(statement, symbols, reader)
    angle: Expr | None = Num(0.0)
    particle = particle_end(ends) if ends else None
    if "angle" in found and reader.spatial:
        reader.report.error("E060", f"weld '{name}' of a spatial model holds its members as "
                            "their orientations place them: it takes no angle",
                            found["angle"].name.span,
                            hint="give the members' `orientation` instead")
        return None
    if "angle" in found:
        if particle is not None:
            reader.report.error("E048", f"weld '{name}' joins {particle.describe()}, which "
                                "has no angle: the weld holds the points together only",
                                found["angle"].name.span, hint="remove the angle")
            return None
        spec = next(s for s in SPECS["weld"] if s.name == "angle")
        angle = reader.scalar(found["angle"], spec, f"{name}.angle")
    if ends is None or angle is None:
        return None
    return Weld(name, ends[0][1], ends[1][1], angle, particle is None, statement.span)


def resolve_free(statement: JointStmt, symbols: SymbolTable, reader: AttributeReader
                 ) -> dict | None:
    """A free joint's fields except its initial values; None when it has errors."""
    name = statement.name.text
    read_block(statement.block, "free", f"free joint '{name}'", statement.name.span,
               reader.report)
    ends = _joint_ends(statement, symbols, reader)
    if ends is None:
        return None
    return dict(name=name, a=ends[0][1], b=ends[1][1], turns=particle_end(ends) is None,
                span=statement.span)


def resolve_ball(statement: JointStmt, symbols: SymbolTable, reader: AttributeReader
                 ) -> dict | None:
    """A ball joint's fields except its initial values; None when it has errors."""
    name = statement.name.text
    read_block(statement.block, "ball", f"ball joint '{name}'", statement.name.span,
               reader.report)
    if not reader.spatial:
        reader.report.error("E060", "a ball joint needs a spatial model: in a plane it is a "
                            "hinge", statement.span, hint="use a hinge, or declare the model "
                                                          "spatial (`model NAME spatial`)")
        return None
    ends = _joint_ends(statement, symbols, reader)
    if ends is None:
        return None
    return dict(name=name, a=ends[0][1], b=ends[1][1], span=statement.span)


def resolve_cylindrical(statement: JointStmt, symbols: SymbolTable, reader: AttributeReader
                        ) -> dict | None:
    """A cylindrical joint's fields except its initial values; None when it has errors."""
    return _axial_joint(statement, symbols, reader, ("axis",))


def resolve_universal(statement: JointStmt, symbols: SymbolTable, reader: AttributeReader
                      ) -> dict | None:
    """A universal joint's fields except its initial values (the axes' being normal where
    the members' orientations place them is checked once the members are known:
    dsl/resolve.py); None when it has errors."""
    return _axial_joint(statement, symbols, reader, ("axis_a", "axis_b"))


def _axial_joint(statement: JointStmt, symbols: SymbolTable, reader: AttributeReader,
                 axes: tuple[str, ...]) -> dict | None:
    """The fields of a spatial joint between two bodies defined by its axes."""
    name = statement.name.text
    kind = statement.kind
    word = "a cylindrical joint" if kind == "cylindrical" else "a universal joint"
    if not reader.spatial:
        reader.report.error("E060", f"{word} needs a spatial model", statement.span,
                            hint="declare the model spatial (`model NAME spatial`); in a plane "
                                 "use a hinge or a slider")
        return None
    found = read_block(statement.block, kind, f"{word.removeprefix('a ')} '{name}'",
                       statement.name.span, reader.report)
    ends = _joint_ends(statement, symbols, reader)
    fields = {axis: read_axis(found[axis], name, reader, axis) if axis in found else None
              for axis in axes}
    particle = particle_end(ends) if ends is not None else None
    if particle is not None:
        reader.report.error("E048", f"{word.removeprefix('a ')} '{name}' joins "
                            f"{particle.describe()}, which has no orientation to carry its "
                            "axis", statement.span,
                            hint="join the particle by a ball joint or a slider")
        return None
    if ends is None or None in fields.values():
        return None
    return dict(name=name, a=ends[0][1], b=ends[1][1], span=statement.span, **fields)


def resolve_spring(statement: JointStmt, symbols: SymbolTable, reader: AttributeReader
                   ) -> Spring | None:
    """A point-to-point spring-damper; None when it has errors (all reported)."""
    name = statement.name.text
    owner = f"spring '{name}'"
    found = read_block(statement.block, "spring", owner, statement.name.span, reader.report)
    ends = _joint_ends(statement, symbols, reader)
    specs = {spec.name: spec for spec in SPECS["spring"]}
    values: dict[str, Expr | None] = {}
    for key, item in found.items():  # in written order, so entries follow the file
        if key != "acts":
            values[key] = reader.scalar(item, specs[key], f"{name}.{key}")
    acts = _acts(found.get("acts"), reader)
    if not ({"stiffness", "preload", "damping"} & found.keys()):
        reader.report.error("E021", f"{owner} has no force: give it a stiffness, a preload "
                            "or a damping", statement.name.span,
                            hint="add: stiffness = 100 N/m; free_length = 0.1 m")
        return None
    if "free_length" not in found and ("stiffness" in found or "acts" in found):
        why = "a stiffness" if "stiffness" in found else "a one-sided range"
        reader.report.error("E021", f"{owner} has {why} but no free_length", statement.name.span,
                            hint="add: free_length = 0.1 m")
        return None
    if ends is None or acts is None or None in values.values():
        return None
    return Spring(name, ends[0][1], ends[1][1], values.get("stiffness"),
                  values.get("free_length"), values.get("preload"), values.get("damping"), acts,
                  statement.span)


def _acts(item, reader: AttributeReader) -> SpringActs | None:
    """`acts = push` or `acts = pull` (both ways without it); None after E029."""
    if item is None:
        return SpringActs.BOTH
    value = item.value
    word = value.parts[0].text if isinstance(value, NameRef) and len(value.parts) == 1 \
        else None
    choices = {acts.value: acts for acts in SpringActs}
    if word in choices:
        return choices[word]
    reader.report.error("E029", "acts takes one of the words push, pull or both",
                        value.span, hint="push: a kick-off spring (pushes until its free "
                        "length); pull: a cable (pulls while taut)")
    return None


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
