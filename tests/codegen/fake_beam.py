"""A stand-in for codegen/beam.py implementing the agreed beam-element interface, so that the
beam paths of derive (layout, assembly, gravity, damping, beam outputs) are tested without the
real element. Nodes n0..nE carry (x, y); axial springs per element, bending springs on the
angle between consecutive elements, lumped mass."""

from __future__ import annotations

import sympy

from depsim.dsl import ir


def coordinate_count(beam: ir.Beam) -> int:
    return 2 * (beam.elements + 1)


class FakeBeam:
    def __init__(self, beam: ir.Beam, q, to_sym):
        self.n = beam.elements
        self.q = list(q)
        self.length = to_sym(beam.length)
        self.le = self.length / self.n
        self.EI, self.EA, self.rho = to_sym(beam.EI), to_sym(beam.EA), to_sym(beam.mass_per_length)
        self.damping = to_sym(beam.damping) if beam.damping is not None else 0
        self.coordinate_names = tuple(f"n{i}.{c}" for i in range(self.n + 1) for c in "xy")
        lumped = [self.rho * self.le * (sympy.Rational(1, 2) if i in (0, self.n) else 1)
                  for i in range(self.n + 1)]
        self.masses = lumped
        self.mass_matrix = sympy.diag(*[m for m in lumped for _ in "xy"])
        self.elastic_energy = self._elastic()

    def coordinate_sizes(self, length):
        return tuple(length for _ in self.q)  # every coordinate a position

    def node(self, i):
        return self.q[2 * i], self.q[2 * i + 1]

    def segment(self, i):
        (x0, y0), (x1, y1) = self.node(i), self.node(i + 1)
        return x1 - x0, y1 - y0

    def _elastic(self):
        energy = 0
        for i in range(self.n):
            dx, dy = self.segment(i)
            energy += self.EA / (2 * self.le) * (sympy.sqrt(dx**2 + dy**2) - self.le) ** 2
        for i in range(self.n - 1):
            (ax, ay), (bx, by) = self.segment(i), self.segment(i + 1)
            bend = sympy.atan2(ax * by - ay * bx, ax * bx + ay * by)
            energy += self.EI / (2 * self.le) * bend**2
        return energy

    def gravity_energy(self, gx, gy):
        return -sum(m * (gx * self.node(i)[0] + gy * self.node(i)[1])
                    for i, m in enumerate(self.masses))

    def end_position(self, end):
        return self.node(0 if end == "a" else self.n)

    def end_angle(self, end, near=None):
        dx, dy = self.segment(0 if end == "a" else self.n - 1)
        return _angle(dx, dy, near)

    def chord_angle(self, near=None):
        (xa, ya), (xb, yb) = self.node(0), self.node(self.n)
        return _angle(xb - xa, yb - ya, near)

    def tip_deflection(self):
        (xa, ya), (xb, yb) = self.node(0), self.node(self.n)
        dx, dy = self.segment(0)
        return (dx * (yb - ya) - dy * (xb - xa)) / sympy.sqrt(dx**2 + dy**2)

    def initial_coordinates(self, x_a, y_a, angle):
        c, s = sympy.cos(angle), sympy.sin(angle)
        step = self.le
        return [v for i in range(self.n + 1) for v in (x_a + i * step * c, y_a + i * step * s)]

    def damping_force(self, qd):
        return -self.damping * sympy.Matrix(qd)


def beam_element(beam: ir.Beam, q, to_sym) -> FakeBeam:
    return FakeBeam(beam, q, to_sym)


def _angle(vx, vy, near):
    if near is None:
        return sympy.atan2(vy, vx)
    c, s = sympy.cos(near), sympy.sin(near)
    return near + sympy.atan2(c * vy - s * vx, c * vx + s * vy)
