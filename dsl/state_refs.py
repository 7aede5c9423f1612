"""Dotted names in expressions: state quantities such as `h1.rate`, `rod.phi`, `rod.b.x`,
`link2.chord`, loads such as `h1.force_x`, `kick.force`, and the system's quantities such as
`system.momentum_x`. They are allowed only in outputs."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .errors import did_you_mean, join_names
from .evaluate import Typed
from .ir import (BeamQuantity, BodyCoord, Dim, HingeAngle, JointLoad, PointCoord, SliderPosition,
                 SystemQuantity)
from .syntax import Ident, NameRef
from .units import ANGLE, LENGTH, NONE

if TYPE_CHECKING:
    from .expressions import ExprResolver

VELOCITY = Dim(length=1, time=-1)
FORCE = Dim(mass=1, length=1, time=-2)
TORQUE = Dim(mass=1, length=2, time=-2)
ENERGY = TORQUE
BODY_COORDS = {"x": LENGTH, "y": LENGTH, "phi": ANGLE, "vx": VELOCITY, "vy": VELOCITY,
               "omega": Dim(angle=1, time=-1)}
PARTICLE_COORDS = {"x": LENGTH, "y": LENGTH, "vx": VELOCITY, "vy": VELOCITY}
# The loads a connector carries, by its kind (ir.JointLoad).
REACTIONS = {"force_x": FORCE, "force_y": FORCE, "force": FORCE, "torque": TORQUE}
# A slider's `force`: what its latch, stop, stick or hold-down exerts on B along the axis.
LOADS = {"hinge": REACTIONS, "weld": REACTIONS, "slider": {"force": FORCE},
         "spring": {"force": FORCE, "length": LENGTH, "rate": VELOCITY}}
# The system's quantities (ir.SystemQuantity); angular momentum in N*m*s (kg*m^2/s).
ANGULAR_MOMENTUM = Dim(mass=1, length=2, time=-1)
SYSTEM_QUANTITIES = {
    "mass": Dim(mass=1), "com_x": LENGTH, "com_y": LENGTH, "com_vx": VELOCITY,
    "com_vy": VELOCITY, "momentum_x": Dim(mass=1, length=1, time=-1),
    "momentum_y": Dim(mass=1, length=1, time=-1), "angular_momentum": ANGULAR_MOMENTUM,
    "kinetic_energy": ENERGY, "potential_energy": ENERGY, "energy": ENERGY,
    "dissipated": ENERGY, "dissipated_friction": ENERGY, "dissipated_damping": ENERGY,
    "dissipated_impacts": ENERGY,
}
POINT_AXES = {"x": LENGTH, "y": LENGTH, "vx": VELOCITY, "vy": VELOCITY}
# A spatial model's joints carry a 3-D reaction force (their rows x, y, z); a hinge its lock
# torque about its axis.
SPATIAL_REACTIONS = {"force_x": FORCE, "force_y": FORCE, "force_z": FORCE, "force": FORCE,
                     "moment_x": TORQUE, "moment_y": TORQUE, "moment_z": TORQUE,
                     "moment": TORQUE}
SPATIAL_LOADS = {"hinge": {**SPATIAL_REACTIONS, "torque": TORQUE}, "weld": SPATIAL_REACTIONS,
                 "ball": SPATIAL_REACTIONS, "spring": LOADS["spring"],
                 # a slider's force is its lock force along the axis; its rows' reaction,
                 # normal to the axis, and moment are force_x, ..., moment
                 "slider": {**{k: v for k, v in SPATIAL_REACTIONS.items() if k != "force"},
                            **LOADS["slider"]},
                 "cylindrical": {"angle": ANGLE, "rate": Dim(angle=1, time=-1),
                                 "position": LENGTH, "velocity": VELOCITY,
                                 **SPATIAL_REACTIONS},
                 "universal": {"angle_a": ANGLE, "rate_a": Dim(angle=1, time=-1),
                               "angle_b": ANGLE, "rate_b": Dim(angle=1, time=-1),
                               **SPATIAL_REACTIONS}}
# A spatial model's: positions and velocities have z; a body's orientation is its rotation
# matrix R (body frame to world, entries R11 ... R33) and its angular velocity (wx, wy, wz)
# is in the world frame.
RATE = Dim(angle=1, time=-1)
SPATIAL_POINT_AXES = {**POINT_AXES, "z": LENGTH, "vz": VELOCITY}
SPATIAL_PARTICLE_COORDS = SPATIAL_POINT_AXES
SPATIAL_BODY_COORDS = {**SPATIAL_POINT_AXES, "wx": RATE, "wy": RATE, "wz": RATE,
                       **{f"R{i}{j}": NONE for i in "123" for j in "123"}}
_MOMENTUM = Dim(mass=1, length=1, time=-1)
SPATIAL_SYSTEM_QUANTITIES = {
    **{name: dim for name, dim in SYSTEM_QUANTITIES.items() if name != "angular_momentum"},
    "com_z": LENGTH, "com_vz": VELOCITY, "momentum_z": _MOMENTUM,
    "angular_momentum_x": ANGULAR_MOMENTUM, "angular_momentum_y": ANGULAR_MOMENTUM,
    "angular_momentum_z": ANGULAR_MOMENTUM,
}


def _tables(resolver) -> tuple[dict, dict, dict, dict]:
    """(body coordinates, particle coordinates, point axes, system quantities) of the
    model's kind, planar or spatial."""
    if resolver.spatial:
        return (SPATIAL_BODY_COORDS, SPATIAL_PARTICLE_COORDS, SPATIAL_POINT_AXES,
                SPATIAL_SYSTEM_QUANTITIES)
    return BODY_COORDS, PARTICLE_COORDS, POINT_AXES, SYSTEM_QUANTITIES
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
    if symbol.kind in ("param", "cable", "output", "input"):
        report.error("E019", f"{symbol.describe()} has no properties", node.span)
        return None
    if not in_output:
        report.error("E018", f"'{node.dotted}' is a state quantity; it can be used only in "
                     "outputs", node.span)
        return None
    if symbol.kind == "system":
        return _system_quantity(resolver, node)
    if symbol.kind in ("hinge", "slider", "weld", "spring", "free", "ball", "cylindrical",
                       "universal"):
        return _joint_property(resolver, symbol, node)
    if len(node.parts) == 2:
        return _member_quantity(resolver, symbol, node.parts[1], node)
    if len(node.parts) == 3:
        return _point_coordinate(resolver, symbol, node.parts[1], node.parts[2])
    report.error("E019", f"'{node.dotted}' has too many parts", node.span,
                 hint="a point coordinate is MEMBER.POINT.x, e.g. rod.b.x")
    return None


def _joint_property(resolver, symbol, node: NameRef):
    """`h.rate`, `s.rate`; a connector's loads (`h.force_x`, `w.torque`, `k.force`)."""
    prop = node.parts[1]
    loads = (SPATIAL_LOADS if resolver.spatial else LOADS).get(symbol.kind, {})
    if len(node.parts) == 2 and prop.text == "rate" and symbol.kind in ("hinge", "slider"):
        expr = HingeAngle(symbol.index, True) if symbol.kind == "hinge" \
            else SliderPosition(symbol.index, True)
        return Typed(expr, JOINT_RATES[symbol.kind])
    if len(node.parts) == 2 and prop.text in loads:
        return Typed(JointLoad(symbol.kind, symbol.index, prop.text), loads[prop.text])
    known = (["rate"] if symbol.kind in ("hinge", "slider") else []) + list(loads)
    hint = f"its properties: {join_names(known)}" if known else \
        "a free joint only places its member at t = 0: use the member's x, y, phi, vx, " \
        "vy, omega"
    resolver.report.error("E019", f"{symbol.describe()} has no property "
                          f"'{'.'.join(p.text for p in node.parts[1:])}'", prop.span,
                          hint=did_you_mean(prop.text, known) or hint)
    return None


def _system_quantity(resolver, node: NameRef):
    """`system.momentum_x`, `system.kinetic_energy`, ...: the whole system's."""
    prop = node.parts[1]
    quantities = _tables(resolver)[3]
    if len(node.parts) == 2 and prop.text in quantities:
        return Typed(SystemQuantity(prop.text), quantities[prop.text])
    what = ".".join(p.text for p in node.parts[1:])
    about = "" if resolver.spatial else \
        "; the angular momentum about a point: angular_momentum(MEMBER.POINT)"
    resolver.report.error("E019", f"the system has no property '{what}'", prop.span,
                          hint=did_you_mean(prop.text, quantities)
                          or f"its properties: {join_names(quantities)}{about}")
    return None


def _member_quantity(resolver, symbol, prop: Ident, node: NameRef):
    points = resolver.symbols.points.get(symbol.name, {})
    body_coords, particle_coords, _, _ = _tables(resolver)
    if symbol.kind in ("bar", "body") and prop.text in body_coords:
        return Typed(BodyCoord(symbol.index, prop.text), body_coords[prop.text])
    if symbol.kind == "particle" and prop.text in particle_coords:
        return Typed(PointCoord(symbol.member, "cm", prop.text), particle_coords[prop.text])
    if symbol.kind == "particle" and prop.text in ("phi", "omega"):
        resolver.report.error("E019", f"{symbol.describe()} does not turn: it has no "
                              f"'{prop.text}'", prop.span, hint="a particle has x, y, vx, vy")
        return None
    if symbol.kind == "beam" and prop.text in BEAM_QUANTITIES:
        return Typed(BeamQuantity(symbol.index, prop.text), BEAM_QUANTITIES[prop.text])
    if prop.text in points:
        resolver.report.error("E019", f"'{node.dotted}' is a point, not a number", node.span,
                              hint=f"write {node.dotted}.x, .y, .vx or .vy")
        return None
    known = _properties(symbol.kind, resolver) + list(points)
    resolver.report.error("E019", f"{symbol.describe()} has no property '{prop.text}'",
                          prop.span, hint=did_you_mean(prop.text, known)
                          or f"its properties: {join_names(known)}")
    return None


def _properties(kind: str, resolver) -> list[str]:
    body_coords, particle_coords, _, _ = _tables(resolver)
    if kind in ("bar", "body"):
        return list(body_coords)
    if kind == "particle":
        return list(particle_coords)
    return list(BEAM_QUANTITIES) if kind == "beam" else []


def point_argument(resolver, node) -> Typed | None:
    """`angular_momentum(MEMBER.POINT)`: the system's angular momentum about that point
    (N*m*s), in outputs only (the caller checks the context)."""
    from .ir import Attachment

    if not isinstance(node, NameRef) or len(node.parts) != 2:
        resolver.report.error("E034", "angular_momentum takes a point, MEMBER.POINT, e.g. "
                              "angular_momentum(ground.origin)", node.span)
        return None
    member, point = node.parts
    symbol = resolver.symbols.get(member.text)
    if symbol is None or symbol.kind not in ("bar", "body", "beam", "particle", "ground"):
        what = symbol.describe() if symbol else f"'{member.text}'"
        resolver.report.error("E012", f"{what} is not a member: angular_momentum takes a "
                              "member's point", member.span)
        return None
    points = resolver.symbols.points.get(symbol.name, {})
    if point.text not in points:
        resolver.report.error("E013", f"{symbol.describe()} has no point '{point.text}'",
                              point.span, hint=did_you_mean(point.text, points)
                              or f"its points: {join_names(points)}")
        return None
    return Typed(SystemQuantity("angular_momentum", Attachment(symbol.member, point.text,
                                                                node.span)),
                 ANGULAR_MOMENTUM)


def _point_coordinate(resolver, symbol, point: Ident, axis: Ident):
    points = resolver.symbols.points.get(symbol.name, {})
    if point.text not in points:
        resolver.report.error("E013", f"{symbol.describe()} has no point '{point.text}'",
                              point.span, hint=did_you_mean(point.text, points)
                              or f"its points: {join_names(points)}")
        return None
    axes = _tables(resolver)[2]
    if axis.text not in axes:
        resolver.report.error("E019", f"a point has no property '{axis.text}'", axis.span,
                              hint=did_you_mean(axis.text, axes)
                              or f"a point has {join_names(axes)}")
        return None
    return Typed(PointCoord(symbol.member, point.text, axis.text), axes[axis.text])
