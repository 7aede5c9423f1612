"""Particles: point masses with coordinates (x, y) and no angle (docs/language.md, particle).

A pendulum of length L = 1 m whose bob is a particle welded to the tip of a light bar
(1 % of the bob's mass), released horizontally: its angle is the exact solution of the
compound pendulum, theta(t) = 2 asin(k sn(K(k) - omega0 t, k)), k = sin(theta0 / 2),
omega0^2 = g (sum m d) / J_O (scipy's Jacobi elliptic functions), and the run is compared
with it over 2000 s (about 830 periods) and with a finer run.
"""

import numpy as np
import pytest
from scipy.special import ellipj, ellipk

from depsim.runtime import simulate

PENDULUM = """model particle_pendulum "a particle on a light bar, released horizontally"
gravity = (0, -9.81) m/s^2
bar rod {{ length = 1 m; mass = 0.01 kg; inertia = 0.01 kg * 1 m^2 / 12 }}
particle bob {{ mass = 1 kg }}
hinge pivot joins ground.origin to rod.a {{ angle = rod - ground + 90 deg }}
{joint} tip joins rod.b to bob.cm
initial {{ pivot = 90 deg }}
simulate {{ t_end = 2000 s; tol = 1e-8; dt_out = 1 s }}
output x = bob.x
output y = bob.y
output H = angular_momentum(ground.origin)
"""
G, L, ROD, BOB = 9.81, 1.0, 0.01, 1.0


def exact_position(t):
    """The bob's position (x, y) of the compound pendulum released from rest at 90 deg."""
    inertia = ROD * L * L / 12 + ROD * (L / 2) ** 2 + BOB * L * L
    omega0 = np.sqrt(G * (ROD * L / 2 + BOB * L) / inertia)
    m = np.sin(np.pi / 4) ** 2
    sn = ellipj(ellipk(m) - omega0 * t, m)[0]
    theta = 2 * np.arcsin(np.sqrt(m) * sn)
    return L * np.sin(theta), -L * np.cos(theta)


@pytest.fixture(scope="module")
def pendulum(build_c):
    return build_c(PENDULUM.format(joint="weld"))


def position_error(result):
    x, y = exact_position(result.times)
    return np.hypot(result.output("x") - x, result.output("y") - y)


def test_the_particle_has_two_coordinates_and_no_angle(pendulum):
    assert pendulum.COORDINATES == ("rod.x", "rod.y", "rod.phi", "bob.x", "bob.y")
    assert pendulum.CONSTRAINTS == ("pivot.x", "pivot.y", "tip.x", "tip.y")


def test_particle_pendulum_follows_the_closed_form_for_2000_s(pendulum):
    """Measured: 1.7e-4 m at tol 1e-10 (974,220 steps); the error is the method's phase
    drift, growing with the square of time (6.2e-3 m at tol 1e-8, 1.1e-3 at 1e-9)."""
    result = simulate(pendulum, tol=1e-10)
    assert np.max(position_error(result)) < 1e-3


def test_particle_pendulum_at_tol_1e8_agrees_with_a_finer_run(pendulum):
    """Over the first 200 s (83 periods) tol 1e-8 is within 1e-4 m of the closed form and
    of a run at tol 1e-10."""
    coarse = simulate(pendulum, t_end=200.0, tol=1e-8)
    fine = simulate(pendulum, t_end=200.0, tol=1e-10)
    assert np.max(position_error(coarse)) < 1e-4
    assert np.max(np.abs(coarse.outputs[:, :2] - fine.outputs[:, :2])) < 1e-4


def test_a_hinge_holds_a_particle_as_a_weld_does(build_c):
    """A particle has no angle, so a hinge to one has the weld's two rows: the same run."""
    hinged = simulate(build_c(PENDULUM.format(joint="hinge")), t_end=5.0)
    welded = simulate(build_c(PENDULUM.format(joint="weld")), t_end=5.0)
    np.testing.assert_allclose(hinged.outputs, welded.outputs, rtol=0, atol=1e-12)


def test_the_angular_momentum_about_the_pivot_is_its_rate_of_change(pendulum):
    """dH_O/dt = the moment of gravity about the pivot, -g sum m x (finite differences of
    the output against the positions)."""
    result = simulate(pendulum, t_end=2.0, dt_out=1e-3)
    H, t = result.output("H"), result.times
    rate = np.gradient(H, t)[5:-5]
    rod_x = result.q[:, 0]
    moment = -G * (BOB * result.output("x") + ROD * rod_x)[5:-5]
    assert np.max(np.abs(rate - moment)) < 1e-4 * np.max(np.abs(moment))
