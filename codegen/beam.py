"""The flexible beam as a symbolic building block (seed section 3; docs/beams.md).

A beam of length L is cut into n equal straight elements joined at n + 1 nodes. Node k sits at
s = k L / n and carries four absolute (inertial) coordinates: its position (x, y) and its slope
vector (dx/ds, dy/ds), so the beam has 4 (n + 1) coordinates, named "<beam>.n<k>.<x|y|dx|dy>".
End a is node 0, end b is node n.

* Mass matrix: rho A int S^T S ds with cubic Hermite S in inertial coordinates, exactly constant,
  so the equations of motion have no Coriolis or centrifugal terms.
* Elastic energy: per element, from the deformation in the element's chord frame (a frame fixed
  by two points of the body), V_e = 1/2 w^T K w (codegen/beam_element.py); exactly invariant under
  rigid motion, and f = -dV/dq is its exact gradient, so free motion conserves energy.

Everything returned is a sympy expression in the beam's own coordinates q (and velocities qd)
and in parameter symbols; nothing here prints code.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import sympy

from depsim.codegen.beam_element import (Element, NodeCoordinates, element_gravity_energy,
                                         element_mass)
from depsim.dsl import ir

NODE_COORDINATES = ("x", "y", "dx", "dy")  # per node: position (m), slope vector d r / d s (-)


def coordinate_count(beam: ir.Beam) -> int:
    """Number of coordinates of the beam: 4 per node, elements + 1 nodes."""
    return len(NODE_COORDINATES) * (beam.elements + 1)


@dataclass(frozen=True)
class BeamSymbolic:
    """The symbolic beam: coordinates, constant mass matrix, energies and end quantities.

    Units: positions m, angles rad (from +x, counter-clockwise), energies J, forces N (and N*m
    on the slope coordinates, which are dimensionless).
    """

    coordinate_names: tuple[str, ...]
    mass_matrix: sympy.Matrix  # (4(n+1), 4(n+1)), depends on parameter symbols only
    elastic_energy: sympy.Expr  # J, function of q and p
    q: tuple[sympy.Symbol, ...]
    length: sympy.Expr  # m
    mass_per_length: sympy.Expr  # kg/m
    damping: sympy.Expr | None  # s, stiffness-proportional coefficient
    elements: tuple[Element, ...]

    def coordinate_sizes(self, length: sympy.Expr) -> tuple[sympy.Expr, ...]:
        """Per coordinate, the size its errors are measured against: `length` for a node's
        position, 1 for its slope vector (dimensionless)."""
        one = sympy.Integer(1)
        return tuple(length if c in ("x", "y") else one
                     for _ in range(len(self.q) // len(NODE_COORDINATES)) for c in NODE_COORDINATES)

    # -- nodes and ends ------------------------------------------------------------------------

    def node(self, k: int) -> NodeCoordinates:
        """(x, y, dx/ds, dy/ds) of node k (0 = end a, n = end b)."""
        return tuple(self.q[4 * k:4 * k + 4])

    def _end_node(self, end: str) -> NodeCoordinates:
        assert end in ("a", "b"), f"a beam end is 'a' or 'b', not {end!r}"
        return self.node(0 if end == "a" else len(self.elements))

    def end_position(self, end: str) -> tuple[sympy.Expr, sympy.Expr]:
        """World position (x, y) of end "a" (s = 0) or "b" (s = L) (m)."""
        x, y, _, _ = self._end_node(end)
        return (x, y)

    def end_direction(self, end: str) -> tuple[sympy.Expr, sympy.Expr]:
        """The slope vector d r / d s at an end (tangent, length 1 + axial strain)."""
        _, _, dx, dy = self._end_node(end)
        return (dx, dy)

    def end_angle(self, end: str, near: sympy.Expr | None = None) -> sympy.Expr:
        """Angle of the tangent at an end from +x (rad).

        atan2 jumps by 2 pi where the tangent points along -x. With `near` given, the result
        is near + (angle - near) wrapped to (-pi, pi], continuous for any tangent within pi of
        the direction `near`: pass the end's initial angle for hinge springs and outputs.
        """
        return _angle(*self.end_direction(end), near)

    def chord_angle(self, near: sympy.Expr | None = None) -> sympy.Expr:
        """Angle of the chord from end a to end b, from +x (rad); `near` as in end_angle."""
        (xa, ya), (xb, yb) = self.end_position("a"), self.end_position("b")
        return _angle(xb - xa, yb - ya, near)

    def tip_deflection(self) -> sympy.Expr:
        """e_z . (t_a x (r_b - r_a)) (m): signed distance of end b from the tangent line at a,
        counter-clockwise positive; t_a is the unit tangent at a (docs/beams.md)."""
        (xa, ya), (xb, yb) = self.end_position("a"), self.end_position("b")
        tx, ty = self.end_direction("a")
        return (tx * (yb - ya) - ty * (xb - xa)) / sympy.sqrt(tx**2 + ty**2)

    # -- initial state ---------------------------------------------------------------------------

    def initial_coordinates(self, x_a: sympy.Expr, y_a: sympy.Expr,
                            angle: sympy.Expr) -> list[sympy.Expr]:
        """q of the undeformed straight beam with end a at (x_a, y_a) (m), pointing at `angle`."""
        c, s = sympy.cos(angle), sympy.sin(angle)
        spacing = self.length / len(self.elements)
        coordinates: list[sympy.Expr] = []
        for k in range(len(self.elements) + 1):
            coordinates += [x_a + k * spacing * c, y_a + k * spacing * s, c, s]
        return coordinates

    def initial_velocities(self, vx_a: sympy.Expr, vy_a: sympy.Expr, angle: sympy.Expr,
                           rate: sympy.Expr) -> list[sympy.Expr]:
        """qd of the undeformed straight beam at `angle` moving rigidly: end a at (vx_a, vy_a)
        (m/s), turning at `rate` (rad/s, counter-clockwise)."""
        c, s = sympy.cos(angle), sympy.sin(angle)
        spacing = self.length / len(self.elements)
        velocities: list[sympy.Expr] = []
        for k in range(len(self.elements) + 1):
            velocities += [vx_a - rate * k * spacing * s, vy_a + rate * k * spacing * c,
                           -rate * s, rate * c]
        return velocities

    # -- forces and energies -------------------------------------------------------------------

    def gravity_energy(self, gx: sympy.Expr, gy: sympy.Expr) -> sympy.Expr:
        """-int rho A g . r ds (J) for gravity acceleration (gx, gy) (m/s^2); exact for the
        cubic interpolation."""
        spacing = self.length / len(self.elements)
        return sympy.Add(*(element_gravity_energy(self.node(k), self.node(k + 1),
                                                  self.mass_per_length, spacing, gx, gy)
                           for k in range(len(self.elements))))

    def elastic_force(self) -> sympy.Matrix:
        """-dV/dq of the elastic energy (column; N on positions, N*m on slopes), assembled
        element by element. Identical to differentiating `elastic_energy`, much faster."""
        return self._assemble(element.force() for element in self.elements)

    def stiffness(self) -> dict[tuple[int, int], sympy.Expr]:
        """The elastic stiffness J^T K J (Element.stiffness) assembled element by element:
        (row, column) in the beam's coordinates -> entry, row-major; N/m on positions."""
        total: dict[tuple[int, int], list[sympy.Expr]] = {}
        for k, element in enumerate(self.elements):
            for a, row in enumerate(element.stiffness()):
                for b, value in enumerate(row):
                    if value != 0:
                        total.setdefault((4 * k + a, 4 * k + b), []).append(value)
        return {place: sympy.Add(*terms) for place, terms in sorted(total.items())}

    def damping_force(self, qd: Sequence[sympy.Symbol]) -> sympy.Matrix:
        """Stiffness-proportional damping -beta J^T K J qd per element (column), beta =
        beam.damping (s), J = dw/dq of the element deformation; zeros if the beam has none.
        Rigid motion is never damped."""
        if self.damping is None:
            return sympy.zeros(len(self.q), 1)
        return self._assemble(element.damping_force(self._element_rates(k, qd), self.damping)
                              for k, element in enumerate(self.elements))

    def damping_power(self, qd: Sequence[sympy.Symbol]) -> sympy.Expr:
        """Power removed by the damping, -qd . damping_force >= 0 (W); 0 without damping."""
        if self.damping is None:
            return sympy.Integer(0)
        return sympy.Add(*(element.damping_power(self._element_rates(k, qd), self.damping)
                           for k, element in enumerate(self.elements)))

    def _element_rates(self, k: int, qd: Sequence[sympy.Symbol]) -> tuple[sympy.Symbol, ...]:
        assert len(qd) == len(self.q), "one rate per beam coordinate"
        return tuple(qd[4 * k:4 * k + 8])

    def _assemble(self, element_vectors: Iterable[tuple[sympy.Expr, ...]]) -> sympy.Matrix:
        """Sum per-element 8-vectors into a beam column; element k starts at coordinate 4k."""
        total = [[] for _ in self.q]
        for k, local in enumerate(element_vectors):
            for a, value in enumerate(local):
                total[4 * k + a].append(value)
        return sympy.Matrix([sympy.Add(*terms) for terms in total])


def _angle(vx: sympy.Expr, vy: sympy.Expr, near: sympy.Expr | None) -> sympy.Expr:
    """Angle of the vector (vx, vy) from +x; measured from direction `near` when given."""
    if near is None:
        return sympy.atan2(vy, vx)
    c, s = sympy.cos(near), sympy.sin(near)
    return near + sympy.atan2(c * vy - s * vx, c * vx + s * vy)


def beam_element(beam: ir.Beam, q: list[sympy.Symbol],
                 to_sym: Callable[[ir.Expr], sympy.Expr]) -> BeamSymbolic:
    """Derive the symbolic beam from its IR, its coordinate symbols q (coordinate_count(beam)
    of them, in the order of the returned coordinate_names) and a converter of IR expressions
    to sympy expressions of the parameter symbols."""
    n = beam.elements
    assert n >= 1, "the checker guarantees at least one element"
    assert len(q) == coordinate_count(beam), "one symbol per beam coordinate"
    length, mass_per_length = to_sym(beam.length), to_sym(beam.mass_per_length)
    EI, EA = to_sym(beam.EI), to_sym(beam.EA)
    spacing = length / n
    elements = tuple(Element(tuple(q[4 * k:4 * k + 8]), spacing, EI, EA) for k in range(n))
    mass = sympy.zeros(len(q), len(q))
    block = element_mass(mass_per_length, spacing)
    for k in range(n):
        mass[4 * k:4 * k + 8, 4 * k:4 * k + 8] += block
    energy = sympy.Add(*(element.energy() for element in elements))
    names = tuple(f"{beam.name}.n{k}.{c}" for k in range(n + 1) for c in NODE_COORDINATES)
    damping = to_sym(beam.damping) if beam.damping is not None else None
    return BeamSymbolic(names, mass, energy, tuple(q), length, mass_per_length, damping,
                        elements)
