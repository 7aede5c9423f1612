"""The flexible beam element (codegen/beam.py) against beam theory, rigid-body mechanics and
energy conservation. The sympy output is evaluated through lambdify here (test only)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import pytest
import sympy
from scipy import integrate, linalg, optimize

from depsim.codegen import beam as beam_module
from depsim.dsl import ir

SPAN = ir.Span("test.dep", 1, 1, 1, 1)
# parameter vector of these tests: beam length, EI, EA, rho A, damping coefficient beta
PARAMS = sympy.symbols("L EI EA rhoA beta", positive=True)
# docs/examples.md, two flexible links link: L = 1 m, EI = 2e11 * 5e-9 N m^2, EA = 2e11 * 2.449e-4 N, 5 kg/m
M2 = (1.0, 1000.0, 2e11 * 2.449e-4, 5.0, 0.0)
# Euler-Bernoulli first roots: cantilever cos b cosh b = -1, free-free cos b cosh b = 1
CANTILEVER_ROOT = 1.8751040687119611
FREE_FREE_ROOT = 4.7300407448627040


def to_sym(expr: ir.Expr) -> sympy.Expr:
    match expr:
        case ir.Num(value):
            return sympy.Float(value)
        case ir.ParamRef(index):
            return PARAMS[index]
    raise AssertionError(f"unexpected expression {expr}")


def make_beam(elements: int, damping: bool = False, name: str = "link1") -> ir.Beam:
    refs = [ir.ParamRef(k) for k in range(5)]
    return ir.Beam(name, refs[0], refs[1], refs[2], refs[3], elements,
                   refs[4] if damping else None, SPAN)


@functools.lru_cache(maxsize=None)
def derive(elements: int, damping: bool = False) -> beam_module.BeamSymbolic:
    beam = make_beam(elements, damping)
    q = list(sympy.symbols(f"q0:{beam_module.coordinate_count(beam)}"))
    return beam_module.beam_element(beam, q, to_sym)


@dataclass
class Numeric:
    """The beam's sympy output at fixed parameter values, as numpy functions of q (and qd)."""

    symbolic: beam_module.BeamSymbolic
    mass: np.ndarray
    energy_fn: object
    force_fn: object
    n: int
    length: float

    def energy(self, q):
        return float(self.energy_fn(q))

    def force(self, q):
        return np.asarray(self.force_fn(q), dtype=np.result_type(q, float)).ravel()

    def stiffness(self, q):
        """Tangent stiffness -d force / d q by complex-step differentiation (exact to rounding)."""
        step = 1e-30
        columns = [self.force(q + 1j * step * unit) for unit in np.eye(len(q))]
        return -np.array(columns).imag.T / step

    def straight(self, angle=0.0, x_a=0.0, y_a=0.0):
        values = self.symbolic.initial_coordinates(x_a, y_a, angle)
        return np.array([float(v.subs(PARAMS[0], self.length)) for v in values])


@functools.lru_cache(maxsize=None)
def lambdified(elements: int) -> tuple:
    """Energy and force of `derive(elements)` as numpy functions of (q, params)."""
    symbolic = derive(elements)
    arguments = [sympy.Matrix(symbolic.q), sympy.Matrix(PARAMS)]
    return (sympy.lambdify(arguments, symbolic.elastic_energy, cse=True),
            sympy.lambdify(arguments, symbolic.elastic_force(), cse=True))


def numeric(elements: int, values: tuple[float, ...] = M2) -> Numeric:
    symbolic = derive(elements)
    energy, force = lambdified(elements)
    mass = np.array(symbolic.mass_matrix.xreplace(dict(zip(PARAMS, values))), dtype=float)
    return Numeric(symbolic, mass, lambda q: energy(q, values), lambda q: force(q, values),
                   elements, values[0])


def rigid_transform(q: np.ndarray, angle: float, shift: tuple[float, float]) -> np.ndarray:
    """Rotate every node position and slope by `angle`, then translate the positions."""
    c, s = math.cos(angle), math.sin(angle)
    nodes = q.reshape(-1, 4).copy()
    for columns, offset in (((0, 1), shift), ((2, 3), (0.0, 0.0))):
        x, y = nodes[:, columns[0]].copy(), nodes[:, columns[1]].copy()
        nodes[:, columns[0]] = c * x - s * y + offset[0]
        nodes[:, columns[1]] = s * x + c * y + offset[1]
    return nodes.ravel()


# -- layout ----------------------------------------------------------------------------------


def test_coordinate_layout():
    beam = make_beam(2)
    assert beam_module.coordinate_count(beam) == 12
    names = derive(2).coordinate_names
    assert names[:4] == ("link1.n0.x", "link1.n0.y", "link1.n0.dx", "link1.n0.dy")
    assert names[-1] == "link1.n2.dy" and len(set(names)) == 12


# -- mass ------------------------------------------------------------------------------------


def test_mass_matrix_is_constant_and_gives_rigid_body_inertia():
    symbolic = derive(3)
    L, rho_a = PARAMS[0], PARAMS[3]
    mass = symbolic.mass_matrix
    assert mass.free_symbols <= set(PARAMS) and mass == mass.T
    q_straight = sympy.Matrix(symbolic.initial_coordinates(0, 0, 0))  # along +x from 0 to L
    translate_x = sympy.Matrix([1, 0, 0, 0] * 4)
    translate_y = sympy.Matrix([0, 1, 0, 0] * 4)
    # turning at 1 rad/s about the centre (L/2, 0): node velocity (0, s - L/2), slope (0, 1)
    spin = sympy.Matrix([v for k in range(4) for v in (0, k * L / 3 - L / 2, 0, 1)])
    assert sympy.simplify((translate_x.T * mass * translate_x)[0] - rho_a * L) == 0
    assert sympy.simplify((translate_y.T * mass * translate_y)[0] - rho_a * L) == 0
    assert sympy.simplify((translate_x.T * mass * translate_y)[0]) == 0
    assert sympy.simplify((spin.T * mass * spin)[0] - rho_a * L**3 / 12) == 0
    assert sympy.simplify((spin.T * mass * translate_y)[0]) == 0  # centre of mass at L/2
    # first moment: translate_x^T M q = int rho A x ds = m x_c = rho A L * L/2
    assert sympy.simplify((translate_x.T * mass * q_straight)[0] - rho_a * L**2 / 2) == 0
    eigenvalues = np.linalg.eigvalsh(numeric(3).mass)
    assert eigenvalues.min() > 0


# -- elastic energy: invariance --------------------------------------------------------------


@pytest.mark.parametrize("angle", [0.0, 0.7, -math.pi / 2, math.pi, 2.9, -3.1])
def test_undeformed_beam_stores_no_energy_at_any_pose(angle):
    beam = numeric(4)
    q = beam.straight(angle, x_a=1.3, y_a=-0.4)
    assert abs(beam.energy(q)) < 1e-12
    assert np.abs(beam.force(q)).max() < 1e-6  # N; EA is 4.9e7 N, so this is rounding


def test_energy_is_invariant_and_force_covariant_under_rigid_motion():
    beam = numeric(4)
    rng = np.random.default_rng(1)
    deformed = beam.straight(0.3) + 1e-3 * rng.standard_normal(20)
    energy, force = beam.energy(deformed), beam.force(deformed)
    assert energy > 1.0
    for angle, shift in ((1.1, (0.5, 2.0)), (math.pi, (-3.0, 0.1)), (-2.5, (0.0, 0.0))):
        moved = rigid_transform(deformed, angle, shift)
        assert beam.energy(moved) == pytest.approx(energy, rel=1e-9)
        rotated_force = rigid_transform(force, angle, (0.0, 0.0))
        assert np.allclose(beam.force(moved), rotated_force, rtol=1e-8,
                           atol=1e-6 * abs(force).max())


def test_energy_is_invariant_symbolically_for_one_element():
    symbolic = derive(1)
    angle, x_a, y_a = sympy.symbols("angle x_a y_a", real=True)
    straight = dict(zip(symbolic.q, symbolic.initial_coordinates(x_a, y_a, angle)))
    for strain in symbolic.elements[0].strains():
        assert sympy.simplify(strain.xreplace(straight)) == 0


def test_elastic_force_is_the_gradient_of_the_energy():
    symbolic = derive(2)
    at = dict(zip(PARAMS, M2))
    gradient = sympy.Matrix([symbolic.elastic_energy.diff(x) for x in symbolic.q])
    both = sympy.lambdify([sympy.Matrix(symbolic.q)],
                          [(-gradient).subs(at), symbolic.elastic_force().subs(at)])
    q = numeric(2).straight(0.4) + 1e-3 * np.random.default_rng(2).standard_normal(12)
    expected, found = (np.asarray(v, dtype=float).ravel() for v in both(q))
    assert np.allclose(found, expected, rtol=1e-10, atol=1e-8)


# -- statics ---------------------------------------------------------------------------------


def equilibrium(beam: Numeric, fixed: list[int], external: np.ndarray,
                steps: int = 1) -> np.ndarray:
    """Static equilibrium force(q) + external = 0 from the straight beam along +x, coordinates
    `fixed` held at their straight values; Newton on the others, the dead load in steps."""
    q = beam.straight()
    free = np.setdiff1d(np.arange(len(q)), fixed)
    for step in range(1, steps + 1):
        for _ in range(30):
            residual = (beam.force(q) + external * step / steps)[free]
            if np.abs(residual).max() < 1e-6 * max(1.0, np.abs(external).max()):  # EA * 1e-15
                break
            q[free] += np.linalg.solve(beam.stiffness(q)[np.ix_(free, free)], residual)
        else:
            raise AssertionError("Newton did not converge")
    return q


def clamped_equilibrium(beam: Numeric, tip_load: float, steps: int = 1) -> np.ndarray:
    """Cantilever clamped at node 0 (position and slope), vertical dead load at the tip node."""
    external = np.zeros(4 * (beam.n + 1))
    external[4 * beam.n + 1] = tip_load
    return equilibrium(beam, [0, 1, 2, 3], external, steps)


@pytest.mark.parametrize("elements", [2, 8])
def test_cantilever_small_tip_load_matches_beam_theory(elements):
    L, EI = M2[0], M2[1]
    load = -3.0  # N, tip deflection P L^3 / 3EI = 1 mm
    q = clamped_equilibrium(numeric(elements), load)
    tip = q[4 * elements:]
    assert tip[1] == pytest.approx(load * L**3 / (3 * EI), rel=1e-3)
    assert math.atan2(tip[3], tip[2]) == pytest.approx(load * L**2 / (2 * EI), rel=1e-3)
    assert tip[0] == pytest.approx(L, abs=1e-5)


def elastica_tip(load_parameter: float) -> tuple[float, float]:
    """Tip (x, y)/L of an inextensible cantilever under a vertical dead load, PL^2/EI given,
    by shooting on theta'' = -k cos(theta), theta(0) = 0, theta'(1) = 0 (independent check)."""

    def shoot(curvature0):
        def rhs(s, y):
            return [y[1], -load_parameter * math.cos(y[0]), math.cos(y[0]), math.sin(y[0])]
        run = integrate.solve_ivp(rhs, (0, 1), [0, curvature0, 0, 0], rtol=1e-12, atol=1e-12)
        return run.y[:, -1]

    curvature0 = optimize.brentq(lambda k: shoot(k)[1], 0.0, load_parameter)
    _, _, x, y = shoot(curvature0)
    return x, y


def test_cantilever_large_deflection_matches_the_elastica():
    beam = numeric(16)
    L, EI = M2[0], M2[1]
    q = clamped_equilibrium(beam, -1.0 * EI / L**2, steps=8)  # P L^2 / EI = 1: 30 % deflection
    x_ref, y_ref = elastica_tip(1.0)
    assert y_ref == pytest.approx(0.30172, abs=1e-4)  # Bisshopp & Drucker (1945)
    assert -q[-3] / L == pytest.approx(y_ref, rel=5e-3)
    assert q[-4] / L == pytest.approx(x_ref, rel=5e-3)


# -- vibration -------------------------------------------------------------------------------


def bending_frequencies(elements: int, clamped: bool) -> np.ndarray:
    """Natural frequencies (Hz) of the linearisation about the straight beam."""
    beam = numeric(elements)
    q = beam.straight()
    keep = np.arange(4 if clamped else 0, len(q))
    stiffness = beam.stiffness(q)[np.ix_(keep, keep)]
    eigenvalues = linalg.eigh(stiffness, beam.mass[np.ix_(keep, keep)], eigvals_only=True)
    return np.sqrt(np.clip(eigenvalues, 0.0, None)) / (2 * math.pi)


def analytic_frequency(root: float) -> float:
    L, EI, _, rho_a, _ = M2
    return root**2 * math.sqrt(EI / (rho_a * L**4)) / (2 * math.pi)


@pytest.mark.parametrize("elements", [2, 8])
def test_first_cantilever_frequency(elements):
    found = bending_frequencies(elements, clamped=True)[0]
    assert found == pytest.approx(analytic_frequency(CANTILEVER_ROOT), rel=1e-2)


def test_free_free_beam_has_three_rigid_modes_then_first_bending():
    frequencies = bending_frequencies(8, clamped=False)
    first = analytic_frequency(FREE_FREE_ROOT)
    assert np.all(frequencies[:3] < 1e-4 * first)
    assert frequencies[3] == pytest.approx(first, rel=1e-2)


def test_tension_stiffens_bending_as_for_a_string_beam():
    """Pinned at node 0, on a roller at node n, pulled by T along the axis: the first mode is
    (pi/L)^2 sqrt(EI/rho A) sqrt(1 + T L^2 / (pi^2 EI)) (geometric stiffening, as in M2)."""
    elements, (L, EI, _, rho_a, _) = 8, M2
    beam, tension = numeric(elements), 10.0 * EI / L**2
    external = np.zeros(4 * (elements + 1))
    external[4 * elements] = tension
    fixed = [0, 1, 4 * elements + 1]
    q = equilibrium(beam, fixed, external)
    free = np.setdiff1d(np.arange(len(q)), fixed)
    stiffness = beam.stiffness(q)[np.ix_(free, free)]
    omega = math.sqrt(linalg.eigh(stiffness, beam.mass[np.ix_(free, free)], eigvals_only=True)[0])
    expected = (math.pi / L)**2 * math.sqrt(EI / rho_a) * math.sqrt(1 + 10.0 / math.pi**2)
    assert omega == pytest.approx(expected, rel=1e-2)


# -- dynamics --------------------------------------------------------------------------------


def test_free_beam_conserves_energy_while_spinning_and_vibrating():
    values = (1.0, 1.0, 1e3, 1.0, 0.0)  # a soft beam so that the run is short
    beam = numeric(4, values)
    q0 = beam.straight()
    stiffness = beam.stiffness(q0)
    _, modes = linalg.eigh(stiffness, beam.mass)
    spin = np.array([v for k in range(5) for v in (0.0, 0.25 * k - 0.5, 0.0, 1.0)])
    qd0 = 3.0 * spin + 0.5 * modes[:, 3] / np.abs(modes[1::4, 3]).max()  # 3 rad/s + bending
    inverse_mass = np.linalg.inv(beam.mass)

    def rhs(t, state):
        q, qd = state[:20], state[20:]
        return np.concatenate([qd, inverse_mass @ beam.force(q)])

    def total_energy(state):
        q, qd = state[:20], state[20:]
        return 0.5 * qd @ beam.mass @ qd + beam.energy(q)

    start = np.concatenate([q0, qd0])
    run = integrate.solve_ivp(rhs, (0.0, 1.5), start, method="DOP853", rtol=1e-11, atol=1e-12)
    end = run.y[:, -1]
    assert beam.energy(run.y[:20, run.y.shape[1] // 2]) > 1e-3  # it does vibrate
    chord = end[16:18] - end[0:2]
    assert abs(math.atan2(chord[1], chord[0])) > 1.0  # and has turned through ~4.5 rad
    assert total_energy(end) == pytest.approx(total_energy(start), rel=1e-8)


# -- damping ---------------------------------------------------------------------------------


def test_damping_is_stiffness_proportional_and_spares_rigid_motion():
    symbolic = derive(3, damping=True)
    values = dict(zip(PARAMS, (*M2[:4], 0.01)))
    q, qd = sympy.Matrix(symbolic.q), sympy.Matrix(sympy.symbols("qd0:16"))
    force = sympy.lambdify([q, qd], symbolic.damping_force(list(qd)).xreplace(values), cse=True)
    power = sympy.lambdify([q, qd], symbolic.damping_power(list(qd)).xreplace(values), cse=True)

    def damping(q_value, qd_value):
        return np.asarray(force(q_value, qd_value), dtype=np.result_type(qd_value, float)).ravel()

    beam = numeric(3)
    rng = np.random.default_rng(3)
    deformed = beam.straight(0.8) + 1e-3 * rng.standard_normal(16)
    # a rigid motion (turning about the origin at 1 rad/s, translating at (2, -1) m/s) is not
    # damped: node velocity e_z x r + v, slope rate e_z x r'
    nodes = deformed.reshape(-1, 4)
    rigid = np.column_stack([-nodes[:, 1] + 2.0, nodes[:, 0] - 1.0, -nodes[:, 3], nodes[:, 2]])
    assert np.abs(damping(deformed, rigid.ravel())).max() < 1e-6
    # it removes power qd . f >= 0, reported by damping_power
    rates = rng.standard_normal(16)
    removed = -rates @ damping(deformed, rates)
    assert removed > 0 and power(deformed, rates) == pytest.approx(removed, rel=1e-10)
    # about the straight beam it is beta K (the linearised stiffness)
    straight = beam.straight()
    matrix = np.array([-damping(straight, unit) for unit in np.eye(16)]).T
    assert np.allclose(matrix, 0.01 * beam.stiffness(straight), rtol=1e-8, atol=1e-6)
    assert derive(3).damping_force(list(qd)) == sympy.zeros(16, 1)


# -- gravity and end quantities --------------------------------------------------------------


def hermite_position(q: np.ndarray, k: int, length: float, xi: float) -> np.ndarray:
    """r at xi in [0, 1] of element k (rest length `length`) from the cubic Hermite functions."""
    shapes = (1 - 3 * xi**2 + 2 * xi**3, length * (xi - 2 * xi**2 + xi**3),
              3 * xi**2 - 2 * xi**3, length * (-xi**2 + xi**3))
    nodes = q.reshape(-1, 4)
    return (shapes[0] * nodes[k, :2] + shapes[1] * nodes[k, 2:] + shapes[2] * nodes[k + 1, :2]
            + shapes[3] * nodes[k + 1, 2:])


def test_gravity_energy_integrates_the_interpolated_beam():
    symbolic, L, rho_a = derive(3), 1.0, 5.0
    gx, gy = 1.5, -9.81
    energy = sympy.lambdify([sympy.Matrix(symbolic.q)], symbolic.gravity_energy(gx, gy).subs(
        {PARAMS[0]: L, PARAMS[3]: rho_a}))
    q = numeric(3).straight(-1.2, 0.3, 0.1) + 0.05 * np.random.default_rng(4).standard_normal(16)
    s, weights = np.polynomial.legendre.leggauss(40)
    quadrature = 0.0
    for k in range(3):  # per element, to keep the integrand smooth
        for point, weight in zip(s, weights):
            r = hermite_position(q, k, L / 3, (point + 1) / 2)
            quadrature -= rho_a * (gx * r[0] + gy * r[1]) * weight * L / 6
    assert float(energy(q)) == pytest.approx(quadrature, rel=1e-12)


def test_end_quantities_of_a_parabola():
    """y = c s^2 along +x is exactly representable by the cubic interpolation."""
    symbolic, c, L = derive(4), 0.1, 1.0
    nodes = [(s, c * s**2, 1.0, 2 * c * s) for s in np.linspace(0, L, 5)]
    at = dict(zip(symbolic.q, [v for node in nodes for v in node]))
    assert symbolic.end_position("b") == (symbolic.q[16], symbolic.q[17])
    assert float(symbolic.tip_deflection().subs(at)) == pytest.approx(c * L**2)
    assert float(symbolic.chord_angle().subs(at)) == pytest.approx(math.atan(c * L))
    assert float(symbolic.end_angle("a").subs(at)) == 0.0
    assert float(symbolic.end_angle("b").subs(at)) == pytest.approx(math.atan(2 * c * L))


def test_angles_near_a_reference_do_not_jump_at_minus_x():
    symbolic = derive(1)
    for tilt in (0.1, -0.1):
        at = dict(zip(symbolic.q, (0, 0, -math.cos(tilt), -math.sin(tilt), -1, 0, -1, 0)))
        plain = float(symbolic.end_angle("a").subs(at))
        near = float(symbolic.end_angle("a", near=sympy.pi).subs(at))
        assert near == pytest.approx(math.pi + tilt)
        assert abs(plain) == pytest.approx(math.pi - 0.1)  # atan2 jumps across -x
    at = dict(zip(symbolic.q, (0, 0, 1, 0, 0, -1, 1, 0)))
    assert float(symbolic.chord_angle(near=-sympy.pi / 2).subs(at)) == pytest.approx(-math.pi / 2)


def test_initial_velocities_are_the_rate_of_the_initial_pose():
    symbolic = derive(2)
    t = sympy.Symbol("t")
    angle, x_a, y_a = (sympy.Function(name)(t) for name in ("angle", "x_a", "y_a"))
    pose = symbolic.initial_coordinates(x_a, y_a, angle)
    rates = symbolic.initial_velocities(x_a.diff(t), y_a.diff(t), angle, angle.diff(t))
    assert all(sympy.simplify(p.diff(t) - r) == 0 for p, r in zip(pose, rates))


def test_sixteen_elements_derive():
    """Two M2 links at 16 elements each: the element template is derived once and reused."""
    for name in ("link1", "link2"):
        beam = make_beam(16, damping=True, name=name)
        q = list(sympy.symbols(f"{name}_q0:68"))
        symbolic = beam_module.beam_element(beam, q, to_sym)
        assert symbolic.elastic_force().shape == (68, 1)
        assert symbolic.damping_force(list(sympy.symbols(f"{name}_qd0:68"))).shape == (68, 1)
        assert symbolic.mass_matrix.shape == (68, 68)
