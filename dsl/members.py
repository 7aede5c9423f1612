"""Members and vectors: gravity, the ground's points, bars, bodies, beams and particles."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from .attributes import SPECS, AttributeReader, read_block
from .errors import Reporter, join_names
from .evaluate import Typed, binary, call, negate
from .expressions import Context
from .ir import Beam, Body, Dim, Expr, Ground, Limit, Model, Num, Particle, Point, Span, Turn
from .syntax import (AttributeItem, BinaryOp, CallExpr, GravityStmt, GroundStmt, MemberStmt,
                     NumberLit, PointItem, VectorLit)
from .units import ANGLE, LENGTH, dim_mul, parse_unit

# Beam elements drive the size of the symbolic system: derivation takes about a minute at
# 2 x 128 elements and grows faster than the square of the count.
MAX_ELEMENTS = 100  # per beam
MAX_TOTAL_ELEMENTS = 200  # all beams of a model together


def read_vector(reader: AttributeReader, vector: VectorLit, dim: Dim, what: str,
                entries: tuple[str, ...]) -> tuple[Expr, ...] | None:
    """The components of `(x, y) UNIT` (`(x, y, z)` in a spatial model) in SI, as parameter
    entries `entries` (one name per axis x, y, z; the first two in a planar model)."""
    components = vector.components
    if len(components) != (3 if reader.spatial else 2):
        reader.report.error("E023", f"{what} of a spatial model has three components "
                            "(x, y, z)", vector.span, hint="e.g. (0, 0, -9.81)")
        return None
    factor, unit_dim = parse_unit(vector.unit) if vector.unit else (1.0, Dim())
    result = []
    for component, entry, axis in zip(components, entries, "xyz"):
        typed = reader.resolver.resolve(component, Context.CONSTANT)
        if typed is None:
            result.append(None)
            continue
        typed = Typed(binary("*", typed.expr, Num(factor)), dim_mul(typed.dim, unit_dim))
        if not reader.expect(typed, dim, f"{what} ({axis})", component):
            result.append(None)
            continue
        result.append(reader.enter(entry, typed.expr, dim, component.span))
    if None in result:
        return None
    return tuple(result)


def resolve_gravity(statement: GravityStmt, reader: AttributeReader) -> tuple[Expr, ...] | None:
    return read_vector(reader, statement.value, Dim(length=1, time=-2), "gravity",
                       ("gravity.x", "gravity.y", "gravity.z"))


def resolve_points(reader: AttributeReader, owner: str, items,
                   builtin: tuple[str, ...] = ()) -> list[Point]:
    """Declared points of a member (duplicates were reported with the symbol table)."""
    points, seen = [], set(builtin)
    for item in items:
        if not isinstance(item, PointItem) or item.name.text in seen:
            continue
        seen.add(item.name.text)
        name = item.name.text
        xyz = read_vector(reader, item.value, LENGTH, f"point '{name}'",
                          tuple(f"{owner}.{name}.local_{axis}" for axis in "xyz"))
        if xyz is not None:
            points.append(Point(name, xyz[0], xyz[1], item.span, *xyz[2:]))
    return points


def resolve_ground(statement: GroundStmt | None, reader: AttributeReader,
                   filename: str) -> Ground:
    """The ground's points: `origin` at (0, 0), then the declared ones."""
    span = statement.span if statement else Span(filename, 1, 1, 1, 1)
    points = [Point("origin", Num(0.0), Num(0.0), span)]  # z = 0
    if statement is not None:
        read_block(statement.block, "ground", "the ground", statement.span, reader.report)
        points += resolve_points(reader, "ground", statement.block.items, ("origin",))
    return Ground(tuple(points))


def _scalars(statement: MemberStmt, reader: AttributeReader,
             found: dict[str, AttributeItem]) -> dict[str, Expr | None]:
    name = statement.name.text
    specs = {spec.name: spec for spec in SPECS[statement.kind]}
    values: dict[str, Expr | None] = {}
    for key, item in found.items():  # in written order, so entries follow the file
        if specs[key].dim is not None and not (reader.spatial and key == "inertia"):
            values[key] = reader.scalar(item, specs[key], f"{name}.{key}")
    return values


def resolve_member(statement: MemberStmt, reader: AttributeReader
                   ) -> Body | Beam | Particle | None:
    """A bar, body, beam or particle; None when it has errors (all reported)."""
    name = statement.name.text
    owner = f"{statement.kind} '{name}'"
    found = read_block(statement.block, statement.kind, owner, statement.name.span,
                       reader.report)
    values = _scalars(statement, reader, found)
    if statement.kind == "beam":
        elements = _elements(found.get("elements"), owner, reader)
        return _beam(statement, values, elements)
    if statement.kind == "particle":
        mass = values.get("mass")
        return None if mass is None else Particle(name, mass, statement.span)
    builtin = ("a", "b") if statement.kind == "bar" else ()
    points = resolve_points(reader, name, statement.block.items, builtin)
    spatial = read_spatial_body(statement, found, reader) if reader.spatial \
        else _planar_only(statement, found, reader)
    required = [s.name for s in SPECS[statement.kind] if s.required and s.dim is not None]
    if spatial is None or any(values.get(r) is None for r in required if r != "inertia"):
        return None
    if not reader.spatial and values.get("inertia") is None:
        return None
    length = values.get("length")
    if length is not None:  # a bar: ends a and b at -L/2 and +L/2 on its x axis
        ends = [Point("a", binary("*", Num(-0.5), length), Num(0.0), statement.name.span),
                Point("b", binary("*", Num(0.5), length), Num(0.0), statement.name.span)]
        points = ends + points
    return Body(name, statement.kind, values["mass"], values.get("inertia"), length,
                tuple(points), statement.span, **spatial)


def _planar_only(statement: MemberStmt, found: dict[str, AttributeItem],
                 reader: AttributeReader) -> dict | None:
    """{} for a planar body; None after E060 for an attribute of spatial models."""
    for key in SPATIAL_ATTRIBUTES:
        if key in found:
            reader.report.error("E060", f"'{key}' is an attribute of bodies in spatial models",
                                found[key].name.span,
                                hint="declare the model spatial (`model NAME spatial`) for "
                                     "3-D bodies; a planar body turns in the x-y plane only")
    return None if any(key in found for key in SPATIAL_ATTRIBUTES) else {}


SPATIAL_ATTRIBUTES = ("orientation", "principal_axes", "products_of_inertia")
_TURNS = {"rx": "x", "ry": "y", "rz": "z"}


def read_spatial_body(statement: MemberStmt, found: dict[str, AttributeItem],
                      reader: AttributeReader) -> dict | None:
    """A spatial body's moments (`inertia = (Ixx, Iyy, Izz) kg*m^2`, checked to be those of
    a body: positive, each smaller than the sum of the other two), either `principal_axes`
    (a product of turns: the moments are principal) or `products_of_inertia = (Pxy, Pyz,
    Pzx) kg*m^2` (the moments are about the body's axes; the tensor checked positive
    definite with its second moments, `_check_products`), and `orientation`; None when they
    have errors (reported)."""
    name = statement.name.text
    item = found.get("inertia")
    if item is None:
        return None  # reported as missing
    if not isinstance(item.value, VectorLit):
        reader.report.error("E023", f"inertia of a spatial body is its three principal "
                            "moments about the centre of mass, (Ixx, Iyy, Izz)", item.value.span,
                            hint="e.g. inertia = (0.2, 0.3, 0.4) kg*m^2 (along the body's axes, "
                                 "or along principal_axes)")
        return None
    moments = read_vector(reader, item.value, Dim(mass=1, length=2), "inertia",
                          tuple(f"{name}.inertia_{axis}" for axis in "xyz"))
    if moments is None:
        return None
    ok = True
    for k, axis in enumerate("xyz"):
        others = binary("+", moments[(k + 1) % 3], moments[(k + 2) % 3])
        ok &= reader.check_limit(Limit(f"{name}.inertia_{axis}", moments[k], "below", "kg*m^2",
                                       item.value.span, others,
                                       f"the sum of the other two principal moments of "
                                       f"'{name}'"))
        ok &= reader.check_limit(Limit(f"{name}.inertia_{axis}", moments[k], "positive",
                                       "kg*m^2", item.value.span))
    axes = read_turns(found.get("principal_axes"), f"{name}.principal_axes", reader)
    orientation = read_turns(found.get("orientation"), f"{name}.orientation", reader)
    products = _read_products(found.get("products_of_inertia"), name, reader)
    if "products_of_inertia" in found and "principal_axes" in found:
        reader.report.error("E028", f"'{name}' has both principal_axes and "
                            "products_of_inertia: its moments are either principal (along "
                            "principal_axes) or about the body's axes (with their products)",
                            found["products_of_inertia"].name.span,
                            hint="give one of the two")
        return None
    if not ok or axes is None or orientation is None or products is False:
        return None
    if products is not None and not _check_products(moments, products, name,
                                                     found["products_of_inertia"], reader):
        return None
    return dict(principal=moments, principal_axes=axes, orientation=orientation,
                products=products)


def _read_products(item: AttributeItem | None, name: str, reader: AttributeReader):
    """`products_of_inertia = (Pxy, Pyz, Pzx) kg*m^2`; None when not given, False after an
    error."""
    if item is None:
        return None
    if not isinstance(item.value, VectorLit):
        reader.report.error("E023", "products_of_inertia takes three values (Pxy, Pyz, Pzx), "
                            "the integrals of x y, y z and z x dm about the centre of mass",
                            item.value.span, hint="e.g. products_of_inertia = (0.01, 0, 0) "
                                                  "kg*m^2")
        return False
    products = read_vector(reader, item.value, Dim(mass=1, length=2), "products_of_inertia",
                           tuple(f"{name}.products_of_inertia_{pair}"
                                 for pair in ("xy", "yz", "zx")))
    return False if products is None else products


def _check_products(moments, products, name: str, item: AttributeItem,
                    reader: AttributeReader) -> bool:
    """The body's second moments J = tr(I)/2 - I (its mass's spread, integral of rho rho^T
    dm) positive definite, by Sylvester's criterion: J's diagonal (the triangle inequality,
    checked with the moments) and its leading minors of order 2 and 3 positive. A positive
    definite J makes the inertia tensor positive definite too."""
    half = [binary("*", Num(0.5), binary("-", binary("+", moments[(k + 1) % 3],
                                                     moments[(k + 2) % 3]), moments[k]))
            for k in range(3)]
    pxy, pyz, pzx = products
    minor = binary("-", binary("*", half[0], half[1]), binary("*", pxy, pxy))
    # det J = Jxx Jyy Jzz + 2 Pxy Pyz Pzx - Jxx Pyz^2 - Jyy Pzx^2 - Jzz Pxy^2
    terms = [binary("*", binary("*", half[0], half[1]), half[2]),
             binary("*", Num(2.0), binary("*", binary("*", pxy, pyz), pzx))]
    negative = [binary("*", half[0], binary("*", pyz, pyz)),
                binary("*", half[1], binary("*", pzx, pzx)),
                binary("*", half[2], binary("*", pxy, pxy))]
    determinant = binary("+", terms[0], terms[1])
    for term in negative:
        determinant = binary("-", determinant, term)
    what = (f"the products of inertia of '{name}' are too large for its moments: the "
            "determinant of its second moments")
    return reader.check_limit(Limit(f"{what} about x and y", minor, "positive", "kg^2*m^4",
                                    item.value.span)) \
        and reader.check_limit(Limit(what, determinant, "positive", "kg^3*m^6",
                                     item.value.span))


def turns_matrix(turns: tuple[Turn, ...]) -> list[list[Expr]]:
    """The rotation matrix of an orientation (R = R_1 R_2 ..., ir.Turn) as expressions."""
    matrix: list[list[Expr]] = [[Num(float(i == j)) for j in range(3)] for i in range(3)]
    for factor in turns:
        k = "xyz".index(factor.axis)
        i, j = (k + 1) % 3, (k + 2) % 3
        c, s = call("cos", (factor.angle,)), call("sin", (factor.angle,))
        step: list[list[Expr]] = [[Num(float(r == q)) for q in range(3)] for r in range(3)]
        step[i][i], step[i][j], step[j][i], step[j][j] = c, negate(s), s, c
        matrix = [[_sum(binary("*", matrix[r][m], step[m][q]) for m in range(3)
                        if step[m][q] != Num(0.0) and matrix[r][m] != Num(0.0))
                   for q in range(3)] for r in range(3)]
    return matrix


def normal_cosine(axis_a: tuple[Expr, ...], turns_a: tuple[Turn, ...],
                  axis_b: tuple[Expr, ...], turns_b: tuple[Turn, ...]) -> Expr:
    """The cosine of the angle between axis_a (in a frame oriented by turns_a) and axis_b (in
    one oriented by turns_b), both in the world: (O_a a) . (O_b b) / (|a| |b|)."""
    world = []
    for axis, turns in ((axis_a, turns_a), (axis_b, turns_b)):
        matrix = turns_matrix(turns)
        world.append([_sum(binary("*", matrix[r][m], axis[m]) for m in range(3)
                           if matrix[r][m] != Num(0.0)) for r in range(3)])
    dot = _sum(binary("*", u, v) for u, v in zip(*world))
    norms = [call("sqrt", (_sum(binary("*", c, c) for c in axis),)) for axis in (axis_a, axis_b)]
    return binary("/", dot, binary("*", norms[0], norms[1]))


def _sum(terms) -> Expr:
    total: Expr = Num(0.0)
    for term in terms:
        total = binary("+", total, term)
    return total


def read_turns(item: AttributeItem | None, entry: str, reader: AttributeReader
               ) -> tuple[Turn, ...] | None:
    """`rz(30 deg) * rx(10 deg)`: turns about the named axes of the frame reached so far, in
    the order written (R = Rz Rx); () when not given; None after E061."""
    if item is None:
        return ()
    factors, node = [], item.value
    while isinstance(node, BinaryOp) and node.op == "*":
        factors.insert(0, node.right)
        node = node.left
    factors.insert(0, node)
    turns = []
    for k, factor in enumerate(factors):
        if not (isinstance(factor, CallExpr) and factor.func.text in _TURNS
                and len(factor.args) == 1):
            reader.report.error("E061", "an orientation is a product of turns about named "
                                "axes: rx(angle), ry(angle), rz(angle)", factor.span,
                                hint="e.g. orientation = rz(30 deg) * rx(-10 deg): 30 deg "
                                     "about z, then -10 deg about the turned x")
            return None
        typed = reader.quantity(factor.args[0], ANGLE, f"the angle of {factor.func.text}")
        if typed is None:
            return None
        angle = reader.enter(f"{entry}_{k + 1}", typed.expr, ANGLE, factor.args[0].span)
        if angle is None:
            return None
        turns.append(Turn(_TURNS[factor.func.text], angle))
    return tuple(turns)


def _beam(statement: MemberStmt, values: dict[str, Expr | None],
          elements: int | None) -> Beam | None:
    required = ("length", "EI", "EA", "mass_per_length")
    if elements is None or any(values.get(r) is None for r in required):
        return None
    return Beam(statement.name.text, values["length"], values["EI"], values["EA"],
                values["mass_per_length"], elements, values.get("damping"), statement.span)


def _elements(item: AttributeItem | None, owner: str, reader: AttributeReader) -> int | None:
    """The element count: a plain whole number from 1 to MAX_ELEMENTS."""
    if item is None:
        return None
    value = item.value
    if isinstance(value, NumberLit) and _is_count(value.text):
        return int(value.text)
    reader.report.error("E024", f"elements of {owner} must be a whole number from 1 to "
                        f"{MAX_ELEMENTS}, written as a plain number", value.span,
                        hint="e.g. elements = 4 (parameters and units are not allowed here)")
    return None


def _is_count(text: str) -> bool:
    """ASCII digits naming a whole number from 1 to MAX_ELEMENTS."""
    return text.isascii() and text.isdigit() \
        and len(text.lstrip("0")) <= len(str(MAX_ELEMENTS)) and 1 <= int(text) <= MAX_ELEMENTS


def check_element_total(beams: list[Beam], report: Reporter) -> None:
    """E024 at the beam whose elements take the model past MAX_TOTAL_ELEMENTS."""
    total = 0
    for beam in beams:
        total += beam.elements
        if total > MAX_TOTAL_ELEMENTS:
            report.error("E024", f"the beams up to {beam.name} have {total} elements in all; "
                         f"a model has at most {MAX_TOTAL_ELEMENTS}", beam.span,
                         hint="use fewer elements per beam")
            return


def with_elements(model: Model, counts: Mapping[str, int | str]) -> Model:
    """`model` with other element counts for the beams named in `counts` (beam name -> a
    count: an int, or text of ASCII digits, e.g. from `--elements link1=8`). Each count is a
    whole number from 1 to MAX_ELEMENTS, and all beams together have at most
    MAX_TOTAL_ELEMENTS. Raises ValueError saying what is wrong."""
    beams = {beam.name: beam for beam in model.beams}
    for name, count in counts.items():
        if name not in beams:
            raise ValueError(f"unknown beam '{name}' (beams in this model: "
                             f"{join_names(beams)})")
        text = str(count) if isinstance(count, int) and not isinstance(count, bool) else count
        if not isinstance(text, str) or not _is_count(text.strip()):
            raise ValueError(f"the element count of beam '{name}' must be a whole number "
                             f"from 1 to {MAX_ELEMENTS} (ASCII digits), got {count!r}")
    new = tuple(dataclasses.replace(b, elements=int(str(counts[b.name]).strip()))
                if b.name in counts else b for b in model.beams)
    total = sum(beam.elements for beam in new)
    if total > MAX_TOTAL_ELEMENTS:
        raise ValueError(f"the beams would have {total} elements in all; a model has at most "
                         f"{MAX_TOTAL_ELEMENTS}")
    return dataclasses.replace(model, beams=new)
