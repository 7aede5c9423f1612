"""Dotted names in expressions: state quantities such as `h1.rate`, `rod.phi`, `rod.b.x`,
`link2.chord`. They are allowed only in outputs."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .errors import did_you_mean, join_names
from .evaluate import Typed
from .ir import BeamQuantity, BodyCoord, Dim, HingeAngle, PointCoord, SliderPosition
from .syntax import Ident, NameRef
from .units import ANGLE, LENGTH

if TYPE_CHECKING:
    from .expressions import ExprResolver

VELOCITY = Dim(length=1, time=-1)
BODY_COORDS = {"x": LENGTH, "y": LENGTH, "phi": ANGLE, "vx": VELOCITY, "vy": VELOCITY,
               "omega": Dim(angle=1, time=-1)}
POINT_AXES = {"x": LENGTH, "y": LENGTH, "vx": VELOCITY, "vy": VELOCITY}
BEAM_QUANTITIES = {"chord": ANGLE, "tip_deflection": LENGTH}
JOINT_RATES = {"hinge": Dim(angle=1, time=-1), "slider": VELOCITY}


def resolve_dotted(resolver: ExprResolver, node: NameRef, in_output: bool) -> Typed | None:
    """A dotted name: a state quantity in outputs, an error anywhere else."""
    report = resolver.report
    head = node.parts[0]
    symbol = resolver.symbols.get(head.text)
    if symbol is None:
        names = list(resolver.symbols.symbols)
        report.error("E010", f"unknown name '{head.text}'", head.span,
                     hint=did_you_mean(head.text, names))
        return None
    if symbol.kind in ("param", "cable", "output"):
        report.error("E019", f"{symbol.describe()} has no properties", node.span)
        return None
    if not in_output:
        report.error("E018", f"'{node.dotted}' is a state quantity; it can be used only in "
                     "outputs", node.span)
        return None
    if symbol.kind in ("hinge", "slider"):
        return _joint_rate(resolver, symbol, node)
    if len(node.parts) == 2:
        return _member_quantity(resolver, symbol, node.parts[1], node)
    if len(node.parts) == 3:
        return _point_coordinate(resolver, symbol, node.parts[1], node.parts[2])
    report.error("E019", f"'{node.dotted}' has too many parts", node.span,
                 hint="a point coordinate is MEMBER.POINT.x, e.g. rod.b.x")
    return None


def _joint_rate(resolver, symbol, node: NameRef):
    prop = node.parts[1]
    if len(node.parts) == 2 and prop.text == "rate":
        expr = HingeAngle(symbol.index, True) if symbol.kind == "hinge" \
            else SliderPosition(symbol.index, True)
        return Typed(expr, JOINT_RATES[symbol.kind])
    resolver.report.error("E019", f"{symbol.describe()} has no property "
                          f"'{'.'.join(p.text for p in node.parts[1:])}'", prop.span,
                          hint=f"its only property is '{symbol.name}.rate'")
    return None


def _member_quantity(resolver, symbol, prop: Ident, node: NameRef):
    points = resolver.symbols.points.get(symbol.name, {})
    if symbol.kind in ("bar", "body") and prop.text in BODY_COORDS:
        return Typed(BodyCoord(symbol.index, prop.text), BODY_COORDS[prop.text])
    if symbol.kind == "beam" and prop.text in BEAM_QUANTITIES:
        return Typed(BeamQuantity(symbol.index, prop.text), BEAM_QUANTITIES[prop.text])
    if prop.text in points:
        resolver.report.error("E019", f"'{node.dotted}' is a point, not a number", node.span,
                              hint=f"write {node.dotted}.x, .y, .vx or .vy")
        return None
    known = _properties(symbol.kind) + list(points)
    resolver.report.error("E019", f"{symbol.describe()} has no property '{prop.text}'",
                          prop.span, hint=did_you_mean(prop.text, known)
                          or f"its properties: {join_names(known)}")
    return None


def _properties(kind: str) -> list[str]:
    if kind in ("bar", "body"):
        return list(BODY_COORDS)
    return list(BEAM_QUANTITIES) if kind == "beam" else []


def _point_coordinate(resolver, symbol, point: Ident, axis: Ident):
    points = resolver.symbols.points.get(symbol.name, {})
    if point.text not in points:
        resolver.report.error("E013", f"{symbol.describe()} has no point '{point.text}'",
                              point.span, hint=did_you_mean(point.text, points)
                              or f"its points: {join_names(points)}")
        return None
    if axis.text not in POINT_AXES:
        resolver.report.error("E019", f"a point has no property '{axis.text}'", axis.span,
                              hint=did_you_mean(axis.text, POINT_AXES)
                              or "a point has x, y, vx and vy")
        return None
    return Typed(PointCoord(symbol.member, point.text, axis.text), POINT_AXES[axis.text])
