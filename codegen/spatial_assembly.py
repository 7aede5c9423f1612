"""The initial state of a spatial model: forward kinematics along Model.placements, as the
planar assembly does it (codegen/assembly.py: one group of local steps per member, the
velocities by forward differentiation of the same steps).

Each placement puts its child so that the joint's attachment points coincide (a free joint:
b's point at (x, y, z) from a's in a's frame) and turns it from its parent: a hinge by its
angle about its axis, a ball or free joint by three turns about the parent's axes x, y, z
(zero at t = 0: the members' orientations place the child; their rates are the child's
angular velocity relative to the parent, in the parent's frame), a cylindrical joint by its
angle about its axis (and b's point moved along it by its position), a universal joint by
angle_a about axis_a then angle_b about axis_b (codegen/spatial.py), a weld not at all. With
every joint at zero each member has its `orientation`."""

from __future__ import annotations

import functools

import sympy

from depsim.dsl import ir

from .assembly import Assembly, _joint_value, _Placing, _sides
from .blocks import member_roles, named_roles, renamed
from .spatial import SpatialKinematics, Vector3, rotation_about, times, turn


def assemble_spatial(model: ir.Model, kin: SpatialKinematics,
                     placings: list | None = None) -> Assembly:
    """The tree placement of a spatial model's members and its initial values; `placings`,
    when given, gets each hinge's placement as (its group's index in the pose and the
    tangent, the roles of its symbols: `_placing_kind`), for its tree blocks
    (spatial_blocks.tree_blocks)."""
    state = _Placing(dict(zip(kin.symbols.q, kin.symbols.qd)))
    place = {ir.JointKind.HINGE: functools.partial(
                 _place_hinge, placed={}, placings=[] if placings is None else placings),
             ir.JointKind.WELD: _place_weld,
             ir.JointKind.BALL: _place_ball, ir.JointKind.FREE: _place_free,
             ir.JointKind.SLIDER: _place_slider, ir.JointKind.CYLINDRICAL: _place_cylindrical,
             ir.JointKind.UNIVERSAL: _place_universal}
    for placement in model.placements:
        _place_at_origin(kin, placement.parent, state)
        place[placement.kind](kin, placement, state)
    for kind, count in ((ir.MemberKind.BODY, len(model.bodies)),
                        (ir.MemberKind.PARTICLE, len(model.particles))):
        for index in range(count):
            _place_at_origin(kin, ir.Member(kind, index), state)
    v = tuple(state.values)
    return Assembly(tree_joints=tuple(name for name, _ in state.names), v=v,
                    vd=tuple(state.rates[s] for s in v),
                    v0=tuple(value for value, _ in state.values.values()),
                    vd0=tuple(rate for _, rate in state.values.values()),
                    held=tuple(held for _, held in state.names), pose=tuple(state.pose),
                    tangent=tuple(state.tangent), beam_angles=(), local=state.local)


def hinge_turns(model: ir.Model, kin: SpatialKinematics, assembly: Assembly
                ) -> tuple[sympy.Expr, ...]:
    """Each hinge's turn (rad, of p) its angle is measured within half a turn of: for a hinge
    that places a member, the middle of its travel, between its initial angle and its latch
    (or the middle of its stops, or its initial angle without either), so that a panel
    folded through 180 degrees reaches its latch; for one that closes a loop, the placed
    members' turn at t = 0."""
    placing = {p.joint for p in model.placements if p.kind is ir.JointKind.HINGE}
    turns = []
    for index, hinge in enumerate(model.hinges):
        if index in placing:
            start = kin.const(hinge.initial_angle)
            if hinge.latch is not None:
                middle = (start + kin.const(hinge.latch)) / 2
            elif hinge.stop_min is not None and hinge.stop_max is not None:
                middle = (kin.const(hinge.stop_min) + kin.const(hinge.stop_max)) / 2
            else:
                middle = start
            turns.append(hinge.sign * (middle - kin.const(hinge.offset)))
        else:
            raw = assembly.at_start(kin.hinge_raw_turn(index, sympy.Integer(0)))
            turns.append(raw.xreplace(kin.resolved()))
    return tuple(turns)


def _rotation(kin: SpatialKinematics, member: ir.Member) -> sympy.Matrix:
    """A placed member's rotation (a particle's frame is the world's)."""
    if member.kind is ir.MemberKind.PARTICLE:
        return sympy.eye(3)
    return kin.rotation(member)


def _relative(kin: SpatialKinematics, joint) -> sympy.Matrix:
    """R0 of a joint whose members may be particles (their orientation is the world's)."""
    return kin.relative_orientation(joint.a.member, joint.b.member)


def _place_turned(kin: SpatialKinematics, joint, placement: ir.Placement,
                  turned: sympy.Matrix, state: _Placing, offset: Vector3 | None = None) -> None:
    """Place the child of `placement` with R_b = R_a turned R0, and b's point at a's point
    (plus `offset` in a's frame, a free joint's)."""
    parent, child, child_is_b = _sides(joint, placement)
    relative = _relative(kin, joint)
    point = kin.attachment_position(parent)
    if child_is_b:
        rotation_a = _rotation(kin, parent.member)
        rotation = rotation_a * turned * relative
        if offset is not None:
            point = tuple(p + d for p, d in zip(point, times(rotation_a, offset)))
    else:
        rotation = _rotation(kin, parent.member) * relative.T * turned.T
        if offset is not None:
            point = tuple(p - d for p, d in zip(point, times(rotation, offset)))
    _place_member(kin, child, point, rotation, state)


def _place_hinge(kin: SpatialKinematics, placement: ir.Placement, state: _Placing,
                 placed: dict, placings: list) -> None:
    """Place a hinge's child turned by its angle about the axis; the steps of a kind of
    placement (`_placing_kind`) written out once and renamed for the others (`placed`:
    kind -> the first one's steps over placeholders); its group and roles onto
    `placings`."""
    hinge = kin.model.hinges[placement.joint]
    theta = _joint_value(kin, hinge.name, hinge.initial_angle, hinge.initial_rate,
                         hinge.held, state)
    frame = kin.hinge_frame(placement.joint)
    key, roles = _placing_kind(kin, hinge, placement, frame, theta, state)
    placings.append((len(state.pose), tuple(roles)))
    if key in placed:
        back = {x: symbol for symbol, x in roles}
        pose, tangent = (tuple((s.xreplace(back), v.xreplace(back)) for s, v in group)
                         for group in placed[key])
        state.local.update(pose)
        state.pose.append(pose)
        state.tangent.append(tangent)
        return
    angle = hinge.sign * (theta - kin.const(hinge.offset))
    _place_turned(kin, hinge, placement, rotation_about(frame.axis, angle), state)
    names = dict(roles)
    template = tuple(tuple((s.xreplace(names), v.xreplace(names)) for s, v in group)
                     for group in (state.pose[-1], state.tangent[-1]))
    own = {x for group in template for s, v in group for x in v.free_symbols | {s}}
    if all(x.name.startswith("#") or x in set(kin.p) for x in own):
        placed[key] = template


def _placing_kind(kin: SpatialKinematics, hinge, placement: ir.Placement, frame, theta,
                  state: _Placing) -> tuple[tuple, list]:
    """What a hinge's placement is a function of but its symbols (its members' kinds and
    sides, sign, offset, attachment points, its axis's and R0's named constants as
    placeholders), and the roles of its symbols: the parent's coordinates and rates as
    side a, the child's as b, the angle and its rate, the named constants (blocks.py)."""
    parent, child, child_is_b = _sides(hinge, placement)
    roles = [(theta, sympy.Symbol("#v")), (state.rates[theta], sympy.Symbol("#dv"))]
    for side, member in (("a", parent.member), ("b", child.member)):
        if member.kind is not ir.MemberKind.GROUND:
            coordinates = kin.member_symbols(member)
            roles += member_roles(side, coordinates, [state.rates[s] for s in coordinates])
    relative = _relative(kin, hinge)
    constants = list(frame.axis) + list(relative)
    prefixes = (f"{hinge.name}.", f"{kin.member_name(hinge.a.member)}."
                f"{kin.member_name(hinge.b.member)}.")
    roles += named_roles({x for x in constants if isinstance(x, sympy.Symbol)}, prefixes)
    names = dict(roles)
    key = (parent.member.kind, child.member.kind, child_is_b, hinge.sign,
           kin.const(hinge.offset), kin.local_point(parent.member, parent.point),
           kin.local_point(child.member, child.point),
           tuple(renamed(x, names) for x in constants))
    return key, roles


def _place_weld(kin: SpatialKinematics, placement: ir.Placement, state: _Placing) -> None:
    _place_turned(kin, kin.model.welds[placement.joint], placement, sympy.eye(3), state)


def _place_slider(kin: SpatialKinematics, placement: ir.Placement, state: _Placing) -> None:
    """The child's point s along the axis (A's frame) from the parent's, not turned."""
    slider = kin.model.sliders[placement.joint]
    s = _joint_value(kin, slider.name, slider.initial_position, slider.initial_rate,
                     slider.held, state)
    axis = kin.slider_frame(placement.joint)[0]
    _place_turned(kin, slider, placement, sympy.eye(3), state,
                  tuple(s * component for component in axis))


def _pair_values(kin: SpatialKinematics, joint, names: tuple[str, str], state: _Placing):
    """The symbols of a joint's two values (ir.CYLINDRICAL_VALUES, UNIVERSAL_VALUES), named
    NAME.<names[k]> in the assembly."""
    return [_joint_value(kin, f"{joint.name}.{name}", joint.initial[2 * k],
                         joint.initial[2 * k + 1], joint.held[k], state)
            for k, name in enumerate(names)]


def _place_cylindrical(kin: SpatialKinematics, placement: ir.Placement,
                       state: _Placing) -> None:
    joint = kin.model.cylindricals[placement.joint]
    angle, position = _pair_values(kin, joint, ("angle", "position"), state)
    axis = kin.axis_frame(joint.name, joint.axis)[0]
    _place_turned(kin, joint, placement, rotation_about(axis, angle), state,
                  tuple(position * component for component in axis))


def _place_universal(kin: SpatialKinematics, placement: ir.Placement, state: _Placing) -> None:
    joint = kin.model.universals[placement.joint]
    angle_a, angle_b = _pair_values(kin, joint, ("angle_a", "angle_b"), state)
    parts = kin.universal_parts(placement.joint)
    turned = rotation_about(parts["axis_a"], angle_a) * rotation_about(parts["b_in_a"], angle_b)
    _place_turned(kin, joint, placement, turned, state)


def _turn_values(kin: SpatialKinematics, joint, first: int, state: _Placing) -> sympy.Matrix:
    """Rz(c) Ry(b) Rx(a) of a joint's three turn values (pairs first.. of its initial)."""
    values = [_joint_value(kin, f"{joint.name}.{name}", joint.initial[2 * (first + k)],
                           joint.initial[2 * (first + k) + 1], joint.held[first + k], state)
              for k, name in enumerate(("turn_x", "turn_y", "turn_z"))]
    return turn("z", values[2]) * turn("y", values[1]) * turn("x", values[0])


def _place_ball(kin: SpatialKinematics, placement: ir.Placement, state: _Placing) -> None:
    ball = kin.model.balls[placement.joint]
    _place_turned(kin, ball, placement, _turn_values(kin, ball, 0, state), state)


def _place_free(kin: SpatialKinematics, placement: ir.Placement, state: _Placing) -> None:
    free = kin.model.free_joints[placement.joint]
    offset = tuple(_joint_value(kin, f"{free.name}.{name}", free.initial[2 * k],
                                free.initial[2 * k + 1], free.held[k], state)
                   for k, name in enumerate("xyz"))
    _place_turned(kin, free, placement, _turn_values(kin, free, 3, state), state, offset)


def _place_member(kin: SpatialKinematics, attachment: ir.Attachment, point: Vector3,
                  rotation: sympy.Matrix, state: _Placing) -> None:
    """Place a member so that `attachment` is at world `point`, turned by `rotation` (a
    particle goes to `point`)."""
    member = attachment.member
    symbols = kin.member_symbols(member)
    if member.kind is ir.MemberKind.PARTICLE:
        state.place(symbols, point)
        return
    offset = times(rotation, kin.local_point(member, attachment.point))
    state.place(symbols, tuple(p - o for p, o in zip(point, offset)) + tuple(rotation))


def _place_at_origin(kin: SpatialKinematics, member: ir.Member, state: _Placing) -> None:
    """Start a member not yet placed (the root of a floating tree) at the origin, in its
    orientation."""
    if member.kind is ir.MemberKind.GROUND or kin.member_symbols(member)[0] in state.local:
        return
    zero = sympy.Integer(0)
    origin = (zero, zero, zero)
    if member.kind is ir.MemberKind.PARTICLE:
        state.place(kin.member_symbols(member), origin)
    else:
        state.place(kin.member_symbols(member), origin + tuple(kin.orientation(member)))
