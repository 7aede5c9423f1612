"""Cylindrical and universal joints of spatial models against closed forms and the rigid-body
laws: Hooke's joint's output angle, a spinning and sliding body's reaction loads, and each
body's angular momentum balance under the reaction loads the joints report.

Bounds. The closed forms are exact; the run's error is its global error, a few tol on these
slow, smooth motions (measured in the comments; the bounds leave more than 3 times that for
another CPU and BLAS). A time derivative taken by central differences of the output at
spacing h is good to h^2 |y'''| / 6 (stated where used)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from references.spatial import rot
from runtime_helpers import compile_text, rotations

BETA = 30.0  # deg, the angle between the shafts

CARDAN = f"""model cardan spatial "A shaft driving another through a universal joint"
ground {{ point far = (1 + cos({BETA} deg), sin({BETA} deg), 0) m }}
body shaft1 {{
    mass = 1 kg
    inertia = (0.01, 0.1, 0.1) kg*m^2
    point start = (-0.5, 0, 0) m
    point end = (0.5, 0, 0) m
}}
body shaft2 {{
    mass = 1.5 kg
    inertia = (0.02, 0.12, 0.13) kg*m^2
    orientation = rz({BETA} deg)
    point start = (-0.5, 0, 0) m
    point end = (0.5, 0, 0) m
}}
hinge h1 joins ground.origin to shaft1.start {{ axis = (1, 0, 0) }}
universal u joins shaft1.end to shaft2.start {{ axis_a = (0, 0, 1); axis_b = (0, 1, 0) }}
cylindrical c joins ground.far to shaft2.end {{ axis = (cos({BETA} deg), sin({BETA} deg), 0) }}
initial {{ h1.rate = 2 rad/s }}
simulate {{ t_end = 3 s; tol = 1e-9; dt_out = 0.005 s }}
output theta_in = h1
output theta_out = c.angle
output out_rate = c.rate
output slide = c.position
output angle_a = u.angle_a
output angle_b = u.angle_b
output energy = system.energy
"""


def wrapped(angle: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * angle))


@pytest.fixture(scope="module")
def cardan(tmp_path_factory):
    return compile_text(tmp_path_factory.mktemp("cardan"), "cardan", CARDAN).run()


def test_hookes_joint_turns_its_output_shaft_by_the_closed_form(cardan):
    """tan(output) = cos(beta) tan(input) for a cross-piece whose input yoke starts normal to
    the plane of the shafts; the output shaft's rate swings between cos(beta) and
    1/cos(beta) of the input's."""
    beta, tol = math.radians(BETA), cardan.tol
    theta1 = cardan.output("theta_in")
    expected = np.arctan2(math.cos(beta) * np.sin(theta1), np.cos(theta1))
    assert np.max(np.abs(wrapped(cardan.output("theta_out") - expected))) < 100 * tol  # 38 tol
    assert np.max(np.abs(cardan.output("slide"))) < 10 * tol  # the shafts' ends are fixed
    ratio = cardan.output("out_rate") / cardan.hinge_rates[:, 0]
    assert ratio.min() == pytest.approx(math.cos(beta), rel=1e-3)
    assert ratio.max() == pytest.approx(1 / math.cos(beta), rel=1e-3)
    energy = cardan.output("energy")  # no gravity, no dissipation
    assert np.ptp(energy) < 10 * tol * energy[0]


def test_a_universal_joints_angles_rebuild_the_output_shafts_orientation(cardan):
    """R_B = R_A Rot(a, angle_a) Rot(R0 b, angle_b) R0 (docs/language.md): the two angles the
    joint reports, put through that definition, give shaft2's rotation matrix."""
    R1, R2 = rotations(cardan, "shaft1"), rotations(cardan, "shaft2")
    R0 = rot((0, 0, 1), math.radians(BETA))  # shaft1 starts in the world's orientation
    a, b_in_a = np.array([0.0, 0, 1]), R0 @ np.array([0.0, 1, 0])
    rebuilt = np.array([r1 @ rot(a, ta) @ rot(b_in_a, tb) @ R0 for r1, ta, tb
                        in zip(R1, cardan.output("angle_a"), cardan.output("angle_b"))])
    assert np.max(np.abs(rebuilt - R2)) < 1e-9  # definitions: round-off of the angles' atan2
    assert np.ptp(cardan.output("angle_b")) > 0.1  # the cross-piece rocks


def _spinning_slider(products=(0.0, 0.0, 0.0)) -> str:
    return f"""model spinner spatial "A body spinning and sliding on a tilted cylindrical joint"
gravity = (0, 0, -9.81) m/s^2
body sleeve {{
    mass = 2 kg
    inertia = (0.05, 0.04, 0.03) kg*m^2
    products_of_inertia = {tuple(products)!r} kg*m^2
}}
cylindrical c joins ground.origin to sleeve.cm {{ axis = (1, 0, 1) }}
initial {{ c.rate = 3 rad/s; c.velocity = 0.5 m/s; c.position = 0.2 m }}
simulate {{ t_end = 1 s; tol = 1e-10; dt_out = 0.01 s }}
output s = c.position
output turn = c.angle
output fx = c.force_x
output fy = c.force_y
output fz = c.force_z
output mx = c.moment_x
output my = c.moment_y
output mz = c.moment_z
"""


def test_a_body_slides_and_spins_on_a_cylindrical_joint_as_the_closed_forms_say(tmp_path):
    """Its centre of mass on the axis, whose unit vector n is (1, 0, 1)/sqrt 2: it slides at
    g . n and keeps spinning at its rate (gravity has no moment about the axis); the joint
    carries the weight's part normal to the axis, -m (g - (g . n) n), and the moment that
    turns the body's angular momentum with it, omega x (I omega) (its products of inertia
    about the axis are not zero)."""
    m, g, n = 2.0, np.array([0.0, 0, -9.81]), np.array([1.0, 0, 1]) / math.sqrt(2)
    products = (0.004, -0.003, 0.002)
    result = compile_text(tmp_path, "spinner", _spinning_slider(products)).run()
    t, tol = result.times, result.tol
    s = 0.2 + 0.5 * t + 0.5 * (g @ n) * t**2
    assert np.max(np.abs(result.output("s") - s)) < 100 * tol  # 0.3 tol
    assert np.max(np.abs(wrapped(result.output("turn") - 3 * t))) < 100 * tol  # 1.3 tol
    force = np.stack([result.output(f"f{k}") for k in "xyz"], axis=1)
    np.testing.assert_allclose(force, np.tile(-m * (g - (g @ n) * n), (len(t), 1)),
                               rtol=0, atol=1e-6 * m * 9.81)
    inertia = np.array([[0.05, -products[0], -products[2]], [-products[0], 0.04, -products[1]],
                        [-products[2], -products[1], 0.03]])
    omega = 3 * n
    moment = np.array([np.cross(omega, r @ inertia @ r.T @ omega)
                       for r in rotations(result, "sleeve")])
    reported = np.stack([result.output(f"m{k}") for k in "xyz"], axis=1)
    assert np.max(np.abs(moment)) > 0.01  # the test sees the gyroscopic moment
    np.testing.assert_allclose(reported, moment, rtol=0, atol=1e-6 * np.max(np.abs(moment)))


def test_each_joints_reaction_loads_balance_the_output_shafts_angular_momentum(cardan,
                                                                              tmp_path):
    """dH/dt about shaft2's centre of mass = the moments of the universal and cylindrical
    joints' reactions on it (their forces at their points, their moments): the loads both
    joints report, against a rigid body's law. H = R I R^T w, differentiated by central
    differences at the output interval h = 1 ms (error h^2 |H'''| / 6, 4e-6 of the
    moments' scale here; 1e-4 at 5 ms). Within the first step the loads at output times
    come from the multipliers' profile of that step alone, which has no earlier step to
    fit: 1e-4 of the scale there."""
    refs = {"fu": "u.force_{}", "mu": "u.moment_{}", "fc": "c.force_{}", "mc": "c.moment_{}",
            "pu": "shaft2.start.{}", "pc": "shaft2.end.{}", "w": "shaft2.w{}"}
    text = CARDAN.replace("dt_out = 0.005 s", "dt_out = 0.001 s") + "".join(f"output {name}_{axis} = {ref.format(axis)}\n"
                            for name, ref in refs.items() for axis in "xyz")
    result = compile_text(tmp_path, "balance", text).run()

    def vector(name):
        return np.stack([result.output(f"{name}_{axis}") for axis in "xyz"], axis=1)

    R = rotations(result, "shaft2")
    names = result.coordinate_names
    centre = result.q[:, [names.index(f"shaft2.{axis}") for axis in "xyz"]]
    inertia = np.diag([0.02, 0.12, 0.13])
    H = np.einsum("nij,jk,nlk,nl->ni", R, inertia, R, vector("w"))
    h = result.times[1] - result.times[0]
    rate = (H[2:] - H[:-2]) / (2 * h)
    moments = vector("mu") + vector("mc") \
        + np.cross(vector("pu") - centre, vector("fu")) \
        + np.cross(vector("pc") - centre, vector("fc"))
    scale = np.max(np.abs(moments))
    assert scale > 1e-3
    later = result.times[1:-1] > 0.02  # after the first step (15 ms here)
    np.testing.assert_allclose(rate[later], moments[1:-1][later], rtol=0,
                               atol=2e-5 * scale)  # 8e-6
    np.testing.assert_allclose(rate, moments[1:-1], rtol=0, atol=3e-4 * scale)  # 1e-4
