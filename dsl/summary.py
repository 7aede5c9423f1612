"""One screen describing a checked model: elements, sizes, parameters, outputs, warnings.

Values are shown at the parameters' defaults, in SI units (angles also in degrees).
"""

from __future__ import annotations

import math
import textwrap

from .attributes import SPECS
from .errors import header
from .evaluate import EvaluationError, evaluate
from .ir import Dim, Expr, Member, MemberKind, Model, Num
from .units import ANGLE, si_text

_WIDTH = 100
_HINGE_DIMS = {spec.name: spec.dim for spec in SPECS["hinge"] if spec.dim is not None}
_HINGE_DIMS.update(initial_angle=ANGLE, initial_rate=Dim(time=-1, angle=1))
_SPRING_DIMS = {spec.name: spec.dim for spec in SPECS["spring"] if spec.dim is not None}
_FREE_DIMS = (Dim(length=1), Dim(length=1, time=-1), Dim(length=1), Dim(length=1, time=-1),
              ANGLE, Dim(time=-1, angle=1))
_HINGE_ATTRIBUTES = tuple(_HINGE_DIMS)
# A slider's springs, friction, latch, stops and hold-down (SPECS["slider"]), in that order.
_SLIDER_DIMS = {spec.name: spec.dim for spec in SPECS["slider"] if spec.dim is not None}
_RATE = Dim(time=-1, angle=1)
_SPATIAL_FREE_NAMES = ("x", "vx", "y", "vy", "z", "vz", "turn_x", "wx", "turn_y", "wy",
                       "turn_z", "wz")
_SPATIAL_FREE_DIMS = (Dim(length=1), Dim(length=1, time=-1)) * 3 + (ANGLE, _RATE) * 3
_SLIDE = (Dim(length=1), Dim(length=1, time=-1))


def summary(model: Model) -> str:
    """A one-screen description of `model` (plain text, lines under 100 characters)."""
    values = [p.default for p in model.params]
    lines = [f"model {model.name}" + (f": {model.description}" if model.description else ""),
             f"source {model.source_file} (sha256 {model.source_sha256[:12]})", ""]
    for section in (_bodies, _particles, _beams, _hinges, _sliders, _welds, _balls,
                    _axial_joints, _free_joints, _springs, _cables, _sizes, _settings, _params,
                    _outputs, _inputs, _warnings):
        lines += section(model, values)
    return "\n".join(lines).rstrip() + "\n"


def quantity(expr: Expr, dim: Dim, values: list[float]) -> str:
    """`expr` at the defaults with its SI unit: "0.1273 N*m/rad", "1.571 rad (90 deg)"."""
    try:
        value = evaluate(expr, values)
    except EvaluationError:
        return "?"
    if dim == ANGLE:
        return f"{math.degrees(value):.4g} deg"
    unit = si_text(dim)
    return f"{value:.4g}" + ("" if unit == "1" else f" {unit}")


def _member_name(model: Model, member: Member) -> str:
    if member.kind is MemberKind.GROUND:
        return "ground"
    elements = {MemberKind.BODY: model.bodies, MemberKind.BEAM: model.beams,
                MemberKind.PARTICLE: model.particles}[member.kind]
    return elements[member.index].name


def _ends(model: Model, joint) -> str:
    """"yoke.b -> panel1.a"."""
    return (f"{_member_name(model, joint.a.member)}.{joint.a.point} -> "
            f"{_member_name(model, joint.b.member)}.{joint.b.point}")


def _bodies(model: Model, values: list[float]) -> list[str]:
    lines = [f"bodies ({len(model.bodies)})"]
    for body in model.bodies:
        parts = [f"  {body.name:<12} {body.kind:<5}"]
        if body.length is not None:
            parts.append(f"length {quantity(body.length, Dim(length=1), values)},")
        parts.append(f"mass {quantity(body.mass, Dim(mass=1), values)},")
        if body.principal is not None:
            moments = ", ".join(quantity(value, Dim(), values) for value in body.principal)
            parts.append(f"inertia ({moments}) kg*m^2;")
            if body.products is not None:
                products = ", ".join(quantity(value, Dim(), values) for value in body.products)
                parts.append(f"products of inertia ({products}) kg*m^2;")
        else:
            parts.append(f"inertia {quantity(body.inertia, Dim(1, 2), values)};")
        parts.append("points " + ", ".join(p.name for p in body.points))
        lines += _wrap(" ".join(parts))
    return lines


def _particles(model: Model, values: list[float]) -> list[str]:
    if not model.particles:
        return []
    return [f"particles ({len(model.particles)})"] + [
        f"  {p.name:<12} mass {quantity(p.mass, Dim(mass=1), values)}" for p in model.particles]


def _welds(model: Model, values: list[float]) -> list[str]:
    if not model.welds:
        return []
    lines = [f"welds ({len(model.welds)})"]
    for weld in model.welds:
        holds = "the points only (a particle)" if not weld.rotational \
            else "their orientations as placed" if model.spatial \
            else f"angle {quantity(weld.angle, ANGLE, values)}"
        lines += _wrap(f"  {weld.name:<12} {_ends(model, weld)}: holds {holds}")
    return lines


def _free_joints(model: Model, values: list[float]) -> list[str]:
    if not model.free_joints:
        return []
    lines = [f"free joints ({len(model.free_joints)})"]
    names, dims = (_SPATIAL_FREE_NAMES, _SPATIAL_FREE_DIMS) if model.spatial \
        else (("x", "vx", "y", "vy", "angle", "omega"), _FREE_DIMS)
    for free in model.free_joints:
        given = [f"{name} {quantity(value, dim, values)}" for name, value, dim
                 in zip(names, free.initial, dims)
                 if (free.turns or name not in ("angle", "omega")) and value != Num(0.0)]
        lines += _wrap_items(f"  {free.name:<12} {_ends(model, free)}; initial", given
                             or ["at rest, at its point"])
    return lines


def _balls(model: Model, values: list[float]) -> list[str]:
    if not model.balls:
        return []
    lines = [f"ball joints ({len(model.balls)})"]
    for ball in model.balls:
        given = [f"{name} {quantity(value, dim, values)}" for name, value, dim
                 in zip(_SPATIAL_FREE_NAMES[6:], ball.initial, _SPATIAL_FREE_DIMS[6:])
                 if value != Num(0.0)]
        lines += _wrap_items(f"  {ball.name:<12} {_ends(model, ball)}; initial", given
                             or ["no relative turn"])
    return lines


def _axial_joints(model: Model, values: list[float]) -> list[str]:
    """Cylindrical and universal joints: their axes and the initial values given."""
    lines = []
    for title, joints, axes, names, dims in (
            ("cylindrical joints", model.cylindricals, ("axis",),
             ("angle", "rate", "position", "velocity"), (ANGLE, _RATE) + _SLIDE),
            ("universal joints", model.universals, ("axis_a", "axis_b"),
             ("angle_a", "rate_a", "angle_b", "rate_b"), (ANGLE, _RATE) * 2)):
        if not joints:
            continue
        lines.append(f"{title} ({len(joints)})")
        for joint in joints:
            directions = [f"{axis} ({', '.join(quantity(c, Dim(), values) for c in value)})"
                          for axis in axes for value in (getattr(joint, axis),)]
            given = [f"{name} {quantity(value, dim, values)}" for name, value, dim
                     in zip(names, joint.initial, dims) if value != Num(0.0)]
            lines += _wrap_items(f"  {joint.name:<12} {_ends(model, joint)}; "
                                 f"{', '.join(directions)}; initial", given
                                 or ["as the orientations place it"])
    return lines


def _springs(model: Model, values: list[float]) -> list[str]:
    if not model.springs:
        return []
    lines = [f"springs ({len(model.springs)})"]
    for spring in model.springs:
        attributes = [f"{name} {quantity(value, _SPRING_DIMS[name], values)}"
                      for name in _SPRING_DIMS if (value := getattr(spring, name)) is not None]
        if spring.acts.value != "both":
            attributes.append(f"acts {spring.acts.value}")
        lines += _wrap_items(f"  {spring.name:<12} {_ends(model, spring)};", attributes)
    return lines


def _beams(model: Model, values: list[float]) -> list[str]:
    if model.spatial:
        return []  # (a spatial model has none yet)
    lines = [f"beams ({len(model.beams)})"]
    for beam in model.beams:
        text = (f"  {beam.name:<12} length {quantity(beam.length, Dim(length=1), values)}, "
                f"EI {quantity(beam.EI, Dim(1, 3, -2), values)}, "
                f"EA {quantity(beam.EA, Dim(1, 1, -2), values)}, "
                f"mass_per_length {quantity(beam.mass_per_length, Dim(1, -1), values)}, "
                f"{beam.elements} element{'s' * (beam.elements != 1)}")
        if beam.damping is not None:
            text += f", damping {quantity(beam.damping, Dim(time=1), values)}"
        lines += _wrap(text)
    return lines


def _hinges(model: Model, values: list[float]) -> list[str]:
    lines = [f"hinges ({len(model.hinges)})"]
    for hinge in model.hinges:
        a, b = _member_name(model, hinge.a.member), _member_name(model, hinge.b.member)
        sign = "" if hinge.sign > 0 else "-"
        offset = "" if hinge.offset == Num(0.0) else \
            f" + {quantity(hinge.offset, ANGLE, values)}"
        text = (f"  {hinge.name:<12} {a}.{hinge.a.point} -> {b}.{hinge.b.point}: "
                f"theta = {sign}({b} - {a}){offset}")
        if hinge.axis is not None:
            text += " about (" + ", ".join(quantity(c, Dim(), values) for c in hinge.axis) + ")"
        attributes = [f"{name} {quantity(value, _HINGE_DIMS.get(name, ANGLE), values)}"
                      for name in _HINGE_ATTRIBUTES
                      if (value := getattr(hinge, name)) is not None and value != Num(0.0)]
        lines += _wrap_items(text + ";", attributes)
    return lines


def _sliders(model: Model, values: list[float]) -> list[str]:
    if model.spatial and not model.sliders:
        return []
    lines = [f"sliders ({len(model.sliders)})"]
    for slider in model.sliders:
        a, b = _member_name(model, slider.a.member), _member_name(model, slider.b.member)
        axis = ", ".join(quantity(c, Dim(), values) for c in slider.axis)
        lines += _wrap_items(
            f"  {slider.name:<12} {a}.{slider.a.point} -> {b}.{slider.b.point}:",
            [f"axis ({axis})",
             f"initial_position {quantity(slider.initial_position, Dim(length=1), values)}",
             f"initial_rate {quantity(slider.initial_rate, Dim(length=1, time=-1), values)}"]
            + [f"{name} {quantity(value, dim, values)}" for name, dim in _SLIDER_DIMS.items()
               if (value := getattr(slider, name)) is not None])
    return lines


def _cables(model: Model, values: list[float]) -> list[str]:
    lines = [f"cables ({len(model.cables)})"]
    for cable in model.cables:
        terms = []
        for term in cable.terms:
            coefficient = quantity(term.coefficient, Dim(), values)
            name = model.hinges[term.hinge].name
            terms.append(name if coefficient == "1" else f"-{name}" if coefficient == "-1"
                         else f"{coefficient}*{name}")
        combination = " + ".join(terms).replace("+ -", "- ")
        lines.append(f"  {cable.name:<12} stiffness "
                     f"{quantity(cable.stiffness, Dim(1, 2, -2, -1), values)}, "
                     f"angles {combination}")
    return lines


def _sizes(model: Model, values: list[float]) -> list[str]:
    if model.spatial:
        return _spatial_sizes(model)
    joints = len(model.hinges) + len(model.sliders)
    coordinates = 3 * len(model.bodies) + 2 * len(model.particles)
    rows = 2 * joints + sum(3 if w.rotational else 2 for w in model.welds)
    text = f"coordinates {coordinates} (3 per rigid body"
    text += ", 2 per particle)" if model.particles else ")"
    if model.beams:
        text += ", plus beam coordinates (set by the beam element)"
    text += f"; constraints {rows} (2 per hinge or slider"
    text += ", 3 per weld)" if model.welds else ")"
    if not model.beams:
        text += f"; degrees of freedom {coordinates - rows}"
    steps = [f"{_joint_name(model, p.kind.value, p.joint)} places "
             f"{_member_name(model, p.child)}" for p in model.placements]
    loops = [_joint_name(model, kind.value, index) for kind, index in model.loop_joints]
    return ["", *_wrap(text), *_assembly(model)]


def _spatial_sizes(model: Model) -> list[str]:
    """A spatial model's coordinates and rows (codegen/spatial.py) and its mobility count."""
    coordinates = 12 * len(model.bodies) + 3 * len(model.particles)
    joint_rows = (5 * len(model.hinges) + 3 * len(model.balls)
                  + 4 * len(model.cylindricals) + 4 * len(model.universals)
                  + sum(6 if w.rotational else 3 for w in model.welds)
                  + sum(2 if s.b.member.kind is MemberKind.PARTICLE else 5
                        for s in model.sliders))
    rows = 6 * len(model.bodies) + joint_rows
    mobility = 6 * len(model.bodies) + 3 * len(model.particles) - joint_rows
    text = (f"coordinates {coordinates} (12 per rigid body: centre of mass and rotation matrix"
            f"{', 3 per particle' if model.particles else ''}); constraints {rows} (6 per body, "
            f"5 per hinge or slider, 3 per ball joint, 4 per cylindrical or universal joint, 6 "
            f"per weld); Grubler count {mobility} (rows "
            "that are redundant raise the true mobility above it)")
    return ["", *_wrap(text), *_assembly(model)]


def _assembly(model: Model) -> list[str]:
    steps = [f"{_joint_name(model, p.kind.value, p.joint)} places "
             f"{_member_name(model, p.child)}" for p in model.placements]
    loops = [_joint_name(model, kind.value, index) for kind, index in model.loop_joints]
    lines = _wrap("assembly: " + (", ".join(steps) or "nothing to place"))
    if loops:
        lines += _wrap("loops closed by: " + ", ".join(loops))
    return lines


def _joint_name(model: Model, kind: str, index: int) -> str:
    return {"hinge": model.hinges, "slider": model.sliders, "weld": model.welds,
            "free": model.free_joints, "ball": model.balls, "cylindrical": model.cylindricals,
            "universal": model.universals}[kind][index].name


def _settings(model: Model, values: list[float]) -> list[str]:
    gravity = ", ".join(quantity(g, Dim(), values) for g in model.gravity)
    s = model.simulation
    return [f"gravity ({gravity}) m/s^2",
            f"simulate t_end {s.t_end:g} s, tol {s.tol:g}, dt_out {s.dt_out:g} s"]


def _params(model: Model, values: list[float]) -> list[str]:
    declared = [p for p in model.params if p.kind.value == "param"]
    attributes = [p for p in model.params if p.kind.value == "attribute"]
    inputs = [p for p in model.params if p.kind.value == "input"]
    of_inputs = f", {len(inputs)} of inputs" if inputs else ""
    lines = ["", f"parameters ({len(model.params)}: {len(declared)} declared, "
             f"{len(attributes)} from attributes{of_inputs})"]
    lines += [f"  {p.name} = {p.default:.6g} {p.unit}" for p in declared]
    if attributes:
        lines += _wrap_items("  attributes:", [
            f"{p.name}={p.default:.4g}" + ("" if p.unit == "1" else f" {p.unit}")
            for p in attributes])
    if inputs:
        lines += _wrap_items("  inputs:", [f"{p.name}={p.default:.4g} {p.unit}" for p in inputs])
    if model.derived:
        lines += _wrap_items("  derived:", [f"{d.name} (from {', '.join(d.depends_on)})"
                                            for d in model.derived])
    if model.structural:
        lines += _wrap_items("  structural (loop bounds and indices, fixed when checked; "
                             "not in the vector):",
                             [f"{s.name} = {s.value}" for s in model.structural])
    return lines


def _outputs(model: Model, values: list[float]) -> list[str]:
    listed = ", ".join(f"{o.name} [{o.unit}]" for o in model.outputs) or "none"
    return _wrap(f"outputs ({len(model.outputs)}): {listed}")


def _inputs(model: Model, values: list[float]) -> list[str]:
    if not model.inputs:
        return []
    items = []
    for put in model.inputs:
        where = model.hinges[put.hinge].name if put.hinge is not None \
            else f"{_member_name(model, put.point.member)}.{put.point.point}"
        items.append(f"{put.name} {put.kind.value} on {where} "
                     f"[{model.params[put.slots[0]].unit}]")
    return _wrap(f"inputs ({len(model.inputs)}): {', '.join(items)}")


def _warnings(model: Model, values: list[float]) -> list[str]:
    if not model.warnings:
        return ["warnings: none"]
    return [f"warnings ({len(model.warnings)}):"] + [f"  {header(w)}" for w in model.warnings]


def _wrap_items(prefix: str, items: list[str], indent: str = "      ") -> list[str]:
    """`prefix item, item, ...` filled to the width, never breaking inside an item."""
    lines, line = [], prefix
    for i, item in enumerate(items):
        piece = item + ("," if i < len(items) - 1 else "")
        if len(line) + 1 + len(piece) > _WIDTH and line.strip():
            lines.append(line)
            line = indent + piece
        else:
            line = f"{line} {piece}"
    return lines + [line]


def _wrap(text: str, indent: str = "      ") -> list[str]:
    return textwrap.wrap(text, _WIDTH, subsequent_indent=indent, break_on_hyphens=False) or [""]
