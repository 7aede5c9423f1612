"""The initial state: forward kinematics along Model.placements.

Members no joint path reaches from the ground (the checker warns, W001) start at the origin:
a body with its centre of mass there at angle 0, a beam with end a there along +x, at rest.
Each placement puts its child member so that the joint's two attachment points coincide (a
hinge, turned by its initial angle) or lie `initial_position` apart along the axis (a slider,
whose child keeps its parent's angle). Every joint's initial value enters as an auxiliary
symbol first, so that qd0 = sum_k (dq0/dvalue_k) rate_k; the symbols are then replaced by the
joints' initial values (expressions of p). Kept as symbols, they make the tree pose q(v) and its
Jacobian, from which the integrator core assembles closed loops (docs/language.md, Assembly)."""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from depsim.dsl import ir

from .kinematics import Kinematics, Vector, rotate

Pose = dict[sympy.Symbol, sympy.Expr]


@dataclass(frozen=True)
class Assembly:
    """The initial state as expressions of p: q0, qd0 (NQ each) and each beam's angle (rad);
    the tree joints (placement order) with their value symbols v, the pose q(v) over them,
    their initial values v0 and rates vd0 (expressions of p) and what the user gave (held)."""

    q0: tuple[sympy.Expr, ...]
    qd0: tuple[sympy.Expr, ...]
    beam_angles: tuple[sympy.Expr, ...]
    tree_joints: tuple[str, ...]
    v: tuple[sympy.Symbol, ...]
    pose: tuple[sympy.Expr, ...]
    tree_jacobian: tuple[tuple[sympy.Expr, ...], ...]  # (NQ, NV): d pose / d v
    v0: tuple[sympy.Expr, ...]
    vd0: tuple[sympy.Expr, ...]
    held: tuple[int, ...]


@dataclass
class _Placing:
    """The assembly so far: placed coordinates, beam angles, joint values -> (value, rate),
    and each placed coordinate's derivatives by the joint values (forward mode: a child's
    from its parent's by the chain rule, so a chain of n members costs O(n^2) products
    instead of O(n^2) derivatives of ever longer expressions)."""

    pose: Pose
    beam_angles: dict[int, sympy.Expr]
    values: dict[sympy.Symbol, tuple[sympy.Expr, sympy.Expr]]
    jacobian: dict[sympy.Symbol, dict[sympy.Symbol, sympy.Expr]]

    def place(self, symbol: sympy.Symbol, local: sympy.Expr) -> None:
        """Put coordinate `symbol` at `local`, an expression of placed coordinates and joint
        values: its pose and its derivatives by every joint value."""
        derivatives: dict[sympy.Symbol, sympy.Expr] = {}
        for s in local.free_symbols:
            if s not in self.values and s not in self.jacobian:
                continue  # a parameter
            partial = local.diff(s).xreplace(self.pose)
            inner = {s: sympy.Integer(1)} if s in self.values else self.jacobian[s]
            for v, d in inner.items():
                derivatives[v] = derivatives.get(v, sympy.Integer(0)) + partial * d
        self.pose[symbol] = local.xreplace(self.pose)
        self.jacobian[symbol] = {v: d for v, d in derivatives.items() if d != 0}


def assemble(model: ir.Model, kin: Kinematics) -> Assembly:
    """Pose, velocities and beam angles of the assembled initial state."""
    state = _Placing({}, {}, {}, {})
    for placement in model.placements:
        _place_at_origin(kin, placement.parent, state)
        if placement.kind is ir.JointKind.HINGE:
            _place_hinge(kin, model.hinges[placement.joint], placement, state)
        else:
            _place_slider(kin, placement, state)
    for index in range(len(model.bodies)):
        _place_at_origin(kin, ir.Member(ir.MemberKind.BODY, index), state)
    for index in range(len(model.beams)):
        _place_at_origin(kin, ir.Member(ir.MemberKind.BEAM, index), state)
    q0 = [state.pose[s] for s in kin.symbols.q]
    values = tuple(state.values)
    tree_jacobian = tuple(tuple(state.jacobian[s].get(v, sympy.Integer(0)) for v in values)
                          for s in kin.symbols.q)
    rates = [state.values[v][1] for v in values]
    qd0 = [sympy.Add(*(d * rate for d, rate in zip(row, rates) if rate != 0))  # (0 * d asks
           for row in tree_jacobian]                                           # sympy a lot)
    initial = {v: value for v, (value, _) in state.values.items()}
    angles = [state.beam_angles[i] for i in range(len(model.beams))]
    joints = [model.hinges[p.joint] if p.kind is ir.JointKind.HINGE else model.sliders[p.joint]
              for p in model.placements]
    return Assembly(*(tuple(x.xreplace(initial) for x in column) for column in (q0, qd0, angles)),
                    tree_joints=tuple(j.name for j in joints), v=values,
                    pose=tuple(q0), tree_jacobian=tree_jacobian, v0=tuple(value for value, _ in state.values.values()),
                    vd0=tuple(rate for _, rate in state.values.values()),
                    held=tuple(j.held for j in joints))


def _joint_value(kin: Kinematics, joint: ir.Hinge | ir.Slider, initial: ir.Expr,
                 state: _Placing) -> sympy.Symbol:
    """An auxiliary symbol standing for the joint's initial angle or displacement."""
    value = sympy.Symbol(f"{joint.name}@0")  # '@' keeps it apart from param names
    state.values[value] = (kin.const(initial), kin.const(joint.initial_rate))
    return value


def _sides(joint: ir.Hinge | ir.Slider, placement: ir.Placement):
    """(parent attachment, child attachment, True when the child is the joint's member b)."""
    if joint.b.member == placement.child:
        return joint.a, joint.b, True
    return joint.b, joint.a, False


def _placed(kin: Kinematics, attachment: ir.Attachment, state: _Placing):
    """(world position, angle) of an attachment of an already placed member, in its placed
    coordinates (a beam's angle in the joint values)."""
    position = tuple(kin.attachment_position(attachment))
    if attachment.member.kind is ir.MemberKind.BEAM:
        return position, state.beam_angles[attachment.member.index]
    return position, kin.attachment_angle(attachment)


def _place_hinge(kin: Kinematics, hinge: ir.Hinge, placement: ir.Placement,
                 state: _Placing) -> None:
    """The child's attachment at the parent's, turned so that theta = its initial angle."""
    parent, child, child_is_b = _sides(hinge, placement)
    theta = _joint_value(kin, hinge, hinge.initial_angle, state)
    point, parent_angle = _placed(kin, parent, state)
    turn = hinge.sign * (theta - kin.const(hinge.offset))  # angle(b) - angle(a)
    _place_member(kin, child, point, parent_angle + turn if child_is_b else parent_angle - turn,
                  state)


def _place_slider(kin: Kinematics, placement: ir.Placement, state: _Placing) -> None:
    """The child's attachment s along the axis from the parent's, at the parent's angle."""
    slider = kin.model.sliders[placement.joint]
    parent, child, child_is_b = _sides(slider, placement)
    s = _joint_value(kin, slider, slider.initial_position, state)
    base, angle = _placed(kin, parent, state)
    axis = rotate(angle, kin.slider_unit_axis(placement.joint))
    along = s if child_is_b else -s
    _place_member(kin, child, (base[0] + along * axis[0], base[1] + along * axis[1]), angle, state)


def _place_member(kin: Kinematics, attachment: ir.Attachment, point: Vector,
                  angle: sympy.Expr, state: _Placing) -> None:
    """Place a member so that `attachment` is at world `point` and the member at `angle`."""
    member = attachment.member
    symbols = kin.member_symbols(member)
    if member.kind is ir.MemberKind.BODY:
        offset = rotate(angle, kin.local_point(member, attachment.point))
        for symbol, local in zip(symbols, (point[0] - offset[0], point[1] - offset[1], angle)):
            state.place(symbol, local)
        return
    # an undeformed straight beam: its angle is the same at both ends
    start = point
    if kin.beam_end(member, attachment.point) == "b":
        length = kin.const(kin.model.beams[member.index].length)
        start = (point[0] - length * sympy.cos(angle), point[1] - length * sympy.sin(angle))
    element = kin.beams[member.index]
    for symbol, local in zip(symbols, element.initial_coordinates(start[0], start[1], angle)):
        state.place(symbol, local)
    state.beam_angles[member.index] = angle.xreplace(state.pose)


def _place_at_origin(kin: Kinematics, member: ir.Member, state: _Placing) -> None:
    """Start a member not yet placed (the root of a floating tree) at the origin, angle 0."""
    if member.kind is ir.MemberKind.GROUND or kin.member_symbols(member)[0] in state.pose:
        return
    zero = sympy.Integer(0)
    point = ir.Attachment(member, "a", None) if member.kind is ir.MemberKind.BEAM else None
    if point is None:
        for symbol in kin.member_symbols(member):
            state.place(symbol, zero)
    else:
        _place_member(kin, point, (zero, zero), zero, state)
