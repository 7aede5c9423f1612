"""The initial state: forward kinematics along Model.placements, as a program of local steps.

Members no joint path reaches from the ground (the checker warns, W001) start at the origin:
a body with its centre of mass there at angle 0, a beam with end a there along +x, at rest.
Each placement puts its child member so that the joint's two attachment points coincide (a
hinge, turned by its initial angle; a weld, at its angle), lie `initial_position` apart along
the axis (a slider, whose child keeps its parent's angle), or lie (x, y) apart in the parent's
frame, turned by `angle` (a free joint: three values, two for a particle). Every joint's value enters as a symbol v_k, so that the
tree pose q(v) places each member from its parent's coordinates and its joint's value: one
step per member, each a few terms, so a chain of n members costs O(n) code where the pose
written out in v would cost O(n^2) (and its Jacobian O(n^3)). The velocities follow by forward
differentiation of the same steps, qd_child = sum_u d local / d u * u', u the parent's
coordinates and the joint's value. The integrator core assembles closed loops from the pose
and these tangents (docs/language.md, Assembly)."""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy

from depsim.dsl import ir

from .kinematics import Kinematics, Vector, rotate

Step = tuple[sympy.Symbol, sympy.Expr]  # symbol := expression of earlier symbols, v and p
Group = tuple[Step, ...]  # one member's steps (no step refers to a symbol of its own group)


@dataclass(frozen=True)
class Assembly:
    """The tree placement: the tree joints (placement order) with their value symbols v and
    rate symbols vd, their initial values v0 and rates vd0 (expressions of p) and what the user
    gave (held); `pose`: per member, its coordinates q_j := local(earlier q, v, p); `tangent`:
    per member, qd_j := d local / d(earlier q, v) . (earlier qd, vd), in the same order.
    `start` holds each coordinate's local expression, for `at_start`."""

    tree_joints: tuple[str, ...]  # per value: "h1", "s1", or "fly.x", "fly.y", "fly.angle"
    v: tuple[sympy.Symbol, ...]
    vd: tuple[sympy.Symbol, ...]
    v0: tuple[sympy.Expr, ...]
    vd0: tuple[sympy.Expr, ...]
    held: tuple[int, ...]
    pose: tuple[Group, ...]
    tangent: tuple[Group, ...]
    beam_angles: tuple[sympy.Expr, ...]  # each beam's initial angle (rad), an expression of p
    local: dict[sympy.Symbol, sympy.Expr] = field(repr=False)

    def at_start(self, expr: sympy.Expr) -> sympy.Expr:
        """`expr` (of q and p) at the initial placement, as an expression of p: the placed
        coordinates replaced by their local steps down to the joints' initial values."""
        return _at_start(expr, self.local, dict(zip(self.v, self.v0)), {})


def _at_start(expr: sympy.Expr, local: dict, initial: dict, memo: dict) -> sympy.Expr:
    replace = {}
    for s in expr.free_symbols:
        if s in initial:
            replace[s] = initial[s]
        elif s in local:
            if s not in memo:
                memo[s] = _at_start(local[s], local, initial, memo)
            replace[s] = memo[s]
    return expr.xreplace(replace)


@dataclass
class _Placing:
    """The placement so far: each placed coordinate's local expression and rate symbol, the
    groups of steps, the beams' angles (local expressions), joint values -> (value, rate)."""

    rates: dict[sympy.Symbol, sympy.Symbol]  # q -> qd, and v -> vd once the joint is placed
    local: dict[sympy.Symbol, sympy.Expr] = field(default_factory=dict)
    pose: list[Group] = field(default_factory=list)
    tangent: list[Group] = field(default_factory=list)
    beam_angles: dict[int, sympy.Expr] = field(default_factory=dict)
    values: dict[sympy.Symbol, tuple[sympy.Expr, sympy.Expr]] = field(default_factory=dict)
    names: list[tuple[str, int]] = field(default_factory=list)  # per value: name, held

    def place(self, symbols, locals_) -> None:
        """Put a member's coordinates `symbols` at `locals_`, expressions of placed
        coordinates, joint values and parameters; and their rates by the chain rule."""
        pose, tangent = [], []
        for symbol, local in zip(symbols, locals_):
            rate = sympy.Add(*(local.diff(u) * self.rates[u] for u in local.free_symbols
                               if u in self.local or u in self.values))
            pose.append((symbol, local))
            tangent.append((self.rates[symbol], rate))
        for symbol, local in pose:
            self.local[symbol] = local
        self.pose.append(tuple(pose))
        self.tangent.append(tuple(tangent))


def assemble(model: ir.Model, kin: Kinematics) -> Assembly:
    """The tree placement of the model's members and its initial values."""
    state = _Placing(dict(zip(kin.symbols.q, kin.symbols.qd)))
    place = {ir.JointKind.HINGE: _place_hinge, ir.JointKind.SLIDER: _place_slider,
             ir.JointKind.WELD: _place_weld, ir.JointKind.FREE: _place_free}
    for placement in model.placements:
        _place_at_origin(kin, placement.parent, state)
        place[placement.kind](kin, placement, state)
    for kind, count in ((ir.MemberKind.BODY, len(model.bodies)),
                        (ir.MemberKind.PARTICLE, len(model.particles)),
                        (ir.MemberKind.BEAM, len(model.beams))):
        for index in range(count):
            _place_at_origin(kin, ir.Member(kind, index), state)
    v = tuple(state.values)
    v0 = tuple(value for value, _ in state.values.values())
    initial, memo = dict(zip(v, v0)), {}
    return Assembly(tree_joints=tuple(name for name, _ in state.names), v=v,
                    vd=tuple(state.rates[s] for s in v), v0=v0,
                    vd0=tuple(rate for _, rate in state.values.values()),
                    held=tuple(held for _, held in state.names), pose=tuple(state.pose),
                    tangent=tuple(state.tangent),
                    beam_angles=tuple(_at_start(state.beam_angles[i], state.local, initial, memo)
                                      for i in range(len(model.beams))),
                    local=state.local)


def _joint_value(kin: Kinematics, name: str, initial: ir.Expr, rate: ir.Expr, held: int,
                 state: _Placing) -> sympy.Symbol:
    """The symbol standing for a joint's value `name` (an angle or a displacement) starting at
    `initial` with `rate`, and its rate's symbol."""
    value = sympy.Symbol(f"{name}@0")  # '@' keeps it apart from param names
    state.values[value] = (kin.const(initial), kin.const(rate))
    state.rates[value] = sympy.Symbol(f"{name}@rate")
    state.names.append((name, held))
    return value


def _sides(joint, placement: ir.Placement):
    """(parent attachment, child attachment, True when the child is the joint's member b)."""
    if joint.b.member == placement.child:
        return joint.a, joint.b, True
    return joint.b, joint.a, False


def _placed(kin: Kinematics, attachment: ir.Attachment, state: _Placing):
    """(world position, angle) of an attachment of an already placed member, in its placed
    coordinates (a beam's angle as placed)."""
    position = tuple(kin.attachment_position(attachment))
    if attachment.member.kind is ir.MemberKind.BEAM:
        return position, state.beam_angles[attachment.member.index]
    return position, kin.attachment_angle(attachment)


def _place_hinge(kin: Kinematics, placement: ir.Placement, state: _Placing) -> None:
    """The child's attachment at the parent's, turned so that theta = the joint's value."""
    hinge = kin.model.hinges[placement.joint]
    parent, child, child_is_b = _sides(hinge, placement)
    theta = _joint_value(kin, hinge.name, hinge.initial_angle, hinge.initial_rate, hinge.held,
                         state)
    point, parent_angle = _placed(kin, parent, state)
    turn = hinge.sign * (theta - kin.const(hinge.offset))  # angle(b) - angle(a)
    _place_member(kin, child, point, parent_angle + turn if child_is_b else parent_angle - turn,
                  state)


def _place_slider(kin: Kinematics, placement: ir.Placement, state: _Placing) -> None:
    """The child's attachment s along the axis from the parent's, at the parent's angle."""
    slider = kin.model.sliders[placement.joint]
    parent, child, child_is_b = _sides(slider, placement)
    s = _joint_value(kin, slider.name, slider.initial_position, slider.initial_rate,
                     slider.held, state)
    base, angle = _placed(kin, parent, state)
    axis = rotate(angle, kin.slider_unit_axis(placement.joint))
    along = s if child_is_b else -s
    _place_member(kin, child, (base[0] + along * axis[0], base[1] + along * axis[1]), angle, state)


def _place_weld(kin: Kinematics, placement: ir.Placement, state: _Placing) -> None:
    """The child's attachment at the parent's, at the weld's relative angle."""
    weld = kin.model.welds[placement.joint]
    parent, child, child_is_b = _sides(weld, placement)
    point, parent_angle = _placed(kin, parent, state)
    turn = kin.const(weld.angle)  # angle(b) - angle(a)
    _place_member(kin, child, point, parent_angle + turn if child_is_b else parent_angle - turn,
                  state)


def _place_free(kin: Kinematics, placement: ir.Placement, state: _Placing) -> None:
    """Member b's point at (x, y) from member a's in a's frame, turned by `angle` from a: the
    free joint's three values (x and y only when it moves a particle)."""
    free = kin.model.free_joints[placement.joint]
    parent, child, child_is_b = _sides(free, placement)
    values = [_joint_value(kin, f"{free.name}.{name}", free.initial[2 * k],
                           free.initial[2 * k + 1], free.held[k], state)
              for k, name in enumerate(("x", "y", "angle")[:3 if free.turns else 2])]
    turn = values[2] if free.turns else sympy.Integer(0)  # angle(b) - angle(a)
    point, parent_angle = _placed(kin, parent, state)
    angle_a = parent_angle if child_is_b else parent_angle - turn
    offset = rotate(angle_a, (values[0], values[1]))  # r_b - r_a, world frame
    sign = 1 if child_is_b else -1
    _place_member(kin, child, (point[0] + sign * offset[0], point[1] + sign * offset[1]),
                  angle_a + turn if child_is_b else angle_a, state)


def _place_member(kin: Kinematics, attachment: ir.Attachment, point: Vector,
                  angle: sympy.Expr, state: _Placing) -> None:
    """Place a member so that `attachment` is at world `point` and the member at `angle` (a
    particle has no angle: it goes to `point`)."""
    member = attachment.member
    symbols = kin.member_symbols(member)
    if member.kind is ir.MemberKind.PARTICLE:
        state.place(symbols, point)
        return
    if member.kind is ir.MemberKind.BODY:
        offset = rotate(angle, kin.local_point(member, attachment.point))
        state.place(symbols, (point[0] - offset[0], point[1] - offset[1], angle))
        return
    # an undeformed straight beam: its angle is the same at both ends
    start = point
    if kin.beam_end(member, attachment.point) == "b":
        length = kin.const(kin.model.beams[member.index].length)
        start = (point[0] - length * sympy.cos(angle), point[1] - length * sympy.sin(angle))
    element = kin.beams[member.index]
    state.place(symbols, element.initial_coordinates(start[0], start[1], angle))
    state.beam_angles[member.index] = angle


def _place_at_origin(kin: Kinematics, member: ir.Member, state: _Placing) -> None:
    """Start a member not yet placed (the root of a floating tree) at the origin, angle 0."""
    if member.kind is ir.MemberKind.GROUND or kin.member_symbols(member)[0] in state.local:
        return
    zero = sympy.Integer(0)
    if member.kind is ir.MemberKind.BODY:
        state.place(kin.member_symbols(member), (zero, zero, zero))
    elif member.kind is ir.MemberKind.PARTICLE:
        state.place(kin.member_symbols(member), (zero, zero))
    else:
        _place_member(kin, ir.Attachment(member, "a", None), (zero, zero), zero, state)
