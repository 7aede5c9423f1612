"""Self-checks of the spatial references (tests/references/spatial.py): conservation laws, closed
forms and, for the double pendulum, a second derivation (sympy.physics.mechanics' Kane's
method, its kinematics differentiated by sympy from the positions and orientations; its
accelerations are compared with the reference's own, _Chain's, at random states)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
import sympy.physics.mechanics as me
from scipy.integrate import solve_ivp

from references.spatial import (_Chain, bennett_geometry, bennett_output_angle, heavy_top,
                                lagrange_top_steady_precession, lagrange_top_steady_state, rot,
                                skewed_double_pendulum, torque_free)

X, Z = np.eye(3)[0], np.eye(3)[2]

# ----------------------------------------------------------------- skewed double pendulum

G = np.array([0.0, 0.0, -9.81])
BODIES = [
    {"m": 2.0, "J": np.array([[0.06, 0.01, -0.005], [0.01, 0.09, 0.01], [-0.005, 0.01, 0.05]])},
    {"m": 1.5, "J": np.array([[0.03, 0.0, 0.004], [0.0, 0.02, 0.0], [0.004, 0.0, 0.04]])},
]
HINGES = [  # skewed, unnormalised axes; attachment points off the bodies' principal axes
    {"axis": [0.0, 1.0, 0.3], "point_a": [0.1, -0.2, 0.05], "point_b": [0.1, 0.05, 0.4]},
    {"axis": [1.0, 0.2, 0.5], "point_a": [0.05, 0.0, -0.4], "point_b": [0.0, 0.1, 0.3]},
]
THETA0 = np.array([1.0, -0.5])
RATE0 = np.array([0.5, 2.0])


def kane_pendulum(g, bodies, hinges):
    """The same double pendulum by sympy's KanesMethod: M(q) u' = F(q, u) and the poses, as
    numpy functions of (q, u); the orientations come from ReferenceFrame.orient_axis and the CM
    velocities from differentiating the CM positions in the world frame."""
    q = me.dynamicsymbols("q1 q2")
    u = me.dynamicsymbols("u1 u2")
    world = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(world, 0)

    def vector(frame, components):
        return sum((float(c) * e for c, e in zip(components, (frame.x, frame.y, frame.z))),
                   sp.S.Zero * frame.x)

    parent, parent_cm = world, origin
    rigid_bodies, loads, poses = [], [], []
    for i, (body, hinge) in enumerate(zip(bodies, hinges)):
        frame = me.ReferenceFrame(f"B{i}")
        axis = np.asarray(hinge["axis"], dtype=float)
        frame.orient_axis(parent, vector(parent, axis / np.linalg.norm(axis)), q[i])
        joint = parent_cm.locatenew(f"H{i}", vector(parent, hinge["point_a"]))
        cm = joint.locatenew(f"C{i}", -vector(frame, hinge["point_b"]))
        cm.set_vel(world, cm.pos_from(origin).dt(world))
        J = body["J"]
        inertia = me.inertia(frame, J[0, 0], J[1, 1], J[2, 2], J[0, 1], J[1, 2], J[2, 0])
        rigid_bodies.append(me.RigidBody(f"b{i}", cm, frame, body["m"], (inertia, cm)))
        loads.append((cm, body["m"] * vector(world, g)))
        poses.append((cm.pos_from(origin).to_matrix(world), world.dcm(frame)))
        parent, parent_cm = frame, cm
    kane = me.KanesMethod(world, q_ind=q, u_ind=u,
                          kd_eqs=[q[k].diff() - u[k] for k in range(2)])
    kane.kanes_equations(rigid_bodies, loads)
    equations = sp.lambdify([q, u], [kane.mass_matrix, kane.forcing], cse=True)
    pose = sp.lambdify([q], poses, cse=True)

    def acceleration(q_value, u_value):
        M, F = equations(q_value, u_value)
        return np.linalg.solve(np.array(M, dtype=float), np.array(F, dtype=float).ravel())

    def pose_arrays(q_value):
        values = pose(q_value)
        return (np.array([np.ravel(r) for r, _ in values], dtype=float),
                np.array([R for _, R in values], dtype=float))

    return acceleration, pose_arrays


@pytest.fixture(scope="module")
def kane():
    return kane_pendulum(G, BODIES, HINGES)


@pytest.fixture(scope="module")
def pendulum():
    t = np.linspace(0.0, 3.0, 301)
    return t, skewed_double_pendulum(t, g=G, bodies=BODIES, hinges=HINGES, theta0=THETA0,
                                     rate0=RATE0)


def test_double_pendulum_conserves_energy(pendulum):
    _, out = pendulum
    energy = out["energy"]
    assert abs(energy[0]) > 5.0  # J, so relative to it means something
    assert np.max(np.abs(energy - energy[0])) < 1e-10 * abs(energy[0])


def test_double_pendulum_poses_follow_the_conventions(pendulum):
    """R_1 = rot(a_1, theta_1), R_2 = R_1 rot(a_2, theta_2), and both hinge points coincide."""
    _, out = pendulum
    for theta, r, R in zip(out["theta"], out["r"], out["R"]):
        assert np.allclose(R[0], rot(HINGES[0]["axis"], theta[0]), atol=1e-14)
        assert np.allclose(R[1], R[0] @ rot(HINGES[1]["axis"], theta[1]), atol=1e-14)
        assert np.allclose(HINGES[0]["point_a"], r[0] + R[0] @ HINGES[0]["point_b"], atol=1e-14)
        assert np.allclose(r[0] + R[0] @ HINGES[1]["point_a"], r[1] + R[1] @ HINGES[1]["point_b"],
                           atol=1e-14)


def test_double_pendulum_accelerations_match_kanes_method(kane):
    """The equations of motion themselves, at random states (well away from the start's)."""
    acceleration, _ = kane
    chain = _Chain(G, BODIES, HINGES)
    rng = np.random.default_rng(1)
    for _ in range(50):
        theta, rate = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-5.0, 5.0, 2)
        reference = acceleration(theta, rate)
        ours = chain.rhs(0.0, np.concatenate([theta, rate]))[2:]
        assert np.max(np.abs(ours - reference)) < 1e-11 * np.max(np.abs(reference))


def test_double_pendulum_trajectory_matches_kanes_method(pendulum, kane):
    t, out = pendulum
    acceleration, pose = kane
    solution = solve_ivp(lambda _t, y: np.concatenate([y[2:], acceleration(y[:2], y[2:])]),
                         (0.0, t[-1]), np.concatenate([THETA0, RATE0]), method="DOP853",
                         t_eval=t, rtol=1e-12, atol=1e-12)
    assert solution.success
    assert np.max(np.abs(out["theta"] - solution.y[:2].T)) < 1e-8
    assert np.max(np.abs(out["rate"] - solution.y[2:].T)) < 1e-8
    for k in range(0, len(t), 30):
        r, R = pose(solution.y[:2, k])
        assert np.allclose(out["r"][k], r, atol=1e-8)
        assert np.allclose(out["R"][k], R, atol=1e-8)


# ---------------------------------------------------------------------------- heavy top


def test_heavy_top_conserves_energy_and_vertical_angular_momentum():
    """An asymmetric top, pivot off the principal axes, gravity not along a world axis."""
    g = np.array([1.0, -2.0, -9.5])
    pivot = np.array([0.02, -0.01, -0.12])
    J = np.array([[0.010, 0.001, 0.0], [0.001, 0.015, -0.002], [0.0, -0.002, 0.022]])
    t = np.linspace(0.0, 5.0, 501)
    out = heavy_top(t, g=g, m=1.3, J=J, pivot=pivot, R0=rot([1.0, 1.0, 0.2], 0.7),
                    omega0=[1.0, -2.0, 25.0])
    for key in ("energy", "h_vertical"):
        assert np.max(np.abs(out[key] - out[key][0])) < 1e-9 * abs(out[key][0]), key
    assert np.allclose(out["r"], -out["R"] @ pivot, atol=1e-15)
    assert np.allclose(np.einsum("nji,njk->nik", out["R"], out["R"]), np.eye(3), atol=1e-13)
    assert np.ptp(out["r"] @ g) > 0.01  # it does nutate: the CM height changes


def test_symmetric_top_keeps_its_spin():
    """A Lagrange top conserves n = omega . e_z (its third integral), here with nutation."""
    t = np.linspace(0.0, 4.0, 401)
    R0, omega0 = lagrange_top_steady_state(g=G, tilt=0.5, spin=30.0, precession=0.0)
    out = heavy_top(t, g=G, m=0.8, J=np.diag([0.004, 0.004, 0.006]), pivot=[0.0, 0.0, -0.05],
                    R0=R0, omega0=omega0)
    spin = np.einsum("ni,ni->n", out["omega"], out["R"][:, :, 2])
    assert np.max(np.abs(spin - 30.0)) < 1e-9 * 30.0
    assert np.ptp(out["r"][:, 2]) > 1e-3  # started without precession, it nutates


TOP = {"m": 0.8, "A": 0.004, "C": 0.006, "l": 0.05}


@pytest.mark.parametrize("g", [G, np.array([2.0, 1.0, -9.0])])
@pytest.mark.parametrize("tilt", [0.6, 2.2])  # CM above, below the pivot
@pytest.mark.parametrize("branch", [0, 1])  # slow, fast
def test_lagrange_top_steady_precession(g, tilt, branch):
    spin = 20.0
    rate = lagrange_top_steady_precession(g=g, tilt=tilt, spin=spin, **TOP)[branch]
    t = np.linspace(0.0, 3 * 2 * np.pi / abs(rate), 301)  # three precession periods
    R0, omega0 = lagrange_top_steady_state(g=g, tilt=tilt, spin=spin, precession=rate)
    J = np.diag([TOP["A"], TOP["A"], TOP["C"]])
    out = heavy_top(t, g=g, m=TOP["m"], J=J, pivot=[0.0, 0.0, -TOP["l"]], R0=R0, omega0=omega0)
    up = -g / np.linalg.norm(g)
    axis = out["R"][:, :, 2]
    tilt_now = np.arctan2(np.linalg.norm(np.cross(axis, up), axis=1), axis @ up)
    assert np.max(np.abs(tilt_now - tilt)) < 1e-8
    h2 = R0[:, 1]  # the builder's horizontal basis: body y = h2 = up x h1
    h1 = np.cross(h2, up)
    azimuth = np.unwrap(np.arctan2(axis @ h2, axis @ h1))
    assert np.max(np.abs(azimuth - rate * t)) < 1e-8 * max(1.0, abs(rate) * t[-1])
    # the test can fail: 1 % off the root, the top nutates by far more than 1e-8 rad
    R0, omega0 = lagrange_top_steady_state(g=g, tilt=tilt, spin=spin, precession=1.01 * rate)
    out = heavy_top(t[:50], g=g, m=TOP["m"], J=J, pivot=[0.0, 0.0, -TOP["l"]], R0=R0,
                    omega0=omega0)
    assert np.ptp(out["R"][:, :, 2] @ up) > 1e-6


def test_steady_precession_roots():
    """Both roots solve A_O P^2 cos(tilt) - C n P + m g l = 0 and are ordered by size; the
    conical pendulum (no spin, CM below) has P = +-sqrt(m g l / (-A_O cos(tilt)))."""
    m, A, C, l, g = TOP["m"], TOP["A"], TOP["C"], TOP["l"], 9.81
    A_O = A + m * l * l
    for tilt, spin in [(0.6, 40.0), (2.2, 40.0), (0.3, -50.0), (2.5, 0.0)]:
        slow, fast = lagrange_top_steady_precession(g=G, tilt=tilt, spin=spin, **TOP)
        assert abs(slow) <= abs(fast) * (1 + 1e-14)  # equal for the conical pendulum
        for rate in (slow, fast):
            residual = A_O * rate ** 2 * math.cos(tilt) - C * spin * rate + m * g * l
            assert abs(residual) < 1e-12 * (A_O * rate ** 2 + abs(C * spin * rate) + m * g * l)
    conical = math.sqrt(m * g * l / (-A_O * math.cos(2.5)))
    assert sorted(lagrange_top_steady_precession(g=G, tilt=2.5, spin=0.0, **TOP)) == \
        pytest.approx([-conical, conical], rel=1e-14)
    assert lagrange_top_steady_precession(g=G, tilt=np.pi / 2, spin=40.0, **TOP)[0] == \
        pytest.approx(m * g * l / (C * 40.0), rel=1e-14)
    with pytest.raises(ValueError):
        lagrange_top_steady_precession(g=G, tilt=0.6, spin=1.0, **TOP)


# ---------------------------------------------------------------------------- torque free


def test_torque_free_conserves_angular_momentum_and_energy():
    J = np.array([[0.3, 0.02, -0.01], [0.02, 0.5, 0.03], [-0.01, 0.03, 0.7]])
    t = np.linspace(0.0, 10.0, 501)
    out = torque_free(t, J=J, R0=rot([0.3, -1.0, 0.5], 1.2), omega0=[2.0, -1.0, 3.0])
    h = out["h_world"]
    assert np.max(np.abs(h - h[0])) < 1e-10 * np.linalg.norm(h[0])
    assert np.max(np.abs(out["energy"] - out["energy"][0])) < 1e-10 * out["energy"][0]
    assert np.allclose(out["omega"], np.einsum("nij,nj->ni", out["R"], out["omega_body"]),
                       atol=1e-14)
    assert np.ptp(out["omega_body"], axis=0).min() > 0.1  # it does tumble


def test_symmetric_torque_free_body_matches_the_closed_form():
    """J = diag(A, A, C): R(t) = rot(h, |h| t / A) R0 rot(z, (1/C - 1/A) h_z t), h_z = h . e_z
    (the sum of two uniform rotations: about the fixed h, and about the body's axis)."""
    A, C = 0.4, 0.7
    R0 = rot([1.0, 2.0, -0.5], 0.9)
    omega0 = np.array([1.5, -0.7, 2.5])
    t = np.linspace(0.0, 10.0, 201)
    out = torque_free(t, J=np.diag([A, A, C]), R0=R0, omega0=omega0)
    h = R0 @ np.diag([A, A, C]) @ R0.T @ omega0
    h_z = h @ R0[:, 2]
    for k, time in enumerate(t):
        closed = rot(h, np.linalg.norm(h) * time / A) @ R0 @ rot(Z, (1 / C - 1 / A) * h_z * time)
        assert np.allclose(out["R"][k], closed, atol=1e-9)


J_PRINCIPAL = np.diag([2.0, 3.0, 4.0])  # kg m^2
SPIN = 2 * np.pi  # rad/s
FLIP_TIME = 5.0  # s: the perturbation grows like exp(SPIN sqrt(1/8) t); it first flips at 4.07 s


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_only_the_intermediate_axis_is_unstable(axis):
    """Spin SPIN about a principal axis, perturbed by 1e-3 SPIN about the other two."""
    W0 = np.full(3, 1e-3 * SPIN)
    W0[axis] = SPIN
    R0 = rot([1.0, -1.0, 2.0], 0.4)
    t = np.linspace(0.0, FLIP_TIME, 501)
    out = torque_free(t, J=J_PRINCIPAL, R0=R0, omega0=R0 @ W0)
    W = out["omega_body"][:, axis]
    if axis == 1:
        assert W.min() < 0  # flipped
    else:
        assert np.max(np.abs(out["omega_body"] - W0)) < 1e-2 * SPIN


# ------------------------------------------------------------------------- Bennett linkage


def dh(theta, length, twist):
    """The Denavit-Hartenberg transform Rot_z(theta) Trans_x(length) Rot_x(twist), 4x4."""
    T = np.eye(4)
    T[:3, :3] = rot(Z, theta) @ rot(X, twist)
    T[:3, 3] = length * rot(Z, theta) @ X
    return T


CASES = [(1.0, 0.5, 1.2), (0.3, 1.1, 0.4), (2.0, 2.5, 0.7), (1.0, 0.3, 2.9)]  # a, alpha, beta
THETAS = [0.3, 1.0, -0.7, 2.5, -3.0, np.pi]


@pytest.mark.parametrize("a, alpha, beta", CASES)
def test_bennett_loop_closes(a, alpha, beta):
    b = a * math.sin(beta) / math.sin(alpha)
    ratio = math.sin((beta + alpha) / 2) / math.sin((beta - alpha) / 2)
    for theta in THETAS:
        phi = bennett_output_angle(theta, alpha=alpha, beta=beta)
        assert -np.pi < phi <= np.pi
        assert math.tan(theta / 2) * math.tan(phi / 2) == pytest.approx(ratio, rel=1e-10)
        geometry = bennett_geometry(theta, a=a, alpha=alpha, beta=beta)
        angles = geometry["angles"]
        assert angles == pytest.approx([theta, phi, -theta, -phi], abs=1e-15)
        loop = np.eye(4)
        for angle, length, twist in zip(angles, (a, b, a, b), (alpha, beta, alpha, beta)):
            loop = loop @ dh(angle, length, twist)
        assert np.max(np.abs(loop - np.eye(4))) < 1e-12 * max(1.0, a, b)


@pytest.mark.parametrize("a, alpha, beta", CASES)
def test_bennett_geometry_is_the_linkage(a, alpha, beta):
    """Construction-free checks: consecutive axes are a_i apart along their common normal, at
    twist alpha_i about it; the ground is placed as stated; and each joint is the documented
    depsim hinge (R_B = R_A rot(axis, angle) R0, points coinciding)."""
    b = a * math.sin(beta) / math.sin(alpha)
    lengths, twists = (a, b, a, b), (alpha, beta, alpha, beta)
    for theta in THETAS:
        geometry = bennett_geometry(theta, a=a, alpha=alpha, beta=beta)
        P, z, F = geometry["points"], geometry["axes"], geometry["frames"]
        angles = geometry["angles"]
        assert np.allclose(F[0], np.eye(3), atol=0) and np.allclose(P[0], 0, atol=0)
        assert np.allclose(P[1], [a, 0, 0], atol=1e-15)
        assert np.allclose(z[1], [0, -math.sin(alpha), math.cos(alpha)], atol=1e-15)
        for i in range(4):
            j = (i + 1) % 4
            link = P[j] - P[i]
            assert np.linalg.norm(link) == pytest.approx(lengths[i], rel=1e-12)
            x = link / lengths[i]
            assert abs(x @ z[i]) < 1e-12 and abs(x @ z[j]) < 1e-12
            assert z[i] @ z[j] == pytest.approx(math.cos(twists[i]), abs=1e-12)
            assert np.cross(z[i], z[j]) @ x == pytest.approx(math.sin(twists[i]), abs=1e-12)
            assert np.allclose(F[i][:, 0], x, atol=1e-12) and np.allclose(F[i][:, 2], z[i])
            assert np.allclose(F[i].T @ F[i], np.eye(3), atol=1e-14)
        for i in (1, 2, 3):  # hinge link i-1 -> link i
            twist = twists[i - 1]
            axis = np.array([0.0, -math.sin(twist), math.cos(twist)])
            assert np.allclose(F[i], F[i - 1] @ rot(axis, angles[i]) @ rot(X, twist), atol=1e-12)
            assert np.allclose(P[i - 1] + F[i - 1] @ [lengths[i - 1], 0, 0], P[i], atol=1e-12)
        # joint 1: ground -> link 4 about -z, R0 = Rot_x(-beta), link 4's point (b, 0, 0)
        assert np.allclose(F[3], rot(-Z, angles[0]) @ rot(X, -beta), atol=1e-12)
        assert np.allclose(P[3] + F[3] @ [b, 0, 0], 0, atol=1e-12)


def test_bennett_output_angle_is_vectorised_and_continuous():
    theta = np.linspace(-3.0, 3.0, 601)
    phi = bennett_output_angle(theta, alpha=0.5, beta=1.2)
    assert phi.shape == theta.shape
    assert phi[300] == pytest.approx(np.pi, abs=1e-12)  # theta = 0
    assert np.max(np.abs(np.diff(np.unwrap(phi)))) < 0.1
