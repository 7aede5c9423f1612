"""The Euler-parameter formulation of tests/references/formulations.py (sympy's equations
emitted as C, the multipliers solved at every evaluation), which bench/bench_formulation.py
measures depsim against: it follows the joint-coordinate references of
tests/references/spatial.py, keeps |p| = 1 and the hinges' rows to its tolerance and
conserves energy, by Baumgarte's stabilisation and by projection. Speed is not checked here
(bench/). Bounds: the measured value (in the comment) with room for another CPU, never
tighter than 3 times it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from references.formulations import Mechanism, build, run
from references.spatial import rot, skewed_double_pendulum, torque_free

G = (0.0, 0.0, -9.81)
BODIES = [dict(name="l1", m=1.0, J=np.diag([0.01, 0.09, 0.09])),
          dict(name="l2", m=0.5, J=np.diag([0.005, 0.04, 0.04]))]
HINGES = [dict(parent=-1, axis=[0, 1, 0.2], point_a=[0, 0, 0], point_b=[-0.5, 0, 0]),
          dict(parent=0, axis=[0.3, 1, 0], point_a=[0.5, 0, 0], point_b=[-0.4, 0, 0])]
THETA0, RATE0 = tuple(np.radians([30.0, -20.0])), (0.0, 1.0)
TOL = 1e-10


@pytest.fixture(scope="module")
def program(tmp_path_factory):
    return build(tmp_path_factory.mktemp("formulations"))


@pytest.fixture(scope="module")
def pendulum_reference():
    t = np.round(np.arange(301) * 0.01, 12)
    return skewed_double_pendulum(t, g=np.array(G), bodies=BODIES, hinges=HINGES,
                                  theta0=THETA0, rate0=RATE0)


@pytest.mark.parametrize("method", ["ep", "ep-project"])
def test_euler_parameters_follow_the_joint_coordinates(program, pendulum_reference, method,
                                                       tmp_path):
    mech = Mechanism("pendulum", BODIES, HINGES, gravity=G, theta0=THETA0, rate0=RATE0)
    out = run(program, mech, method, tmp_path, tol=TOL, t_end=3.0, dt_out=0.01)
    assert len(out["t"]) == 301
    assert np.max(np.abs(out["R"] - pendulum_reference["R"])) < 15 * TOL  # 1.3, 4.1 tol
    assert np.max(np.abs(out["r"] - pendulum_reference["r"])) < 15 * TOL  # 0.8, 1.4 tol
    energy = out["energy"]
    assert abs(energy[0] - pendulum_reference["energy"][0]) < 1e-12 * abs(energy[0])
    assert np.ptp(energy) < 35 * TOL * abs(energy[0])  # 1.6, 10.8 tol
    # every row, the norm rows among them, at every accepted step: Baumgarte leaves a
    # fraction of tol, the projection a hundredth of it
    assert out["worst_residual"] < (0.5 if method == "ep" else 0.011) * TOL  # 0.15, 0.010


def test_euler_parameters_of_a_tumbling_body_keep_their_norm_and_flip_with_the_reference(
        program, tmp_path):
    """The torque-free body of tests/runtime/test_spatial.py, spun about its middle axis:
    the norm row is its only row."""
    R0 = rot([0.2, -0.4, 1.0], 0.7)
    omega0 = R0 @ np.array([1e-3, 2 * math.pi, 1e-3])
    J = np.diag([2.0, 3.0, 4.0])
    mech = Mechanism("tumbling", [dict(name="top", m=5.0, J=J)], free=True, R0=R0,
                     omega0=omega0)
    out = run(program, mech, "ep-project", tmp_path, tol=TOL, t_end=6.0, dt_out=0.005)
    reference = torque_free(out["t"], J=J, R0=R0, omega0=omega0)
    R = out["R"][:, 0]
    assert np.max(np.abs(R - reference["R"])) < 400 * TOL  # 111 tol: six turns and a flip
    assert out["worst_residual"] < 0.011 * TOL  # | |p|^2 - 1 | at every step: 0.010 tol
    assert np.ptp(out["energy"]) < 35 * TOL * out["energy"][0]  # 10.8 tol
    spin = np.einsum("nji,nj->ni", R, reference["omega"])[:, 1]  # about the middle axis
    flips = out["t"][np.nonzero(np.diff(np.sign(spin)))[0]]
    expected = out["t"][np.nonzero(np.diff(np.sign(reference["omega_body"][:, 1])))[0]]
    assert len(expected) >= 1 and len(flips) == len(expected)
    np.testing.assert_allclose(flips, expected, atol=0.006)
