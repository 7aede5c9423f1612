"""Members and vectors: gravity, the ground's points, bars, bodies, beams and particles."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from .attributes import SPECS, AttributeReader, read_block
from .errors import Reporter, join_names
from .evaluate import Typed, binary
from .expressions import Context
from .ir import Beam, Body, Dim, Expr, Ground, Model, Num, Particle, Point, Span
from .syntax import (AttributeItem, GravityStmt, GroundStmt, MemberStmt, NumberLit, PointItem,
                     VectorLit)
from .units import LENGTH, dim_mul, parse_unit

# Beam elements drive the size of the symbolic system: derivation takes about a minute at
# 2 x 128 elements and grows faster than the square of the count.
MAX_ELEMENTS = 100  # per beam
MAX_TOTAL_ELEMENTS = 200  # all beams of a model together


def read_vector(reader: AttributeReader, vector: VectorLit, dim: Dim, what: str,
                entries: tuple[str, str]) -> tuple[Expr, Expr] | None:
    """Both components of `(x, y) UNIT` in SI, as parameter entries `entries`."""
    factor, unit_dim = parse_unit(vector.unit) if vector.unit else (1.0, Dim())
    result = []
    for component, entry, axis in zip((vector.x, vector.y), entries, "xy"):
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
    return result[0], result[1]


def resolve_gravity(statement: GravityStmt, reader: AttributeReader) -> tuple[Expr, Expr] | None:
    return read_vector(reader, statement.value, Dim(length=1, time=-2), "gravity",
                       ("gravity.x", "gravity.y"))


def resolve_points(reader: AttributeReader, owner: str, items,
                   builtin: tuple[str, ...] = ()) -> list[Point]:
    """Declared points of a member (duplicates were reported with the symbol table)."""
    points, seen = [], set(builtin)
    for item in items:
        if not isinstance(item, PointItem) or item.name.text in seen:
            continue
        seen.add(item.name.text)
        name = item.name.text
        xy = read_vector(reader, item.value, LENGTH, f"point '{name}'",
                         (f"{owner}.{name}.local_x", f"{owner}.{name}.local_y"))
        if xy is not None:
            points.append(Point(name, xy[0], xy[1], item.span))
    return points


def resolve_ground(statement: GroundStmt | None, reader: AttributeReader,
                   filename: str) -> Ground:
    """The ground's points: `origin` at (0, 0), then the declared ones."""
    span = statement.span if statement else Span(filename, 1, 1, 1, 1)
    points = [Point("origin", Num(0.0), Num(0.0), span)]
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
        if specs[key].dim is not None:
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
    required = [s.name for s in SPECS[statement.kind] if s.required]
    if any(values.get(r) is None for r in required):
        return None
    length = values.get("length")
    if length is not None:  # a bar: ends a and b at -L/2 and +L/2 on its x axis
        ends = [Point("a", binary("*", Num(-0.5), length), Num(0.0), statement.name.span),
                Point("b", binary("*", Num(0.5), length), Num(0.0), statement.name.span)]
        points = ends + points
    return Body(name, statement.kind, values["mass"], values["inertia"], length,
                tuple(points), statement.span)


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
