"""One straight beam element: cubic Hermite shape integrals and the corotational strains.

The element joins node i (s = 0) to node j (s = l). Each node carries four inertial coordinates
(x, y, dx/ds, dy/ds), so the element has eight, ordered (node i, node j). The position field is

    r(xi) = N1 r_i + l N2 r'_i + N3 r_j + l N4 r'_j,        xi = s / l in [0, 1]

with the cubic Hermite functions N1..N4; every integral the beam needs reduces to the
dimensionless matrices of `hermite_integrals` (see docs/beams.md for the derivation).

The elastic energy is measured in the element's own chord frame (origin at node i, x along
r_j - r_i): a frame fixed by two points of the body, as the paper prescribes, one per element.
`element_strains` gives the five deformation measures w of that frame, and the energy is
exactly V = 1/2 w^T K w with the constant `element_stiffness` K. `Element` hands out the
energy, its gradient and the damping of one element, derived once and reused by substitution.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import sympy

NodeCoordinates = tuple[sympy.Expr, sympy.Expr, sympy.Expr, sympy.Expr]  # x, y, dx/ds, dy/ds

# Positions of the five deformation measures in w.
THETA_I, THETA_J, STRETCH_I, MEAN_STRAIN, STRETCH_J = range(5)
STRAIN_NAMES = ("theta_i", "theta_j", "stretch_i", "mean_strain", "stretch_j")


@dataclass(frozen=True)
class HermiteIntegrals:
    """Integrals over xi in [0, 1] of the cubic Hermite functions N = (N1, N2, N3, N4).

    mass = int N N^T, slope = int N' N'^T, curvature = int N'' N''^T (4x4, primes d/dxi),
    mean = int N (4). The slope functions N2, N4 are the ones multiplied by l.
    """

    mass: sympy.ImmutableMatrix
    slope: sympy.ImmutableMatrix
    curvature: sympy.ImmutableMatrix
    mean: tuple[sympy.Rational, ...]


@lru_cache(maxsize=None)
def hermite_integrals() -> HermiteIntegrals:
    """The exact rational integrals (computed once; e.g. mass = [[156, 22, 54, -13], ...]/420)."""
    xi = sympy.Symbol("xi")
    shapes = sympy.Matrix([1 - 3 * xi**2 + 2 * xi**3, xi - 2 * xi**2 + xi**3,
                           3 * xi**2 - 2 * xi**3, -xi**2 + xi**3])

    def integral(matrix: sympy.Matrix) -> sympy.ImmutableMatrix:
        return sympy.ImmutableMatrix(matrix.applyfunc(lambda f: sympy.integrate(f, (xi, 0, 1))))

    first, second = shapes.diff(xi), shapes.diff(xi, 2)
    return HermiteIntegrals(
        mass=integral(shapes * shapes.T),
        slope=integral(first * first.T),
        curvature=integral(second * second.T),
        mean=tuple(integral(shapes)),
    )


def element_mass(mass_per_length: sympy.Expr, length: sympy.Expr) -> sympy.Matrix:
    """Consistent mass matrix rho A int S^T S ds of one element (8x8, element coordinate order).

    The same 4x4 Hermite matrix acts on the x and on the y coordinates; it is constant because
    the coordinates are inertial and the interpolation is linear in them.
    """
    scale = (1, length, 1, length)  # r_i, l r'_i, r_j, l r'_j
    hermite = hermite_integrals().mass
    mass = sympy.zeros(8, 8)
    for a in range(4):
        for b in range(4):
            entry = mass_per_length * length * scale[a] * scale[b] * hermite[a, b]
            for axis in range(2):
                mass[2 * a + axis, 2 * b + axis] = entry
    return mass


def element_gravity_energy(node_i: NodeCoordinates, node_j: NodeCoordinates,
                           mass_per_length: sympy.Expr, length: sympy.Expr,
                           gx: sympy.Expr, gy: sympy.Expr) -> sympy.Expr:
    """-rho A int g . r ds of one element (J); (gx, gy) is the gravity acceleration (m/s^2)."""
    mean = hermite_integrals().mean
    terms = ((node_i[0], node_i[1], mean[0]), (node_i[2], node_i[3], length * mean[1]),
             (node_j[0], node_j[1], mean[2]), (node_j[2], node_j[3], length * mean[3]))
    return -mass_per_length * length * sum(w * (gx * x + gy * y) for x, y, w in terms)


def element_strains(node_i: NodeCoordinates, node_j: NodeCoordinates,
                    length: sympy.Expr) -> tuple[sympy.Expr, ...]:
    """The deformation w of the element joining node_i to node_j (rest length l), in its chord
    frame, as exact functions of the coordinates (order of STRAIN_NAMES):

    theta_i, theta_j: transverse slopes dY/ds of the nodes in the chord frame (rad, small);
    stretch_i, stretch_j: |r'| - 1 at the nodes (the axial strain there);
    mean_strain: (arc length - l) / l with the shallow-arch arc length
        |r_j - r_i| + 1/2 int (dY/ds)^2 ds, which carries the geometric stiffening under tension.
    """
    xi, yi, dxi, dyi = node_i
    xj, yj, dxj, dyj = node_j
    cx, cy = xj - xi, yj - yi
    chord = sympy.sqrt(cx**2 + cy**2)
    # the node slope vectors resolved on the chord normal (e_z x chord / |chord|)
    theta_i = (cx * dyi - cy * dxi) / chord
    theta_j = (cx * dyj - cy * dxj) / chord
    slope = hermite_integrals().slope
    # int (dY/ds)^2 ds / l, Y the local Hermite deflection with Y(0) = Y(l) = 0
    arc_excess = (slope[1, 1] * theta_i**2 + 2 * slope[1, 3] * theta_i * theta_j
                  + slope[3, 3] * theta_j**2)
    mean_strain = (chord - length) / length + arc_excess / 2
    stretch_i = sympy.sqrt(dxi**2 + dyi**2) - 1
    stretch_j = sympy.sqrt(dxj**2 + dyj**2) - 1
    return (theta_i, theta_j, stretch_i, mean_strain, stretch_j)


def element_stiffness(EI: sympy.Expr, EA: sympy.Expr, length: sympy.Expr) -> sympy.Matrix:
    """The constant 5x5 K with element energy V = 1/2 w^T K w (w in STRAIN_NAMES order).

    Bending: EI/2 int Y''^2 ds with Y Hermite through (0, theta_i, 0, theta_j).
    Axial: EA/2 int u'^2 ds with u the cubic through u(0) = 0, u'(0) = stretch_i,
    u(l) = l * mean_strain, u'(l) = stretch_j: the quadratic strain field with those nodal
    values and that mean, so an inextensible bent element stores no axial energy.
    """
    h = hermite_integrals()
    stiffness = sympy.zeros(5, 5)
    bending = ((THETA_I, 1), (THETA_J, 3))  # (index in w, Hermite function)
    for a, ha in bending:
        for b, hb in bending:
            stiffness[a, b] = EI / length * h.curvature[ha, hb]
    axial = ((STRETCH_I, 1), (MEAN_STRAIN, 2), (STRETCH_J, 3))
    for a, ha in axial:
        for b, hb in axial:
            stiffness[a, b] = EA * length * h.slope[ha, hb]
    return stiffness


def quadratic_form(matrix: sympy.Matrix, vector: tuple[sympy.Expr, ...]) -> sympy.Expr:
    """1/2 v^T A v for symmetric A, written term by term without expanding v."""
    n = len(vector)
    terms = [matrix[a, a] * vector[a]**2 / 2 for a in range(n) if matrix[a, a] != 0]
    terms += [matrix[a, b] * vector[a] * vector[b]
              for a in range(n) for b in range(a + 1, n) if matrix[a, b] != 0]
    return sympy.Add(*terms)


@dataclass(frozen=True)
class _Template:
    """Every expression of one element, derived once for placeholder symbols. sympy's diff is
    the slow part of a derivation; each element reuses these by substitution."""

    coordinates: tuple[sympy.Symbol, ...]  # 8
    rates: tuple[sympy.Symbol, ...]  # 8
    material: tuple[sympy.Symbol, ...]  # l, EI, EA, beta
    strains: tuple[sympy.Expr, ...]  # w
    energy: sympy.Expr  # 1/2 w^T K w
    force: tuple[sympy.Expr, ...]  # -J^T K w, J = dw/dq_e
    stiffness: tuple[tuple[sympy.Expr, ...], ...]  # 8x8 J^T K J
    damping_force: tuple[sympy.Expr, ...]  # -beta J^T K J qd_e
    damping_power: sympy.Expr  # beta (J qd_e)^T K (J qd_e)


@lru_cache(maxsize=None)
def _template() -> _Template:
    coordinates = tuple(sympy.Dummy(f"q{k}", real=True) for k in range(8))
    rates = tuple(sympy.Dummy(f"qd{k}", real=True) for k in range(8))
    length, EI, EA, beta = (sympy.Dummy(name, positive=True) for name in ("l", "EI", "EA", "b"))
    strains = element_strains(coordinates[:4], coordinates[4:], length)
    stiffness = element_stiffness(EI, EA, length)
    jacobian = sympy.Matrix(strains).jacobian(coordinates)
    strain_rates = tuple(jacobian * sympy.Matrix(rates))
    return _Template(
        coordinates, rates, (length, EI, EA, beta), strains,
        energy=quadratic_form(stiffness, strains),
        force=tuple(-jacobian.T * (stiffness * sympy.Matrix(strains))),
        stiffness=tuple(tuple(row) for row in (jacobian.T * stiffness * jacobian).tolist()),
        damping_force=tuple(-beta * jacobian.T * (stiffness * sympy.Matrix(strain_rates))),
        damping_power=2 * beta * quadratic_form(stiffness, strain_rates),
    )


@dataclass(frozen=True)
class Element:
    """One element of a beam: its eight coordinates (node i then node j, each x, y, dx, dy),
    rest length l (m), EI (N*m^2) and EA (N). Forces are on the eight coordinates."""

    coordinates: tuple[sympy.Expr, ...]
    length: sympy.Expr
    EI: sympy.Expr
    EA: sympy.Expr

    def _substitute(self, expressions: tuple[sympy.Expr, ...], rates: Sequence[sympy.Expr] = (),
                    beta: sympy.Expr | None = None) -> tuple[sympy.Expr, ...]:
        """The template's expressions for this element (and rates qd_e, damping beta)."""
        template = _template()
        substitution = dict(zip(template.coordinates, self.coordinates))
        substitution |= dict(zip(template.rates, rates))
        material = (self.length, self.EI, self.EA) + ((beta,) if beta is not None else ())
        substitution |= dict(zip(template.material, material))
        return tuple(e.xreplace(substitution) for e in expressions)

    def strains(self) -> tuple[sympy.Expr, ...]:
        """w, in the order of STRAIN_NAMES."""
        return self._substitute(_template().strains)

    def energy(self) -> sympy.Expr:
        """Elastic energy 1/2 w^T K w (J)."""
        return self._substitute((_template().energy,))[0]

    def force(self) -> tuple[sympy.Expr, ...]:
        """-dV/dq_e (8), the exact gradient of `energy`."""
        return self._substitute(_template().force)

    def stiffness(self) -> tuple[tuple[sympy.Expr, ...], ...]:
        """J^T K J (8x8, N/m on positions), J = dw/dq_e: the Hessian of `energy` less its
        term in the strains themselves (w^T K d^2w/dq^2, of the order of the strains), so
        symmetric positive semi-definite in every pose. The linearly implicit step takes it
        as the elastic force's Jacobian -df/dq; the damping's d f/d qd is exactly -beta times
        it."""
        rows = _template().stiffness
        flat = self._substitute(tuple(e for row in rows for e in row))
        return tuple(flat[8 * a:8 * a + 8] for a in range(8))

    def damping_force(self, rates: Sequence[sympy.Expr],
                      beta: sympy.Expr) -> tuple[sympy.Expr, ...]:
        """Stiffness-proportional damping -beta J^T K wdot (8), wdot = J qd_e, beta in s."""
        return self._substitute(_template().damping_force, rates, beta)

    def damping_power(self, rates: Sequence[sympy.Expr], beta: sympy.Expr) -> sympy.Expr:
        """Power the damping removes, beta wdot^T K wdot >= 0 (W)."""
        return self._substitute((_template().damping_power,), rates, beta)[0]
