"""Positions, angles and rates of the model's members in terms of the coordinates q.

`Kinematics` is the scope in which state expressions (outputs) are converted, and the source of
every geometric quantity derive needs: attachment points, member angles, hinge angles, slider
displacements, spring lengths. Rigid bodies use (x, y, phi) of the centre of mass, particles
(x, y) (their angle is 0, as the ground's); beams delegate to the beam element
(codegen/beam.py). Loads and the system's quantities in outputs come from `OutputScope`
(codegen/system.py)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy

from depsim.dsl import ir
from depsim.dsl.attributes import SPECS

from .errors import CodegenError
from .expr import ConstantScope, to_sympy

Vector = tuple[sympy.Expr, sympy.Expr]


@dataclass(frozen=True)
class Coordinates:
    """The ordered symbols of a model: q, q', p and t, with q's names."""

    names: tuple[str, ...]
    q: tuple[sympy.Symbol, ...]
    qd: tuple[sympy.Symbol, ...]
    p: tuple[sympy.Symbol, ...]
    t: sympy.Symbol
    beam_q: tuple[tuple[sympy.Symbol, ...], ...]  # each beam's slice of q


def core_sliders(model: ir.Model) -> tuple[int, ...]:
    """The sliders the integrator treats as hinges along their axes: those with an attribute
    it applies itself (a column of hinge_properties other than slip_rate: friction, a latch,
    a stop, a hold-down). Each is one more entry of the hinge tables, after the hinges, its
    coordinate its displacement s (m) (docs/language.md, slider)."""
    columns = [spec.name for spec in SPECS["slider"]
               if spec.column is not None and spec.name != "slip_rate"]
    return tuple(index for index, slider in enumerate(model.sliders)
                 if any(getattr(slider, name) is not None for name in columns))


def rotate(angle: sympy.Expr, vector: Vector) -> Vector:
    """The plane vector rotated counter-clockwise by angle."""
    c, s = sympy.cos(angle), sympy.sin(angle)
    return (c * vector[0] - s * vector[1], s * vector[0] + c * vector[1])


class Kinematics:
    """Member geometry as sympy expressions of q (and p); also the scope of output expressions."""

    def __init__(self, model: ir.Model, symbols: Coordinates, beams: tuple[Any, ...],
                 beam_angles: tuple[sympy.Expr, ...] | None = None):
        self.model = model
        self.symbols = symbols
        self.p, self.t = symbols.p, symbols.t
        self.beams = beams  # one BeamSymbolic per model beam
        # Each beam's initial (undeformed) angle: beam angles are measured near it, so that
        # they do not jump by 2 pi where atan2 would (set once the assembly is known).
        self.beam_angles = beam_angles
        self._rate_of = dict(zip(symbols.q, symbols.qd))
        self._constant_scope = ConstantScope(symbols.p, symbols.t)

    def const(self, expr: ir.Expr) -> sympy.Expr:
        """A constant (parameter-only) IR expression as sympy."""
        return to_sympy(expr, self._constant_scope)

    def body_symbols(self, body: int) -> tuple[sympy.Symbol, ...]:
        """(x, y, phi) of rigid body `body`."""
        return self.symbols.q[3 * body: 3 * body + 3]

    def particle_symbols(self, particle: int) -> tuple[sympy.Symbol, ...]:
        """(x, y) of particle `particle` (after the bodies' coordinates)."""
        start = 3 * len(self.model.bodies) + 2 * particle
        return self.symbols.q[start: start + 2]

    def member_symbols(self, member: ir.Member) -> tuple[sympy.Symbol, ...]:
        """The coordinates of a rigid body, a particle or a beam."""
        if member.kind is ir.MemberKind.BODY:
            return self.body_symbols(member.index)
        if member.kind is ir.MemberKind.PARTICLE:
            return self.particle_symbols(member.index)
        assert member.kind is ir.MemberKind.BEAM, "the ground has no coordinates"
        return self.symbols.beam_q[member.index]

    def rate(self, expr: sympy.Expr) -> sympy.Expr:
        """Time derivative of a function of q (not of t): (d expr/dq) q'."""
        present = expr.free_symbols
        return sympy.Add(*(expr.diff(s) * self._rate_of[s] for s in self.symbols.q if s in present))

    # -- members ---------------------------------------------------------------------------

    def local_point(self, member: ir.Member, name: str) -> Vector:
        """A point of the ground (world frame) or of a rigid body or particle (body frame,
        from the CM; `cm` is (0, 0))."""
        zero = sympy.Integer(0)
        if member.kind is ir.MemberKind.PARTICLE or (
                member.kind is ir.MemberKind.BODY and name == "cm"):
            if name == "cm":
                return (zero, zero)
            raise CodegenError("E904", f"'{self.member_name(member)}' has no point '{name}'",
                               self.model.particles[member.index].span)
        element = self.model.ground if member.kind is ir.MemberKind.GROUND \
            else self.model.bodies[member.index]
        for point in element.points:
            if point.name == name:
                return (self.const(point.x), self.const(point.y))
        if member.kind is ir.MemberKind.GROUND and name == "origin":
            return (sympy.Integer(0), sympy.Integer(0))
        if member.kind is ir.MemberKind.BODY and element.kind == "bar" and name in ("a", "b"):
            half = self.const(element.length) / 2
            return (-half if name == "a" else half, sympy.Integer(0))
        raise CodegenError("E904", f"'{self.member_name(member)}' has no point '{name}'",
                           getattr(element, "span", None))

    def member_name(self, member: ir.Member) -> str:
        """The member's name in the model text."""
        if member.kind is ir.MemberKind.GROUND:
            return "ground"
        elements = {ir.MemberKind.BODY: self.model.bodies, ir.MemberKind.BEAM: self.model.beams,
                    ir.MemberKind.PARTICLE: self.model.particles}[member.kind]
        return elements[member.index].name

    def point_position(self, member: ir.Member, name: str) -> Vector:
        """World position of a named point of a member."""
        if member.kind is ir.MemberKind.BEAM:
            return tuple(self.beams[member.index].end_position(self.beam_end(member, name)))
        local = self.local_point(member, name)
        if member.kind is ir.MemberKind.GROUND:
            return local
        if member.kind is ir.MemberKind.PARTICLE:
            return tuple(self.particle_symbols(member.index))
        x, y, phi = self.body_symbols(member.index)
        offset = rotate(phi, local)
        return (x + offset[0], y + offset[1])

    def angle(self, member: ir.Member, point: str) -> sympy.Expr:
        """Angle of a member from +x at one of its points (a beam's tangent at an end); 0 for
        the ground and a particle."""
        if member.kind in (ir.MemberKind.GROUND, ir.MemberKind.PARTICLE):
            return sympy.Integer(0)
        if member.kind is ir.MemberKind.BODY:
            return self.body_symbols(member.index)[2]
        return self.beams[member.index].end_angle(self.beam_end(member, point),
                                                  near=self._beam_angle(member.index))

    def _beam_angle(self, index: int) -> sympy.Expr | None:
        return None if self.beam_angles is None else self.beam_angles[index]

    def beam_end(self, member: ir.Member, point: str) -> str:
        """The end ("a" or "b") a beam point names; any other point is an error."""
        if point not in ("a", "b"):
            beam = self.model.beams[member.index]
            raise CodegenError("E903", f"beam '{beam.name}' has no point '{point}'", beam.span,
                               "joints attach to a beam at its ends 'a' and 'b'")
        return point

    # -- joints ----------------------------------------------------------------------------

    def attachment_angle(self, attachment: ir.Attachment) -> sympy.Expr:
        """Angle of the attached member at the attachment point."""
        return self.angle(attachment.member, attachment.point)

    def attachment_position(self, attachment: ir.Attachment) -> Vector:
        """World position of the attachment point."""
        return self.point_position(attachment.member, attachment.point)

    def hinge_theta(self, index: int) -> sympy.Expr:
        """Hinge angle theta = sign (angle(b) - angle(a)) + offset (rad)."""
        hinge = self.model.hinges[index]
        relative = self.attachment_angle(hinge.b) - self.attachment_angle(hinge.a)
        return hinge.sign * relative + self.const(hinge.offset)

    def slider_unit_axis(self, index: int) -> Vector:
        """The slider's unit axis in member a's frame."""
        ax, ay = (self.const(component) for component in self.model.sliders[index].axis)
        norm = sympy.sqrt(ax**2 + ay**2)
        return (ax / norm, ay / norm)

    def slider_axis(self, index: int) -> Vector:
        """The slider's unit axis in the world frame (fixed in member a)."""
        slider = self.model.sliders[index]
        return rotate(self.attachment_angle(slider.a), self.slider_unit_axis(index))

    def slider_offset(self, index: int) -> Vector:
        """r_b - r_a of the slider's two attachment points."""
        slider = self.model.sliders[index]
        ra, rb = self.attachment_position(slider.a), self.attachment_position(slider.b)
        return (rb[0] - ra[0], rb[1] - ra[1])

    def spring_offset(self, index: int) -> Vector:
        """r_b - r_a of a spring's two points."""
        spring = self.model.springs[index]
        ra, rb = self.attachment_position(spring.a), self.attachment_position(spring.b)
        return (rb[0] - ra[0], rb[1] - ra[1])

    def spring_length(self, index: int) -> sympy.Expr:
        """The distance between a spring's two points (m)."""
        dx, dy = self.spring_offset(index)
        return sympy.sqrt(dx**2 + dy**2)

    def slider_s(self, index: int) -> sympy.Expr:
        """Slider displacement s = axis . (r_b - r_a) (m)."""
        axis, offset = self.slider_axis(index), self.slider_offset(index)
        return axis[0] * offset[0] + axis[1] * offset[1]

    # -- the Scope protocol of expr.to_sympy (state references in outputs) ------------------

    def body_coord(self, body: int, coord: str) -> sympy.Expr:
        x, y, phi = self.body_symbols(body)
        position = {"x": x, "y": y, "phi": phi, "vx": x, "vy": y, "omega": phi}[coord]
        return self._rate_of[position] if coord in ("vx", "vy", "omega") else position

    def point_coord(self, member: ir.Member, point: str, axis: str) -> sympy.Expr:
        x, y = self.point_position(member, point)
        value = {"x": x, "y": y, "vx": x, "vy": y}[axis]
        return self.rate(value) if axis in ("vx", "vy") else value

    def hinge_angle(self, hinge: int, rate: bool) -> sympy.Expr:
        theta = self.hinge_theta(hinge)
        return self.rate(theta) if rate else theta

    def slider_position(self, slider: int, rate: bool) -> sympy.Expr:
        s = self.slider_s(slider)
        return self.rate(s) if rate else s

    def beam_quantity(self, beam: int, kind: str) -> sympy.Expr:
        element = self.beams[beam]
        if kind == "chord":
            return element.chord_angle(near=self._beam_angle(beam))
        assert kind == "tip_deflection", kind
        return element.tip_deflection()
