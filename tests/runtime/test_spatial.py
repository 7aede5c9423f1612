"""Spatial models against independent references (tests/references/spatial.py: joint
coordinates by hand, integrated by scipy's DOP853 at 1e-12, each checked there against
conservation laws and a second derivation), conservation laws and closed forms.

Bounds. The step control holds each step's local error to tol (s + |y|) per coordinate
(docs/method.md, 6a); a run's global error is the sum of the local errors carried along the
motion, so it grows with the number of steps a motion takes. A slow mechanism ends within
a few tol of the reference; a fast spin accumulates a phase error of a few tol per
revolution. The bounds below are each case's measured error (in the comment) with room for
a different CPU and BLAS: never tighter than 3 times it."""

from __future__ import annotations

import math

import numpy as np
import pytest

import depsim
from references.spatial import (bennett_geometry, bennett_output_angle, heavy_top,
                                lagrange_top_steady_precession,
                                lagrange_top_steady_state, rot, skewed_double_pendulum,
                                torque_free)
from runtime_helpers import compile_text, rotations

G = (0.0, 0.0, -9.81)


def vector(values) -> str:
    return "(" + ", ".join(repr(float(v)) for v in values) + ")"


def turns(R) -> str:
    """R as rz(a) * ry(b) * rx(c) (R = Rz Ry Rx, |b| < 90 deg)."""
    b = -math.asin(max(-1.0, min(1.0, R[2, 0])))
    a, c = math.atan2(R[1, 0], R[0, 0]), math.atan2(R[2, 1], R[2, 2])
    return f"rz({float(a)!r} rad) * ry({float(b)!r} rad) * rx({float(c)!r} rad)"


# -- a double pendulum with skewed hinge axes ------------------------------------------------

PENDULUM = """model skewed spatial "Double pendulum, skewed hinge axes"
gravity = (0, 0, -9.81) m/s^2
body l1 {
    mass = 1 kg
    inertia = (0.01, 0.09, 0.09) kg*m^2
    point root = (-0.5, 0, 0) m
    point tip = (0.5, 0, 0) m
}
body l2 {
    mass = 0.5 kg
    inertia = (0.005, 0.04, 0.04) kg*m^2
    point root = (-0.4, 0, 0) m
}
hinge h1 joins ground.origin to l1.root { axis = (0, 1, 0.2) }
hinge h2 joins l1.tip to l2.root { axis = (0.3, 1, 0) }
initial { h1 = 30 deg; h2 = -20 deg; h2.rate = 1 rad/s }
simulate { t_end = 3 s; tol = 1e-8; dt_out = 0.01 s }
output energy = system.energy
"""


@pytest.fixture(scope="module")
def pendulum_reference():
    t = np.round(np.arange(301) * 0.01, 12)
    bodies = [dict(m=1.0, J=np.diag([0.01, 0.09, 0.09])),
              dict(m=0.5, J=np.diag([0.005, 0.04, 0.04]))]
    hinges = [dict(axis=[0, 1, 0.2], point_a=[0, 0, 0], point_b=[-0.5, 0, 0]),
              dict(axis=[0.3, 1, 0], point_a=[0.5, 0, 0], point_b=[-0.4, 0, 0])]
    return skewed_double_pendulum(t, g=np.array(G), bodies=bodies, hinges=hinges,
                                  theta0=np.radians([30.0, -20.0]), rate0=np.array([0.0, 1.0]))


@pytest.mark.parametrize("target", ["c", "numpy"])
def test_skewed_double_pendulum_follows_the_joint_coordinate_solution(tmp_path, target,
                                                                      pendulum_reference):
    result = compile_text(tmp_path, "skewed", PENDULUM, target).run()
    tol = result.tol
    assert np.max(np.abs(result.hinge_angles - pendulum_reference["theta"])) < 2 * tol  # 0.22
    assert np.max(np.abs(result.hinge_rates - pendulum_reference["rate"])) < 20 * tol  # 1.4
    assert np.max(np.abs(rotations(result, "l2") - pendulum_reference["R"][:, 1])) < 2 * tol
    energy = result.output("energy")
    assert np.ptp(energy) < 10 * tol * abs(energy[0])  # 1.6 tol


# -- a heavy top on a ball joint -------------------------------------------------------------

def top_model(m, J, pivot, R0, omega0, g, tol, t_end, dt_out=0.01) -> str:
    return f"""model top spatial "A top on a ball joint"
gravity = {vector(g)} m/s^2
body top {{
    mass = {m!r} kg
    inertia = {vector(J)} kg*m^2
    orientation = {turns(R0)}
    point tip = {vector(pivot)} m
}}
ball pivot joins ground.origin to top.tip {{ }}
initial {{
    pivot.wx = {float(omega0[0])!r} rad/s
    pivot.wy = {float(omega0[1])!r} rad/s
    pivot.wz = {float(omega0[2])!r} rad/s
}}
simulate {{ t_end = {t_end} s; tol = {tol}; dt_out = {dt_out} s }}
output energy = system.energy
output hx = system.angular_momentum_x
output hy = system.angular_momentum_y
output hz = system.angular_momentum_z
"""


def test_an_asymmetric_heavy_top_follows_the_reference(tmp_path):
    m, J, pivot = 2.0, (0.02, 0.025, 0.03), (0.01, -0.02, -0.1)
    R0, omega0 = rot([1, 0.5, 0], 0.4), (1.0, -2.0, 3.0)
    sim = compile_text(tmp_path, "top", top_model(m, J, pivot, R0, omega0, G, 1e-9, 2))
    result = sim.run()
    reference = heavy_top(result.times, g=np.array(G), m=m, J=np.diag(J),
                          pivot=np.array(pivot), R0=R0, omega0=np.array(omega0))
    tol = result.tol
    assert np.max(np.abs(rotations(result, "top") - reference["R"])) < 300 * tol  # 70 tol
    energy = result.output("energy")
    assert np.ptp(energy) < 10 * tol * abs(energy[0])  # 2.5 tol


def test_a_force_input_at_the_centre_of_mass_acts_as_gravity_does(tmp_path):
    """The heavy top without gravity, pushed down at its centre of mass by a force input
    whose z component a run sets to -m g: the reference's motion (a force at a point enters
    as (dr/dq)^T F, gravity as -dV/dq)."""
    m, J, pivot = 2.0, (0.02, 0.025, 0.03), (0.01, -0.02, -0.1)
    R0, omega0 = rot([1, 0.5, 0], 0.4), (1.0, -2.0, 3.0)
    text = top_model(m, J, pivot, R0, omega0, (0, 0, 0), 1e-9, 2).replace(
        "simulate", "input weight force on top.cm\nsimulate")
    sim = compile_text(tmp_path, "pushed", text)
    result = sim.run(inputs={"weight.z": -m * 9.81})
    reference = heavy_top(result.times, g=np.array(G), m=m, J=np.diag(J),
                          pivot=np.array(pivot), R0=R0, omega0=np.array(omega0))
    assert np.max(np.abs(rotations(result, "top") - reference["R"])) < 300 * result.tol


def test_a_top_given_its_products_of_inertia_follows_the_reference_of_its_tensor(tmp_path):
    """The moments about the body's axes with the products of inertia (Pxy, Pyz, Pzx), the
    integrals of x y, y z, z x dm: the tensor's off-diagonal entries are their negatives."""
    m, pivot = 2.0, (0.01, -0.02, -0.1)
    tensor = np.array([[0.02, -0.003, 0.002], [-0.003, 0.025, -0.001], [0.002, -0.001, 0.03]])
    products = (-tensor[0, 1], -tensor[1, 2], -tensor[2, 0])
    R0, omega0 = rot([1, 0.5, 0], 0.4), (1.0, -2.0, 3.0)
    text = top_model(m, np.diag(tensor), pivot, R0, omega0, G, 1e-9, 2).replace(
        "    point tip", f"    products_of_inertia = {vector(products)} kg*m^2\n    point tip")
    result = compile_text(tmp_path, "products", text).run()
    reference = heavy_top(result.times, g=np.array(G), m=m, J=tensor, pivot=np.array(pivot),
                          R0=R0, omega0=np.array(omega0))
    assert np.max(np.abs(rotations(result, "top") - reference["R"])) < 300 * result.tol
    principal = heavy_top(result.times, g=np.array(G), m=m, J=np.diag(np.diag(tensor)),
                          pivot=np.array(pivot), R0=R0, omega0=np.array(omega0))
    assert np.max(np.abs(principal["R"] - reference["R"])) > 1e4 * result.tol  # they matter


def test_a_lagrange_top_precesses_steadily_at_the_closed_form_rate(tmp_path):
    """A symmetric top started in steady precession keeps its tilt and precesses at the
    slow root of A_O W^2 cos(tilt) - C n W + m g l = 0."""
    m, A, C, l, tilt, spin = 1.0, 0.004, 0.006, 0.05, math.radians(30), 60.0
    slow, _ = lagrange_top_steady_precession(g=np.array(G), m=m, A=A, C=C, l=l, tilt=tilt,
                                             spin=spin)
    R0, omega0 = lagrange_top_steady_state(g=np.array(G), tilt=tilt, spin=spin,
                                           precession=slow)
    period = 2 * math.pi / abs(slow)
    t_end = round(period, 3)
    sim = compile_text(tmp_path, "lagrange", top_model(m, (A, A, C), (0, 0, -l), R0, omega0,
                                                       G, 1e-10, t_end, dt_out=t_end / 200))
    result = sim.run()
    axis = rotations(result, "top")[:, :, 2]  # the symmetry axis, pivot to centre of mass
    tilts = np.arccos(np.clip(axis[:, 2], -1, 1))
    assert np.max(np.abs(tilts - tilt)) < 1e-7  # 1.2e-8 rad
    azimuth = np.unwrap(np.arctan2(axis[:, 1], axis[:, 0]))
    rate = np.polyfit(result.times, azimuth, 1)[0]
    assert rate == pytest.approx(slow, rel=1e-7)


# -- a free rigid body -------------------------------------------------------------------------

def test_a_tumbling_body_keeps_its_angular_momentum_and_flips_about_its_middle_axis(tmp_path):
    """Torque-free motion of an asymmetric body spun about its intermediate axis: the
    angular momentum vector stays put while the body flips, as the reference flips."""
    J, R0 = (2.0, 3.0, 4.0), rot([0.2, -0.4, 1.0], 0.7)
    omega0 = R0 @ np.array([1e-3, 2 * math.pi, 1e-3])
    sim = compile_text(tmp_path, "tumble", top_model(5.0, J, (0, 0, 0), R0, omega0,
                                                     (0, 0, 0), 1e-10, 6, dt_out=0.005))
    result = sim.run()
    reference = torque_free(result.times, J=np.diag(J), R0=R0, omega0=omega0)
    h = np.stack([result.output(name) for name in ("hx", "hy", "hz")], axis=1)
    size = np.linalg.norm(h[0])
    np.testing.assert_allclose(h[0], reference["h_world"][0], rtol=0, atol=1e-12 * size)
    assert np.max(np.abs(h - h[0])) < 50 * result.tol * size  # 16 tol over six turns
    # (both proportional to tol: 16 and 41 tol at tol 1e-8, 1e-10 and 1e-12 alike)
    R = rotations(result, "top")
    spin = np.einsum("nji,nj->ni", R, reference["omega"])[:, 1]  # about the middle axis
    flips = result.times[np.nonzero(np.diff(np.sign(spin)))[0]]
    expected = result.times[np.nonzero(np.diff(np.sign(reference["omega_body"][:, 1])))[0]]
    assert len(expected) >= 1 and len(flips) == len(expected)
    np.testing.assert_allclose(flips, expected, atol=0.011)  # the same output interval
    energy = result.output("energy")
    assert np.ptp(energy) < 150 * result.tol * energy[0]  # 41 tol over six turns


# -- a planar model written as a spatial one ------------------------------------------------------

def test_a_planar_pendulum_written_spatially_swings_as_the_planar_model(tmp_path):
    planar = depsim.load("examples/pendulum.dep").compile("c", out_dir=tmp_path / "planar")
    text = """model pendulum3 spatial "The rigid bar pendulum, in 3-D"
gravity = (0, -9.81, 0) m/s^2
param L = 1 m
param m = 2 kg
bar rod {
    length = L
    mass = m
    inertia = (m * L^2 / 1200, m * L^2 / 12, m * L^2 / 12)
}
hinge pivot joins ground.origin to rod.a {
    axis = (0, 0, 1)
    angle = rod - ground + 90 deg
}
initial { pivot = 60 deg }
simulate { t_end = 10 s; tol = 1e-9; dt_out = 0.01 s }
output tip_x = rod.b.x
output tip_z = rod.b.z
"""
    spatial = compile_text(tmp_path, "pendulum3", text)
    a, b = planar.run(), spatial.run()
    np.testing.assert_allclose(b.times, a.times)
    assert np.max(np.abs(b.hinge_angles - a.hinge_angles)) < 20 * a.tol  # 1.3 tol
    assert np.max(np.abs(b.output("tip_x") - a.output("tip_x"))) < 20 * a.tol
    assert np.max(np.abs(b.output("tip_z"))) < 1e-12


# -- loads, free flight ------------------------------------------------------------------------------

def test_a_body_hanging_from_a_skewed_hinge_carries_its_weight(tmp_path):
    text = """model hang spatial "A body at rest below a skewed hinge"
gravity = (0, 0, -9.81) m/s^2
body weight {
    mass = 3 kg
    inertia = (0.1, 0.12, 0.15) kg*m^2
    point top = (0, 0, 0.5) m
}
hinge h joins ground.origin to weight.top { axis = (1, 0.4, 0.3) }
simulate { t_end = 1 s; tol = 1e-9; dt_out = 0.1 s }
output fz = h.force_z
"""
    result = compile_text(tmp_path, "hang", text).run()
    load = result.hinge_loads["h"]
    np.testing.assert_allclose(load.force_z, 3 * 9.81, rtol=1e-9)
    np.testing.assert_allclose(result.output("fz"), load.force_z, rtol=0, atol=1e-12)
    assert np.max(np.abs(load.force_x)) < 1e-9 and np.max(np.abs(load.force_y)) < 1e-9
    np.testing.assert_allclose(load.force, 3 * 9.81, rtol=1e-9)
    assert result.peak_loads["h"].force == pytest.approx(3 * 9.81, rel=1e-9)
    assert np.max(np.abs(result.hinge_angles)) < 1e-12


def test_a_free_body_moves_as_its_free_joint_starts_it(tmp_path):
    text = """model drift spatial "A body thrown in zero gravity"
body probe {
    mass = 4 kg
    inertia = (0.2, 0.3, 0.4) kg*m^2
    orientation = rz(30 deg) * rx(10 deg)
    point corner = (0.2, 0.1, -0.1) m
}
free fly joins ground.origin to probe.cm { }
initial {
    fly.x = 1 m; fly.y = 2 m; fly.z = 3 m
    fly.vx = 0.5 m/s; fly.vy = -0.2 m/s; fly.vz = 0.1 m/s
    fly.wx = 0.3 rad/s; fly.wy = 1.5 rad/s; fly.wz = -0.4 rad/s
}
simulate { t_end = 4 s; tol = 1e-10; dt_out = 0.5 s }
output px = system.momentum_x
output pz = system.momentum_z
output wy = probe.wy
output cz = probe.cm.z
"""
    result = compile_text(tmp_path, "drift", text).run()
    np.testing.assert_allclose(result.output("px"), 4 * 0.5, rtol=0, atol=1e-12)
    np.testing.assert_allclose(result.output("pz"), 4 * 0.1, rtol=0, atol=1e-12)
    np.testing.assert_allclose(result.output("cz"), 3 + 0.1 * result.times, rtol=0,
                               atol=1e-9)
    assert result.output("wy")[0] == pytest.approx(1.5, abs=1e-12)
    R0 = rot([0, 0, 1], math.radians(30)) @ rot([1, 0, 0], math.radians(10))
    np.testing.assert_allclose(rotations(result, "probe")[0], R0, rtol=0, atol=1e-12)


# -- the Bennett linkage: mobile although its Grubler count is -2 ------------------------------------

def test_the_bennett_linkage_moves_on_its_closed_form_input_output_relation(tmp_path):
    """Four links, four hinges with skewed axes (Denavit-Hartenberg lengths a, b, a, b and
    twists alpha, beta, alpha, beta, a / sin alpha = b / sin beta): 38 rows on 36
    coordinates, three of them redundant, one degree of freedom. Placed at the reference
    configuration of input angle 1 rad, started turning at 2 rad/s without gravity: the
    output angle stays on tan(theta/2) tan(phi/2) = sin((beta + alpha)/2) / sin((beta -
    alpha)/2) up to near pi, where the linkage folds into a line (its joints collinear, a
    singular position of higher rank loss), the energy stays, the loads are reported not
    unique."""
    a, alpha, beta = 0.5, math.radians(40), math.radians(70)
    lengths = (a, a * math.sin(beta) / math.sin(alpha), a, a * math.sin(beta) / math.sin(alpha))
    geometry = bennett_geometry(1.0, a=a, alpha=alpha, beta=beta)
    angles = [float(value) for value in geometry["angles"]]
    links = "".join(f"""body link{i + 1} {{
    mass = {0.5 + 0.1 * i} kg
    inertia = (0.001, {0.04 * lengths[i] ** 2 + 0.001!r}, {0.04 * lengths[i] ** 2 + 0.0015!r}) kg*m^2
    orientation = {turns(geometry["frames"][i])}
    point start = ({-lengths[i] / 2!r}, 0, 0) m
    point end = ({lengths[i] / 2!r}, 0, 0) m
}}
""" for i in (1, 2, 3))

    def axis(twist):
        return f"(0, {-math.sin(twist)!r}, {math.cos(twist)!r})"

    text = f"""model bennett spatial "The Bennett linkage"
ground {{ point j2 = ({a!r}, 0, 0) m }}
{links}
hinge h2 joins ground.j2 to link2.start {{ axis = {axis(alpha)}; angle = link2 - ground + {angles[1]!r} rad }}
hinge h3 joins link2.end to link3.start {{ axis = {axis(beta)}; angle = link3 - link2 + {angles[2]!r} rad }}
hinge h4 joins link3.end to link4.start {{ axis = {axis(alpha)}; angle = link4 - link3 + {angles[3]!r} rad }}
hinge h1 joins ground.origin to link4.end {{ axis = (0, 0, -1); angle = link4 - ground + {angles[0]!r} rad }}
initial {{
    h1 = {angles[0]!r} rad; h2 = {angles[1]!r} rad; h3 = {angles[2]!r} rad; h4 = {angles[3]!r} rad
    h1.rate = 2 rad/s
}}
simulate {{ t_end = 1.4 s; tol = 1e-9; dt_out = 0.01 s }}
output energy = system.energy
"""
    result = compile_text(tmp_path, "bennett", text).run()
    names = result.hinge_names
    theta = result.hinge_angles[:, names.index("h1")]
    phi = result.hinge_angles[:, names.index("h2")]
    assert theta[0] == pytest.approx(1.0) and theta[-1] > 2.9  # 1 rad to near the fold at pi
    expected = bennett_output_angle(theta, alpha=alpha, beta=beta)
    assert np.max(np.abs(np.angle(np.exp(1j * (phi - expected))))) < 10 * result.tol  # 0.01
    # (the output angle through its wrap at -pi)
    energy = result.output("energy")
    assert np.ptp(energy) < 10 * result.tol * energy[0]
    assert not any(peak.unique for peak in result.peak_loads.values())


def test_a_carriage_slides_down_a_tilted_rail_as_gravity_along_it_says(tmp_path):
    """A slider on a rail along (1, 2, -2) (unit (1, 2, -2)/3): the carriage keeps its
    orientation and moves s = s0 + v0 t + (g . a) t^2 / 2, g . a = 9.81 * 2/3; the rail
    carries the rest of its weight and the moment that keeps it from turning."""
    text = """model rail spatial "A carriage on a tilted rail"
gravity = (0, 0, -9.81) m/s^2
ground { point start = (0.2, -0.1, 1) m }
body carriage {
    mass = 2 kg
    inertia = (0.02, 0.03, 0.04) kg*m^2
    orientation = rz(20 deg)
    point shoe = (0.05, 0, -0.03) m
}
slider rail joins ground.start to carriage.shoe { axis = (1, 2, -2) }
initial { rail = 0.1 m; rail.rate = 0.5 m/s }
simulate { t_end = 1 s; tol = 1e-10; dt_out = 0.1 s }
output s = rail
output shoe_z = carriage.shoe.z
output fx = rail.force_x
output fy = rail.force_y
output fz = rail.force_z
output mx = rail.moment_x
output my = rail.moment_y
output mz = rail.moment_z
output lock = rail.force
"""
    result = compile_text(tmp_path, "rail", text).run()
    t = result.times
    s = 0.1 + 0.5 * t + 9.81 * 2 / 3 * t**2 / 2
    np.testing.assert_allclose(result.output("s"), s, rtol=0, atol=1e-9)
    np.testing.assert_allclose(result.output("shoe_z"), 1 - 2 / 3 * s, rtol=0, atol=1e-9)
    turned = rot([0, 0, 1], math.radians(20))
    np.testing.assert_allclose(rotations(result, "carriage"), np.broadcast_to(turned, (len(t), 3, 3)),
                               rtol=0, atol=1e-10)
    # the rail's reaction: the weight's part normal to the axis, held up, -m (g - (g . a) a);
    # its moment about the shoe keeps the carriage from turning, (r_cm - r_shoe) x F
    a, g = np.array([1.0, 2, -2]) / 3, np.array([0, 0, -9.81])
    force = -2.0 * (g - (g @ a) * a)
    reported = np.column_stack([result.output(f"f{k}") for k in "xyz"])
    np.testing.assert_allclose(reported, np.broadcast_to(force, reported.shape), rtol=0,
                               atol=1e-9 * 2 * 9.81)
    moment = np.cross(-turned @ np.array([0.05, 0, -0.03]), force)
    reported = np.column_stack([result.output(f"m{k}") for k in "xyz"])
    np.testing.assert_allclose(reported, np.broadcast_to(moment, reported.shape), rtol=0,
                               atol=1e-9 * 2 * 9.81)
    assert np.all(result.output("lock") == 0.0)  # nothing can lock it


@pytest.mark.parametrize("joint", ["hinge h joins ground.origin to arm.root { axis = (0, 0, 1) }",
                                   "weld h joins ground.origin to arm.root { }"])
def test_a_joint_holding_a_body_out_carries_its_weight_and_moment(tmp_path, joint):
    """A 2 kg body whose centre of mass is 0.5 m out along x from its joint: the force on it
    from the ground is its weight, up; the moment about the joint is -(0.5 x) x (-m g z),
    (0, -m g 0.5, 0): a hinge about z carries it by its axis rows, a weld by its turn rows."""
    text = f"""model held spatial "A body held out"
gravity = (0, 0, -9.81) m/s^2
body arm {{
    mass = 2 kg
    inertia = (0.01, 0.2, 0.2) kg*m^2
    point root = (-0.5, 0, 0) m
}}
{joint}
simulate {{ t_end = 0.2 s; tol = 1e-9; dt_out = 0.1 s }}
output fz = h.force_z
output mx = h.moment_x
output my = h.moment_y
output mz = h.moment_z
output m = h.moment
"""
    result = compile_text(tmp_path, "held", text).run()
    np.testing.assert_allclose(result.output("fz"), 2 * 9.81, rtol=1e-9)
    np.testing.assert_allclose(result.output("my"), -2 * 9.81 * 0.5, rtol=1e-9)
    np.testing.assert_allclose(result.output("m"), 2 * 9.81 * 0.5, rtol=1e-9)
    for name in ("mx", "mz"):
        assert np.max(np.abs(result.output(name))) < 1e-9


def test_a_panel_folded_through_half_a_turn_reaches_its_latch(tmp_path):
    """A hinge driven by its preload from 0 to its latch at 180 deg (a Z-folded panel's
    travel): its angle is measured about the middle of that travel, so it reaches the latch
    instead of reading -180 deg there; the spring's work, preload x pi, is the impact's
    loss."""
    text = """model halfturn spatial "A panel turned through half a turn to its latch"
body panel { mass = 2 kg; inertia = (0.05, 0.3, 0.3) kg*m^2; point a = (0.5, 0, 0) m }
hinge h joins ground.origin to panel.a { axis = (0, 0, 1); preload = 0.5 N*m; latch = 180 deg }
simulate { t_end = 4 s; tol = 1e-9; dt_out = 0.01 s }
"""
    result = compile_text(tmp_path, "halfturn", text).run()
    assert result.deployment.deployed
    (latch,) = result.deployment.latches
    assert latch.energy_loss == pytest.approx(0.5 * math.pi, rel=1e-6)
    assert np.all(np.diff(result.hinge_angles[:, 0]) >= -1e-12)  # no jump of a whole turn
    assert result.hinge_angles[-1, 0] == pytest.approx(math.pi, abs=1e-9)


SPIN = """model spin spatial "A bar spun about a skewed hinge, nothing holding it"
gravity = (0, 0, 0) m/s^2
bar b {{ length = 1 m; mass = 1 kg; inertia = (0.001, 0.0833, 0.0833) kg*m^2 }}
hinge h joins ground.origin to b.a {{ axis = (0, 0.3, 1){attributes} }}
initial {{ h.rate = 2 rad/s }}
simulate {{ t_end = 8 s; tol = 1e-9; dt_out = 0.05 s }}
output tip_x = b.b.x
output tip_y = b.b.y
output tip_z = b.b.z
{outputs}"""


@pytest.mark.parametrize("target", ["c", "numpy"])
def test_a_loaded_hinge_turned_past_half_a_turn_stops_the_run(tmp_path, target):
    """A spatial hinge's angle is measured within half a turn of the middle of its travel:
    where the motion depends on it (here a spring; also a cable, a latch, stops), turning
    past that stops the run with the hinge named (its torque would follow an angle a whole
    turn off), at the step where it does (2 rad/s from 0: t = pi / 2 s), no result kept."""
    from depsim.runtime.errors import SolverError

    sim = compile_text(tmp_path, "spinspring", SPIN.format(
        attributes="; stiffness = 0.001 N*m/rad; preload = 0.004 N*m", outputs=""), target)
    assert sim.module.HINGE_WRAPS == (1,)
    with pytest.raises(SolverError) as failure:
        sim.run()
    assert failure.value.joint == "h" and failure.value.stage == "hinge angle"
    assert math.pi / 2 - 0.1 < failure.value.t < math.pi / 2 + 0.2  # a step past it
    assert "turned more than half a turn from the middle of its travel" in str(failure.value)
    assert "latch or stops" in str(failure.value)


def test_a_hinge_nothing_loads_turns_freely(tmp_path):
    """The same bar with no load, latch or stop on its angle (a crank, a shaft, a wheel)
    turns on through four turns at its constant rate: the tip is the rotation about the axis
    of its start (measured 5.6e-8 m over the 8 s at tol 1e-9, a phase error of a few tol a
    turn), and its angle output is read within half a turn of its start."""
    sim = compile_text(tmp_path, "spinfree", SPIN.format(attributes="",
                                                         outputs="output angle = h\n"))
    assert sim.module.HINGE_WRAPS == (0,)
    result = sim.run()
    axis = np.array([0.0, 0.3, 1.0]) / math.hypot(0.3, 1.0)
    tip = np.array([rot(axis, 2.0 * t) @ np.array([1.0, 0.0, 0.0]) for t in result.times])
    got = np.column_stack([result.output(f"tip_{a}") for a in "xyz"])
    assert np.max(np.abs(got - tip)) < 1e-6
    assert result.times[-1] == pytest.approx(8.0)
    wrapped = np.angle(np.exp(2j * result.times))
    assert np.max(np.abs(np.angle(np.exp(1j * (result.output("angle") - wrapped))))) < 1e-6
    assert np.all(np.abs(result.output("angle")) <= math.pi + 1e-9)
