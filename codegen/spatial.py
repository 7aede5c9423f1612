"""Spatial models: member geometry in 3-D as sympy expressions of q (docs/method.md, 12).

A rigid body's coordinates are its centre of mass (x, y, z) and the nine entries of its
rotation matrix R (body frame to world, row by row: R11, R12, ..., R33), so a body point at
rho (body frame) is at r + R rho, linear in q. The kinetic energy is then

    T = m |r'|^2 / 2 + sum_i R'_i J R'_i^T / 2,   J = integral rho rho^T dm = tr(I)/2 - I,

(R'_i the i-th row of R', I the inertia tensor about the centre of mass in the body frame): the
mass matrix is constant, diag(m, m, m) and one block J per row of R, as the integrator's core
needs it. R stays a rotation through six rows per body, R^T R = 1 (columns of unit length and
orthogonal), which the iteration handles like any joint's. J is positive definite exactly when
the principal moments satisfy the strict triangle inequality (the checker's range check). A
particle has (x, y, z).

Joints: a hinge holds its points together (rows x, y, z) and its axis a (member A's frame,
unit) parallel to the same axis fixed in B (rows axis_1, axis_2: R_B a_B normal to two unit
vectors e, f of A normal to a). A member's `orientation` is its frame's in the world when
every hinge is at zero, so at the hinge angle theta

    R_B = R_A Rot(a, sign (theta - offset)) R0,   R0 = O_A^T O_B (the orientations),

and theta is measured by the turn of e about a, within half a turn of the middle of its
travel (codegen/spatial_assembly.py, hinge_turns: the angle does not jump where atan2
would). A weld holds R_B = R_A R0 (rows rx, ry, rz), a ball
joint its points only. A cylindrical joint holds a hinge's axis rows and, instead of its point
rows, the offset of B's point from A's normal to the axis (a slider's rows normal_1,
normal_2); a universal joint holds the points and its cross-piece, R_A a . R_B b = 0 (row
cross), and turns by angle_a about a, then angle_b about b:

    R_B = R_A Rot(a, angle_a) Rot(R0 b, angle_b) R0."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import sympy

from depsim.dsl import ir

from .errors import CodegenError
from .expr import ConstantScope, to_sympy
from .kinematics import Coordinates

Vector3 = tuple[sympy.Expr, sympy.Expr, sympy.Expr]

BODY_COORDINATES = ("x", "y", "z") + tuple(f"R{i}{j}" for i in "123" for j in "123")
PARTICLE_COORDINATES = ("x", "y", "z")
# The columns of a spatial model's system_state(q, qd, p) (depsim.runtime.interface).
SYSTEM_STATE = ("mass", "com_x", "com_y", "com_z", "momentum_x", "momentum_y", "momentum_z",
                "angular_momentum_x", "angular_momentum_y", "angular_momentum_z")
_AXES = {"x": 0, "y": 1, "z": 2}


def turn(axis: str, angle: sympy.Expr) -> sympy.Matrix:
    """The right-handed rotation by `angle` about the named axis."""
    c, s = sympy.cos(angle), sympy.sin(angle)
    k = _AXES[axis]
    i, j = (k + 1) % 3, (k + 2) % 3
    matrix = sympy.eye(3)
    matrix[i, i], matrix[i, j], matrix[j, i], matrix[j, j] = c, -s, s, c
    return matrix


def rotation_about(axis: Vector3, angle: sympy.Expr) -> sympy.Matrix:
    """Rodrigues: the rotation by `angle` about the unit vector `axis`."""
    a = sympy.Matrix(axis)
    cross = sympy.Matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return sympy.cos(angle) * sympy.eye(3) + sympy.sin(angle) * cross \
        + (1 - sympy.cos(angle)) * a * a.T


def dot(u, v) -> sympy.Expr:
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def cross(u, v) -> Vector3:
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def turn_between(u: Vector3, w: Vector3, n: Vector3) -> sympy.Expr:
    """The turn (rad, within half a turn) that takes u to w about n, all normal to the unit
    n: atan2((u x w) . n, u . w)."""
    return sympy.atan2(dot(cross(u, w), n), dot(u, w))


def unit(vector) -> Vector3:
    norm = sympy.sqrt(dot(vector, vector))
    return tuple(component / norm for component in vector)


def times(matrix: sympy.Matrix, vector) -> Vector3:
    """matrix . vector as a tuple."""
    return tuple(sympy.Add(*(matrix[i, j] * vector[j] for j in range(3))) for i in range(3))


def normal_pair(axis: Vector3, defaults: Vector3) -> tuple[Vector3, Vector3]:
    """Two unit vectors e, f = a x e normal to the unit `axis` and to each other: e from the
    world axis least along `axis` at the default parameters (`defaults`, the axis's value)."""
    k = min(range(3), key=lambda i: abs(defaults[i]))
    basis = tuple(sympy.Integer(int(i == k)) for i in range(3))
    e = unit(cross(axis, basis))
    return e, cross(axis, e)


@dataclass(frozen=True)
class HingeFrame:
    """A spatial hinge's geometry, constant in its members' frames: the unit axis a and the
    normal e, f in A's frame, the same axis and e in B's (a_b = R0^T a), and R0."""

    axis: Vector3
    e: Vector3
    f: Vector3
    axis_b: Vector3
    e_b: Vector3
    relative: sympy.Matrix  # R0 = O_A^T O_B


class SpatialKinematics:
    """Member geometry of a spatial model as sympy expressions of q (and p); the scope of
    output expressions (the expr.Scope protocol, as Kinematics for planar models)."""

    def __init__(self, model: ir.Model, symbols: Coordinates,
                 hinge_turns: tuple[sympy.Expr, ...] | None = None):
        self.model = model
        self.symbols = symbols
        self.p, self.t = symbols.p, symbols.t
        self.beams = ()
        # each hinge's turn at t = 0 (rad, an expression of p): its angle is measured within
        # half a turn of it (set once the assembly is known)
        self.hinge_turns = hinge_turns
        self._rate_of = dict(zip(symbols.q, symbols.qd))
        self._constant_scope = ConstantScope(symbols.p, symbols.t)
        self._frames: dict[int, HingeFrame] = {}
        # Constant geometry (unit axes, relative orientations: functions of p) stands as
        # named symbols while derive differentiates, and is put back at the end
        # (`constants`): the expressions of q stay small.
        self.constants: dict[sympy.Symbol, sympy.Expr] = {}
        self._resolved: dict[sympy.Symbol, sympy.Expr] = {}  # resolved(), the first ones
        # each hinge's vectors, S, C and their rates named (hinge_derivatives): groups of
        # steps of q, qd and the constants
        self.hinge_steps: dict[int, tuple[tuple[tuple[sympy.Symbol, sympy.Expr], ...], ...]] = {}

    def named(self, name: str, value: sympy.Expr) -> sympy.Expr:
        """`value` (a function of p) as the symbol `@name`, or itself when a number."""
        if value.is_number:
            return value
        symbol = sympy.Symbol(f"@{name}")
        if self.constants.setdefault(symbol, value) != value:  # named again as another value
            self.constants[symbol] = value
            self._resolved.clear()
        return symbol

    def _named_vector(self, name: str, vector) -> Vector3:
        return tuple(self.named(f"{name}_{axis}", value) for axis, value in zip("xyz", vector))

    def const(self, expr: ir.Expr) -> sympy.Expr:
        """A constant (parameter-only) IR expression as sympy."""
        return to_sympy(expr, self._constant_scope)

    def rate(self, expr: sympy.Expr) -> sympy.Expr:
        """Time derivative of a function of q (not of t): (d expr/dq) q'."""
        present = expr.free_symbols
        return sympy.Add(*(expr.diff(s) * self._rate_of[s] for s in self.symbols.q
                           if s in present))

    # -- coordinates -----------------------------------------------------------------------

    def body_symbols(self, body: int) -> tuple[sympy.Symbol, ...]:
        """(x, y, z, R11, ..., R33) of rigid body `body`."""
        return self.symbols.q[12 * body: 12 * body + 12]

    def particle_symbols(self, particle: int) -> tuple[sympy.Symbol, ...]:
        start = 12 * len(self.model.bodies) + 3 * particle
        return self.symbols.q[start: start + 3]

    def member_symbols(self, member: ir.Member) -> tuple[sympy.Symbol, ...]:
        if member.kind is ir.MemberKind.BODY:
            return self.body_symbols(member.index)
        assert member.kind is ir.MemberKind.PARTICLE, "the ground has no coordinates"
        return self.particle_symbols(member.index)

    def rotation(self, member: ir.Member) -> sympy.Matrix:
        """R of a body (body frame to world); the identity for the ground."""
        if member.kind is ir.MemberKind.GROUND:
            return sympy.eye(3)
        assert member.kind is ir.MemberKind.BODY, "a particle has no orientation"
        return sympy.Matrix(3, 3, self.body_symbols(member.index)[3:])

    def orientation(self, member: ir.Member) -> sympy.Matrix:
        """The member's orientation when every hinge is at zero (a function of p)."""
        if member.kind is not ir.MemberKind.BODY:
            return sympy.eye(3)
        return self.turns(self.model.bodies[member.index].orientation)

    def turns(self, turns: tuple[ir.Turn, ...]) -> sympy.Matrix:
        result = sympy.eye(3)
        for factor in turns:
            result = result * turn(factor.axis, self.const(factor.angle))
        return result

    def second_moment(self, body: ir.Body) -> sympy.Matrix:
        """J = integral rho rho^T dm = tr(I)/2 - I in the body frame (ir.Body: I from the
        principal moments along principal_axes, or from the moments and products)."""
        moments = [self.const(value) for value in body.principal]
        if body.products is not None:
            pxy, pyz, pzx = (self.const(value) for value in body.products)
            inertia = sympy.Matrix([[moments[0], -pxy, -pzx], [-pxy, moments[1], -pyz],
                                    [-pzx, -pyz, moments[2]]])
        else:
            axes = self.turns(body.principal_axes)
            inertia = axes * sympy.diag(*moments) * axes.T
        return sympy.Add(*moments) / 2 * sympy.eye(3) - inertia

    # -- points ----------------------------------------------------------------------------

    def member_name(self, member: ir.Member) -> str:
        if member.kind is ir.MemberKind.GROUND:
            return "ground"
        elements = self.model.bodies if member.kind is ir.MemberKind.BODY \
            else self.model.particles
        return elements[member.index].name

    def local_point(self, member: ir.Member, name: str) -> Vector3:
        """A point of the ground (world frame) or of a body (body frame, from its centre of
        mass)."""
        zero = sympy.Integer(0)
        if name == "cm" and member.kind is not ir.MemberKind.GROUND:
            return (zero, zero, zero)
        if member.kind is ir.MemberKind.GROUND and name == "origin":
            return (zero, zero, zero)
        element = self.model.ground if member.kind is ir.MemberKind.GROUND \
            else self.model.bodies[member.index]
        for point in getattr(element, "points", ()):
            if point.name == name:
                return (self.const(point.x), self.const(point.y), self.const(point.z))
        raise CodegenError("E904", f"'{self.member_name(member)}' has no point '{name}'",
                           getattr(element, "span", None))

    def point_position(self, member: ir.Member, name: str) -> Vector3:
        """World position of a named point of a member."""
        local = self.local_point(member, name)
        if member.kind is ir.MemberKind.GROUND:
            return local
        if member.kind is ir.MemberKind.PARTICLE:
            return tuple(self.particle_symbols(member.index))
        x, y, z = self.body_symbols(member.index)[:3]
        offset = times(self.rotation(member), local)
        return (x + offset[0], y + offset[1], z + offset[2])

    def attachment_position(self, attachment: ir.Attachment) -> Vector3:
        return self.point_position(attachment.member, attachment.point)

    # -- joints ----------------------------------------------------------------------------

    def relative_orientation(self, a: ir.Member, b: ir.Member) -> sympy.Matrix:
        """R0 = O_A^T O_B: B's frame in A's when the joint between them is at zero (named)."""
        relative = self.orientation(a).T * self.orientation(b)
        prefix = f"{self.member_name(a)}.{self.member_name(b)}.R0"
        return sympy.Matrix(3, 3, lambda i, j: self.named(f"{prefix}_{i + 1}{j + 1}",
                                                          relative[i, j]))

    def resolved(self) -> dict[sympy.Symbol, sympy.Expr]:
        """Each named constant as an expression of p alone (a name's value may use earlier
        names); those resolved before are kept (every hinge asks: resolving all names
        again each time would grow as the square of the hinges)."""
        found = self._resolved
        for symbol, value in list(self.constants.items())[len(found):]:
            found[symbol] = value.xreplace(found)
        return found

    def hinge_frame(self, index: int) -> HingeFrame:
        if index not in self._frames:
            hinge = self.model.hinges[index]
            name = hinge.name
            raw = tuple(self.const(component) for component in hinge.axis)
            defaults = tuple(float(value.xreplace(self._defaults())) for value in raw)
            axis = self._named_vector(f"{name}.axis", unit(raw))
            e, f = normal_pair(axis, defaults)
            e, f = self._named_vector(f"{name}.e", e), self._named_vector(f"{name}.f", f)
            relative = self.relative_orientation(hinge.a.member, hinge.b.member)
            self._frames[index] = HingeFrame(
                axis, e, f, self._named_vector(f"{name}.axis_b", times(relative.T, axis)),
                self._named_vector(f"{name}.e_b", times(relative.T, e)), relative)
        return self._frames[index]

    def _defaults(self) -> dict:
        return {symbol: param.default for symbol, param in zip(self.p, self.model.params)}

    def hinge_rows(self, index: int) -> tuple[sympy.Expr, sympy.Expr]:
        """The two rows holding a hinge's axis: (R_B a_b) . (R_A e), (R_B a_b) . (R_A f)."""
        hinge, frame = self.model.hinges[index], self.hinge_frame(index)
        ra, rb = self.rotation(hinge.a.member), self.rotation(hinge.b.member)
        axis_b = times(rb, frame.axis_b)
        return dot(axis_b, times(ra, frame.e)), dot(axis_b, times(ra, frame.f))

    def hinge_turn_parts(self, index: int, near: sympy.Expr) -> tuple[sympy.Expr, sympy.Expr]:
        """(S, C): the turn of B relative to A about the axis is near + atan2(S, C) (S, C
        bilinear in q). It is measured between a unit vector s_A normal to the axis fixed in
        A and one, s_B, fixed in B, each along its member's largest second moment in the
        plane normal to the axis at the default parameters (`_measuring_turns`): a hinge
        force's direction then moves no member along its thin direction, whose small moment
        would make the explicit step stiff (a panel's thickness). With (C0 + i S0) the pair of
        u = R_A s_A and w = R_B s_B, (C + i S) = (C0 + i S0) e^(-i delta), delta = near -
        beta, beta the angle from s_B's reference to s_A about the axis."""
        hinge = self.model.hinges[index]
        s_a, s_b, axis, turned = self._turn_vectors(index, near)
        ra, rb = self.rotation(hinge.a.member), self.rotation(hinge.b.member)
        u, w, n = times(ra, s_a), times(rb, s_b), times(ra, axis)
        return turned(dot(cross(u, w), n), dot(u, w))

    def _turn_vectors(self, index: int, near: sympy.Expr):
        """s_A and the axis a (A's frame), s_B (B's frame; both named) of hinge_turn_parts, and
        (S0, C0) -> (S, C), the turn by -delta."""
        hinge, frame = self.model.hinges[index], self.hinge_frame(index)
        t_a, t_b = self._measuring_turns(index)
        s_a = tuple(math.cos(t_a) * e + math.sin(t_a) * f for e, f in zip(frame.e, frame.f))
        s_b = times(frame.relative.T, tuple(math.cos(t_b) * e + math.sin(t_b) * f
                                            for e, f in zip(frame.e, frame.f)))
        s_a = self._named_vector(f"{hinge.name}.s_a", s_a)
        s_b = self._named_vector(f"{hinge.name}.s_b", s_b)
        delta = near - (t_a - t_b)
        c, s = self.named(f"{hinge.name}.cos_delta", sympy.cos(delta)), \
            self.named(f"{hinge.name}.sin_delta", sympy.sin(delta))

        def turned(sine: sympy.Expr, cosine: sympy.Expr) -> tuple[sympy.Expr, sympy.Expr]:
            return sine * c - cosine * s, cosine * c + sine * s

        return s_a, s_b, frame.axis, turned

    def _measuring_turns(self, index: int) -> tuple[float, float]:
        """(t_A, t_B): the directions cos t e + sin t f (A's frame) of s_A and of s_B (B's,
        mapped by R0) that minimise s^T J^-1 s of their member at the default parameters
        (the largest second moment normal to the axis); 0 for the ground or a particle."""
        hinge, frame = self.model.hinges[index], self.hinge_frame(index)
        defaults = self._defaults()
        resolved = self.resolved()

        def value(expr) -> float:
            return float(expr.xreplace(resolved).xreplace(defaults))

        e = np.array([value(x) for x in frame.e])
        f = np.array([value(x) for x in frame.f])
        relative = np.array([[value(frame.relative[i, j]) for j in range(3)]
                             for i in range(3)])

        def best(member: ir.Member, turn: np.ndarray) -> float:
            if member.kind is not ir.MemberKind.BODY:
                return 0.0
            second = self.second_moment(self.model.bodies[member.index])
            inverse = np.linalg.inv(np.array([[value(second[i, j]) for j in range(3)]
                                              for i in range(3)]))
            basis = turn @ np.stack([e, f], axis=1)  # the plane, in the member's frame
            form = basis.T @ inverse @ basis
            vector = np.linalg.eigh(form)[1][:, 0]
            return float(math.atan2(vector[1], vector[0]))

        t_b = best(hinge.b.member, relative.T)
        t_a = best(hinge.a.member, np.eye(3)) if hinge.a.member.kind is ir.MemberKind.BODY \
            else t_b
        return t_a, t_b

    def hinge_raw_turn(self, index: int, near: sympy.Expr) -> sympy.Expr:
        """The turn of B relative to A about the axis (rad), within half a turn of `near`."""
        sine, cosine = self.hinge_turn_parts(index, near)
        return near + sympy.atan2(sine, cosine)

    def hinge_near(self, index: int) -> sympy.Expr:
        return self.hinge_turns[index] if self.hinge_turns is not None else sympy.Integer(0)

    def hinge_theta(self, index: int) -> sympy.Expr:
        """Hinge angle theta = sign turn + offset (rad)."""
        hinge = self.model.hinges[index]
        return hinge.sign * self.hinge_raw_turn(index, self.hinge_near(index)) \
            + self.const(hinge.offset)

    def axis_frame(self, name: str, direction: tuple[ir.Expr, ...]
                   ) -> tuple[Vector3, Vector3, Vector3]:
        """A joint's unit axis a (from the IR direction) and two unit normals e, f (named
        NAME.axis, NAME.e, NAME.f), in the frame the direction is given in."""
        raw = tuple(self.const(component) for component in direction)
        defaults = tuple(float(value.xreplace(self._defaults())) for value in raw)
        axis = self._named_vector(f"{name}.axis", unit(raw))
        e, f = normal_pair(axis, defaults)
        return axis, self._named_vector(f"{name}.e", e), self._named_vector(f"{name}.f", f)

    def _rotation_rate(self, member: ir.Member) -> sympy.Matrix:
        """R' of a body (the rates of its rotation matrix's entries); zero for the ground."""
        if member.kind is ir.MemberKind.GROUND:
            return sympy.zeros(3, 3)
        return self.rotation(member).applyfunc(lambda s: self._rate_of[s])

    def slider_frame(self, index: int) -> tuple[Vector3, Vector3, Vector3]:
        """A slider's unit axis a and two unit normals e, f in member A's frame (named)."""
        slider = self.model.sliders[index]
        return self.axis_frame(slider.name, slider.axis)

    # -- cylindrical and universal joints ----------------------------------------------------

    def cylindrical_parts(self, index: int) -> dict[str, Vector3]:
        """A cylindrical joint's vectors in the world: its axis a, normals e, f (fixed in A),
        the axis and e fixed in B (a_B, e_B: R_B R0^T a, R_B R0^T e) and d = r_b - r_a."""
        joint = self.model.cylindricals[index]
        axis, e, f = self.axis_frame(joint.name, joint.axis)
        relative = self.relative_orientation(joint.a.member, joint.b.member)
        ra, rb = self.rotation(joint.a.member), self.rotation(joint.b.member)
        axis_b = self._named_vector(f"{joint.name}.axis_b", times(relative.T, axis))
        e_b = self._named_vector(f"{joint.name}.e_b", times(relative.T, e))
        start, end = self.attachment_position(joint.a), self.attachment_position(joint.b)
        return dict(a=times(ra, axis), e=times(ra, e), f=times(ra, f), a_b=times(rb, axis_b),
                    e_b=times(rb, e_b), d=tuple(y - x for x, y in zip(start, end)))

    def cylindrical_rows(self, index: int) -> tuple[sympy.Expr, ...]:
        """normal_1, normal_2 (the offset normal to the axis), axis_1, axis_2 (the axis held
        in B, as a hinge's)."""
        v = self.cylindrical_parts(index)
        return dot(v["e"], v["d"]), dot(v["f"], v["d"]), dot(v["a_b"], v["e"]), \
            dot(v["a_b"], v["f"])

    def universal_parts(self, index: int) -> dict[str, Vector3]:
        """A universal joint's unit axes in the world: a (fixed in A), b (fixed in B), and
        where each would be from the other member with both angles zero: b_A = R_A R0 b,
        a_B = R_B R0^T a."""
        joint = self.model.universals[index]
        name = joint.name
        axis_a = self._named_vector(f"{name}.axis_a", unit(tuple(map(self.const, joint.axis_a))))
        axis_b = self._named_vector(f"{name}.axis_b", unit(tuple(map(self.const, joint.axis_b))))
        relative = self.relative_orientation(joint.a.member, joint.b.member)
        b_in_a = self._named_vector(f"{name}.b_in_a", times(relative, axis_b))
        a_in_b = self._named_vector(f"{name}.a_in_b", times(relative.T, axis_a))
        ra, rb = self.rotation(joint.a.member), self.rotation(joint.b.member)
        return dict(a=times(ra, axis_a), b=times(rb, axis_b), b_A=times(ra, b_in_a),
                    a_B=times(rb, a_in_b), axis_a=axis_a, b_in_a=b_in_a)

    def joint_value(self, kind: str, index: int, quantity: str) -> sympy.Expr | None:
        """A cylindrical joint's angle, rate, position, velocity; a universal joint's
        angle_a, rate_a, angle_b, rate_b; None for any other quantity (a load)."""
        if kind == "cylindrical" and quantity in ("angle", "rate"):
            v = self.cylindrical_parts(index)
            value = turn_between(v["e"], v["e_b"], v["a"])
        elif kind == "cylindrical" and quantity in ("position", "velocity"):
            v = self.cylindrical_parts(index)
            value = dot(v["a"], v["d"])
        elif kind == "universal" and quantity in ("angle_a", "rate_a"):
            v = self.universal_parts(index)
            value = turn_between(v["b_A"], v["b"], v["a"])
        elif kind == "universal" and quantity in ("angle_b", "rate_b"):
            v = self.universal_parts(index)
            value = -turn_between(v["a_B"], v["a"], v["b"])
        else:
            return None
        return self.rate(value) if quantity.startswith(("rate", "velocity")) else value

    def slider_offset(self, index: int) -> Vector3:
        """r_b - r_a of the slider's two attachment points (world frame)."""
        slider = self.model.sliders[index]
        ra, rb = self.attachment_position(slider.a), self.attachment_position(slider.b)
        return tuple(b - a for a, b in zip(ra, rb))

    def slider_s(self, index: int) -> sympy.Expr:
        """Slider displacement s = (R_A a) . (r_b - r_a) (m)."""
        axis = times(self.rotation(self.model.sliders[index].a.member),
                     self.slider_frame(index)[0])
        return dot(axis, self.slider_offset(index))

    def slider_rows(self, index: int) -> tuple[sympy.Expr, sympy.Expr]:
        """The offset normal to the axis: (R_A e) . (r_b - r_a), (R_A f) . (r_b - r_a)."""
        slider = self.model.sliders[index]
        _, e, f = self.slider_frame(index)
        rotation, offset = self.rotation(slider.a.member), self.slider_offset(index)
        return dot(times(rotation, e), offset), dot(times(rotation, f), offset)

    def slider_position(self, slider: int, rate: bool) -> sympy.Expr:
        s = self.slider_s(slider)
        return self.rate(s) if rate else s

    def weld_rows(self, index: int) -> tuple[sympy.Expr, sympy.Expr, sympy.Expr]:
        """R_B = R_A R0 as three rows: b3 . c2, b1 . c3, b2 . c1 (b_k the columns of R_B, c_k
        of R_A R0), zero there and each the first-order turn about x, y, z."""
        weld = self.model.welds[index]
        return self.turn_rows(weld.a.member, weld.b.member)

    def turn_rows(self, a: ir.Member, b: ir.Member) -> tuple[sympy.Expr, sympy.Expr, sympy.Expr]:
        """R_B = R_A R0 as three rows (weld_rows)."""
        target = self.rotation(a) * self.relative_orientation(a, b)
        actual = self.rotation(b)
        b = [actual[:, k] for k in range(3)]
        c = [target[:, k] for k in range(3)]
        return dot(b[2], c[1]), dot(b[0], c[2]), dot(b[1], c[0])

    def spring_offset(self, index: int) -> Vector3:
        spring = self.model.springs[index]
        ra, rb = self.attachment_position(spring.a), self.attachment_position(spring.b)
        return tuple(b - a for a, b in zip(ra, rb))

    def spring_length(self, index: int) -> sympy.Expr:
        offset = self.spring_offset(index)
        return sympy.sqrt(dot(offset, offset))

    def reaction_moment(self, kind: str, index: int, lam: dict[str, sympy.Expr]) -> Vector3:
        """The moment on member B from member A about the joint's point (world frame, N m)
        that the joint's rows carry, with M q'' = f - Phi_q^T lambda: a hinge's axis rows
        give lambda_2 e - lambda_1 f (e, f its normals in the world; (a, e, f)
        right-handed), normal to its axis (the torque about the axis, a latch's or a stop's,
        is its `torque`); a weld's rows rx, ry, rz give the sum of lambda_k c_k (c_k the
        columns of R_A R0); a ball joint carries none; a universal joint's cross row, on B
        lambda (a x b); a cylindrical joint's axis rows as a hinge's (its normal rows act at
        B's point: no moment about it)."""
        zero = sympy.Integer(0)
        if kind == "ball":
            return (zero, zero, zero)
        if kind == "universal":  # the cross row a . b: on B, -lambda (b x a)
            v = self.universal_parts(index)
            return tuple(lam["cross"] * c for c in cross(v["a"], v["b"]))
        if kind == "cylindrical":  # the axis rows as a hinge's; the normal rows act at b's point
            v = self.cylindrical_parts(index)
            return tuple(lam["axis_2"] * e - lam["axis_1"] * f for e, f in zip(v["e"], v["f"]))
        if kind in ("weld", "slider"):  # rows rx, ry, rz (a slider's when B is a body)
            weld = self.model.welds[index] if kind == "weld" else self.model.sliders[index]
            if "rx" not in lam:
                return (zero, zero, zero)
            target = self.rotation(weld.a.member) \
                * self.relative_orientation(weld.a.member, weld.b.member)
            return tuple(sympy.Add(*(lam[f"r{axis}"] * target[i, k]
                                     for k, axis in enumerate("xyz"))) for i in range(3))
        hinge, frame = self.model.hinges[index], self.hinge_frame(index)
        rotation = self.rotation(hinge.a.member)
        e, f = times(rotation, frame.e), times(rotation, frame.f)
        return tuple(lam["axis_2"] * e[i] - lam["axis_1"] * f[i] for i in range(3))

    # -- the whole system ------------------------------------------------------------------

    def rigid_modes(self) -> tuple[list[list], list[list]]:
        """How each coordinate moves in a rigid motion of the whole system: per unit
        translation along x, y, z, and per radian of rotation about the world axes x, y, z
        through the origin (positions turn as e_k x r, a rotation matrix as [e_k]x R)."""
        one, zero = sympy.Integer(1), sympy.Integer(0)
        translations: list[list] = [[], [], []]
        rotations: list[list] = [[], [], []]
        for index in range(len(self.model.bodies)):
            symbols = self.body_symbols(index)
            position, matrix = symbols[:3], sympy.Matrix(3, 3, symbols[3:])
            for k in range(3):
                e = tuple(one if i == k else zero for i in range(3))
                translations[k] += [e[i] for i in range(3)] + [zero] * 9
                turned = sympy.Matrix(3, 3, lambda i, j: cross(e, matrix[:, j])[i])
                rotations[k] += list(cross(e, position)) + list(turned)
        for index in range(len(self.model.particles)):
            position = self.particle_symbols(index)
            for k in range(3):
                e = tuple(one if i == k else zero for i in range(3))
                translations[k] += list(e)
                rotations[k] += list(cross(e, position))
        return translations, rotations

    # -- the Scope protocol of expr.to_sympy (state references in outputs) ------------------

    def body_coord(self, body: int, coord: str) -> sympy.Expr:
        symbols = self.body_symbols(body)
        if coord in ("x", "y", "z"):
            return symbols[_AXES[coord]]
        if coord in ("vx", "vy", "vz"):
            return self._rate_of[symbols[_AXES[coord[1]]]]
        if coord.startswith("R"):
            return symbols[3 + 3 * (int(coord[1]) - 1) + int(coord[2]) - 1]
        # the world angular velocity: R' R^T = [w]x, taken by its skew part
        matrix = sympy.Matrix(3, 3, symbols[3:])
        rates = matrix.applyfunc(lambda s: self._rate_of[s])
        spin = rates * matrix.T
        i, j = {"wx": (2, 1), "wy": (0, 2), "wz": (1, 0)}[coord]
        return (spin[i, j] - spin[j, i]) / 2

    def point_coord(self, member: ir.Member, point: str, axis: str) -> sympy.Expr:
        position = self.point_position(member, point)
        value = position[_AXES[axis[-1]]]
        return self.rate(value) if axis.startswith("v") else value

    def hinge_angle(self, hinge: int, rate: bool) -> sympy.Expr:
        theta = self.hinge_theta(hinge)
        return self.rate(theta) if rate else theta


# -- the system's parts ------------------------------------------------------------------------

Row = tuple[str, str, int, int, sympy.Expr]  # name, joint, hinge (or -1), slider (-1), residual


def spatial_rows(model: ir.Model, kin: SpatialKinematics) -> list[Row]:
    """Every constraint row: each body's six (its rotation matrix's columns of unit length
    and orthogonal), then the hinges' (x, y, z: the reaction force; axis_1, axis_2), the
    welds' (x, y, z; rx, ry, rz between bodies), the ball joints' (x, y, z), the cylindrical
    joints' (normal_1, normal_2, axis_1, axis_2), the universal joints' (x, y, z, cross) and
    the sliders' (normal_1, normal_2: the offset normal to the axis; rx, ry, rz unless they
    move a particle). Only a hinge's force rows name it (its axis rows are its reaction torque
    normal to the axis)."""
    rows: list[Row] = []
    for index, body in enumerate(model.bodies):
        columns = [kin.rotation(ir.Member(ir.MemberKind.BODY, index))[:, k] for k in range(3)]
        for name, (i, j) in zip(("xx", "yy", "zz", "xy", "yz", "zx"),
                                ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0))):
            residual = dot(columns[i], columns[j]) - (1 if i == j else 0)
            rows.append((f"{body.name}.frame_{name}", body.name, -1, -1, residual))
    for index, hinge in enumerate(model.hinges):
        rows += _point_rows(kin, hinge, index)
        for k, residual in enumerate(kin.hinge_rows(index)):
            rows.append((f"{hinge.name}.axis_{k + 1}", hinge.name, -1, -1, residual))
    for index, weld in enumerate(model.welds):
        rows += _point_rows(kin, weld, -1)
        if weld.rotational:
            for name, residual in zip(("rx", "ry", "rz"), kin.weld_rows(index)):
                rows.append((f"{weld.name}.{name}", weld.name, -1, -1, residual))
    for ball in model.balls:
        rows += _point_rows(kin, ball, -1)
    for index, joint in enumerate(model.cylindricals):
        for name, residual in zip(("normal_1", "normal_2", "axis_1", "axis_2"),
                                  kin.cylindrical_rows(index)):
            rows.append((f"{joint.name}.{name}", joint.name, -1, -1, residual))
    for index, joint in enumerate(model.universals):
        rows += _point_rows(kin, joint, -1)
        parts = kin.universal_parts(index)
        rows.append((f"{joint.name}.cross", joint.name, -1, -1, dot(parts["a"], parts["b"])))
    for index, slider in enumerate(model.sliders):
        for name, residual in zip(("normal_1", "normal_2"), kin.slider_rows(index)):
            rows.append((f"{slider.name}.{name}", slider.name, -1, index, residual))
        if slider.b.member.kind is not ir.MemberKind.PARTICLE:
            turns = kin.turn_rows(slider.a.member, slider.b.member)
            for name, residual in zip(("rx", "ry", "rz"), turns):
                rows.append((f"{slider.name}.{name}", slider.name, -1, index, residual))
    return rows


def _point_rows(kin: SpatialKinematics, joint, hinge: int) -> list[Row]:
    ra, rb = kin.attachment_position(joint.a), kin.attachment_position(joint.b)
    return [(f"{joint.name}.{axis}", joint.name, hinge, -1, a - b)
            for axis, a, b in zip("xyz", ra, rb)]


def spatial_mass_matrix(model: ir.Model, kin: SpatialKinematics) -> sympy.ImmutableSparseMatrix:
    """Constant M: per body diag(m, m, m) and the block J for each row of R; per particle
    diag(m, m, m)."""
    entries, start = {}, 0
    for body in model.bodies:
        mass = kin.const(body.mass)
        for k in range(3):
            entries[(start + k, start + k)] = mass
        second = kin.second_moment(body)
        for row in range(3):
            base = start + 3 + 3 * row
            for i in range(3):
                for j in range(3):
                    if second[i, j] != 0:
                        entries[(base + i, base + j)] = second[i, j]
        start += 12
    for particle in model.particles:
        for k in range(3):
            entries[(start + k, start + k)] = kin.const(particle.mass)
        start += 3
    size = len(kin.symbols.q)
    return sympy.ImmutableSparseMatrix(size, size, entries)


def spatial_coordinate_scales(model: ir.Model, kin: SpatialKinematics) -> list[sympy.Expr]:
    """Per coordinate the size its errors are measured against (docs/method.md, 6a): the
    model's length for a position (a body's largest point distance or radius of gyration, a
    spring's free length), 1 for an entry of a rotation matrix."""
    sizes = []
    for body in model.bodies:
        if body.length is not None:
            sizes.append(kin.const(body.length))
        moments = [kin.const(value) for value in body.principal]
        sizes.append(sympy.sqrt(sympy.Max(*moments) / kin.const(body.mass)))
        sizes += [sympy.sqrt(kin.const(point.x) ** 2 + kin.const(point.y) ** 2
                             + kin.const(point.z) ** 2) for point in body.points]
    sizes += [kin.const(spring.free_length) for spring in model.springs
              if spring.free_length is not None]
    sizes = [size for size in sizes if size != 0]
    length = sympy.Max(*sizes) if sizes else sympy.Integer(1)
    one = sympy.Integer(1)
    return ([length] * 3 + [one] * 9) * len(model.bodies) \
        + [length] * 3 * len(model.particles)


def spatial_gravity(model: ir.Model, kin: SpatialKinematics) -> sympy.Expr:
    """V = -sum m g . r over bodies and particles."""
    g = [kin.const(component) for component in model.gravity]
    energy = sympy.Integer(0)
    for index, body in enumerate(model.bodies):
        energy -= kin.const(body.mass) * dot(g, kin.body_symbols(index)[:3])
    for index, particle in enumerate(model.particles):
        energy -= kin.const(particle.mass) * dot(g, kin.particle_symbols(index))
    return energy
