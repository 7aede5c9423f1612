"""A spatial slider-crank against its one-angle solution by the energy integral.

The crank turns about the world x axis through the origin (its centre of mass on the axis);
its pin, r from the axis, drives a rod of length L through a ball joint; the rod's other end
is a ball joint on a slider block (a particle) that runs on a line skewed to the crank's
plane. The rod is axisymmetric (moments I_a about its axis, I_p across it), so its spin about
its own axis is free and stays what it starts at (the ball joints' forces act through the
axis): the motion is one angle theta, with

    A(theta) = r (0, cos theta, sin theta),  B = p0 + s u,  |B - A| = L,
    T = (I_crank + m_rod |dr_rod/dtheta|^2 + I_p |de/dtheta|^2 + m_block (ds/dtheta)^2)
        theta'^2 / 2,   V = -g . (m_rod r_rod + m_block B),

e = (A - B) / L the rod's axis and r_rod = (A + B) / 2. Energy gives theta' as a function of
theta; the time to reach theta is the integral of dtheta / theta', by quadrature at 1e-13
(scipy's quad), never through depsim's derivation. The crank keeps turning (enough energy)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

import depsim

R, L = 0.1, 0.5
M_CRANK_AXIS = 0.02  # kg m^2 about the x axis
M_ROD, I_AXIAL, I_CROSS = 0.6, 2e-4, 0.6 * L**2 / 12 + 1e-4
M_BLOCK = 0.4
P0 = np.array([0.35, -0.1, 0.2])
U = np.array([1.0, 0.4, -0.3]) / np.linalg.norm([1.0, 0.4, -0.3])
G = np.array([0.0, 0.0, -9.81])
OMEGA0 = 8.0  # rad/s


def geometry(theta: float):
    """(A, B, s, dA, ds, e, de) at crank angle theta (the branch with the block beyond the
    crank along u)."""
    A = R * np.array([0.0, math.cos(theta), math.sin(theta)])
    dA = R * np.array([0.0, -math.sin(theta), math.cos(theta)])
    w = A - P0
    along = U @ w
    s = along + math.sqrt(along**2 - w @ w + L**2)
    B = P0 + s * U
    ds = (B - A) @ dA / ((B - A) @ U)
    e = (A - B) / L
    de = (dA - ds * U) / L
    return A, B, s, dA, ds, e, de


def mass_and_potential(theta: float) -> tuple[float, float]:
    A, B, _, dA, ds, _, de = geometry(theta)
    rod_rate = (dA + ds * U) / 2
    mass = M_CRANK_AXIS + M_ROD * rod_rate @ rod_rate + I_CROSS * de @ de + M_BLOCK * ds**2
    potential = -G @ (M_ROD * (A + B) / 2 + M_BLOCK * B)
    return mass, potential


def reference_time(theta: float) -> float:
    mass0, potential0 = mass_and_potential(0.0)
    energy = 0.5 * mass0 * OMEGA0**2 + potential0

    def slowness(phi: float) -> float:
        mass, potential = mass_and_potential(phi)
        return math.sqrt(mass / (2 * (energy - potential)))

    return quad(slowness, 0.0, theta, epsabs=1e-13, epsrel=1e-13, limit=200)[0]


def rod_orientation() -> str:
    """The rod's x axis from A to B at theta = 0 (the assembly closes the loop from there)."""
    A, B, *_ = geometry(0.0)
    d = (B - A) / L
    yaw, pitch = float(math.atan2(d[1], d[0])), float(-math.asin(d[2]))
    return f"rz({yaw!r} rad) * ry({pitch!r} rad)"


MODEL = f"""model spatial_crank spatial "A spatial slider-crank"
gravity = ({G[0]}, {G[1]}, {G[2]}) m/s^2
ground {{ point rail = ({float(P0[0])!r}, {float(P0[1])!r}, {float(P0[2])!r}) m }}
body crank {{
    mass = 1 kg
    inertia = ({M_CRANK_AXIS}, 0.015, 0.015) kg*m^2
    point pin = (0, {R}, 0) m
}}
bar rod {{
    length = {L} m
    mass = {M_ROD} kg
    inertia = ({I_AXIAL}, {I_CROSS!r}, {I_CROSS!r}) kg*m^2
    orientation = {rod_orientation()}
}}
particle block {{ mass = {M_BLOCK} kg }}
hinge drive joins ground.origin to crank.cm {{ axis = (1, 0, 0) }}
ball big_end joins crank.pin to rod.a {{ }}
slider rail joins ground.rail to block.cm {{ axis = ({float(U[0])!r}, {float(U[1])!r}, {float(U[2])!r}) }}
ball small_end joins rod.b to block.cm {{ }}
initial {{ drive = 0 deg; drive.rate = {OMEGA0} rad/s }}
simulate {{ t_end = 1.5 s; tol = 1e-9; dt_out = 0.01 s }}
output theta = drive
output slide = rail
output energy = system.energy
"""


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("spatial_crank")
    path = folder / "spatial_crank.dep"
    path.write_text(MODEL)
    return depsim.load(path).compile("c", out_dir=folder / "c").run()


def test_the_crank_reaches_each_angle_when_the_energy_integral_says(run):
    """The run's crank angle theta(t_k), unwrapped, reached at t_ref(theta(t_k)): the time
    error times the crank's rate is its angle error (a few tol: the slow motion of one turn
    and a half)."""
    theta = np.unwrap(run.output("theta"))
    assert theta[-1] > 2 * math.pi  # it turns over the top more than once
    times = np.array([reference_time(value) for value in theta[1:]])
    rates = run.hinge_rates[1:, 0]
    error = np.max(np.abs((times - run.times[1:]) * rates))
    assert error < 30 * run.tol  # 6.1 tol (3.6 and 11 at tol 1e-7 and 1e-11)


def test_the_block_sits_where_the_loop_closes(run):
    """The slider's displacement from the rail's point p0 is the closed form's s(theta): the
    loop held to the passes' limits (the assembly closing it from the rod's free spin, a
    direction the loop does not fix)."""
    theta = run.output("theta")
    expected = np.array([geometry(value)[2] for value in theta])
    assert np.max(np.abs(run.output("slide") - expected)) < 0.01 * run.tol * L  # 4e-4 tol L


def test_its_energy_stays(run):
    energy = run.output("energy")
    kinetic_scale = 0.5 * mass_and_potential(0.0)[0] * OMEGA0**2
    assert np.ptp(energy) < 10 * run.tol * kinetic_scale  # 2.0 tol
