"""Independent references for spatial (3-D) rigid multibody models.

Written by hand with numpy in minimal (joint) coordinates and integrated with scipy's DOP853
(rtol = atol = 1e-12); nothing here comes from depsim. tests/references/test_spatial_reference.py
checks every function against conservation laws, closed forms and a second derivation.

Conventions (SI units throughout; shared with depsim):

* The world frame is fixed; gravity is the vector ``g`` (3,), in m/s^2. Potential energy of a
  body of mass m with centre of mass (CM) at r is m (-g . r).
* A rigid body has mass m, inertia tensor J (3x3, symmetric, about its CM, in the BODY frame),
  orientation R (3x3, body -> world: world vector = R @ body vector) and CM position r (world).
  Body points are given in the body frame relative to the CM: their world position is r + R @ p.
  "Angular velocity" omega is in the world frame unless called omega_body (= R^T omega).
* ``rot(axis, angle)``: the right-handed rotation by ``angle`` about the unit vector ``axis``
  (Rodrigues).
* A hinge (revolute joint) joins member A (the ground or a body) to member B. Its axis ``a`` is a
  unit vector in A's frame (the ground's frame is the world). Its angle theta is the right-hand
  rotation of B relative to A about the axis: R_B = R_A @ rot(a, theta) @ R0, R0 being B's
  reference orientation relative to A (identity unless stated). It attaches a point p_A of A
  (A's frame) to a point p_B of B (B's frame): r_A + R_A p_A = r_B + R_B p_B.
* Every simulation takes output times ``t`` (1-D, strictly increasing, t[0] = 0) and returns a
  dict of numpy arrays sampled at those times, time along the first axis.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

Array = NDArray[np.float64]

RTOL = 1e-12
ATOL = 1e-12


# ----------------------------------------------------------------------------- helpers


def rot(axis: ArrayLike, angle: float) -> Array:
    """The right-handed rotation by ``angle`` (rad) about ``axis`` (normalised here): Rodrigues."""
    return _rodrigues(_unit(axis), angle)


def _rodrigues(axis: Array, angle: float) -> Array:
    """rot() about a unit axis: cos I + sin [axis]x + (1 - cos) axis axis^T, written out."""
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    k = 1.0 - c
    return np.array([[c + k * x * x, k * x * y - s * z, k * x * z + s * y],
                     [k * x * y + s * z, c + k * y * y, k * y * z - s * x],
                     [k * x * z - s * y, k * y * z + s * x, c + k * z * z]])


def _unit(v: ArrayLike) -> Array:
    v = np.asarray(v, dtype=float).reshape(3)
    norm = np.linalg.norm(v)
    if norm == 0.0:
        raise ValueError("zero vector where a direction is needed")
    return v / norm


def _cross(a: Array, b: Array) -> Array:
    """a x b for two 3-vectors (np.cross is an order of magnitude slower on them)."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def _rotation_matrix(R: ArrayLike) -> Array:
    R = np.asarray(R, dtype=float).reshape(3, 3)
    if np.max(np.abs(R.T @ R - np.eye(3))) > 1e-9 or np.linalg.det(R) < 0:
        raise ValueError("not a proper rotation matrix (to 1e-9)")
    return R


def _quaternion_to_matrix(q: Array) -> Array:
    """Rotation matrix (..., 3, 3) of unit quaternions q = (w, x, y, z) (..., 4), scalar first."""
    w, x, y, z = (q[..., k] for k in range(4))
    rows = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def _matrix_to_quaternion(R: Array) -> Array:
    """A unit quaternion (w, x, y, z) of the rotation matrix R (Shepperd's method)."""
    trace = np.trace(R)
    k = int(np.argmax([trace, R[0, 0], R[1, 1], R[2, 2]]))
    if k == 0:
        w = 0.5 * math.sqrt(1.0 + trace)
        q = [w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w),
             (R[1, 0] - R[0, 1]) / (4 * w)]
    elif k == 1:
        x = 0.5 * math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        q = [(R[2, 1] - R[1, 2]) / (4 * x), x, (R[0, 1] + R[1, 0]) / (4 * x),
             (R[0, 2] + R[2, 0]) / (4 * x)]
    elif k == 2:
        y = 0.5 * math.sqrt(1.0 - R[0, 0] + R[1, 1] - R[2, 2])
        q = [(R[0, 2] - R[2, 0]) / (4 * y), (R[0, 1] + R[1, 0]) / (4 * y), y,
             (R[1, 2] + R[2, 1]) / (4 * y)]
    else:
        z = 0.5 * math.sqrt(1.0 - R[0, 0] - R[1, 1] + R[2, 2])
        q = [(R[1, 0] - R[0, 1]) / (4 * z), (R[0, 2] + R[2, 0]) / (4 * z),
             (R[1, 2] + R[2, 1]) / (4 * z), z]
    return np.array(q)


def _integrate(rhs: Callable[[float, Array], Array], t: ArrayLike, y0: Array) -> Array:
    """The states (len(t), len(y0)) of y' = rhs(t, y), y(0) = y0, by DOP853 at RTOL, ATOL."""
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size == 0 or t[0] != 0.0 or np.any(np.diff(t) <= 0):
        raise ValueError("t must be 1-D, strictly increasing and start at 0")
    if t.size == 1:
        return y0[None, :].copy()
    solution = solve_ivp(rhs, (0.0, t[-1]), y0, method="DOP853", t_eval=t, rtol=RTOL, atol=ATOL)
    if not solution.success:
        raise RuntimeError(f"integration failed: {solution.message}")
    return solution.y.T


# --------------------------------------------------------------- skewed double pendulum


class _Chain:
    """A serial chain of hinged bodies from the ground, in its hinge angles q (minimal
    coordinates). Body i hangs from hinge i, whose member A is body i-1 (the ground for i = 0).

    Kane's equations: with hinge i's world axis e_i and world point P_i, body i's angular
    velocity is w_i = sum_{j<=i} qd_j e_j and its CM velocity v_i = sum_{j<=i} qd_j e_j x
    (r_i - P_j), both linear in qd (Jacobians Jw_i, Jv_i); differentiating with e_j' = w_{j-1} x
    e_j gives the accelerations Jw_i qdd + aw_i and Jv_i qdd + av_i. Projecting the Newton-Euler
    equations of every body on the Jacobians:
        sum_i [m_i Jv_i^T Jv_i + Jw_i^T I_i Jw_i] qdd
            = sum_i [m_i Jv_i^T (g - av_i) - Jw_i^T (I_i aw_i + w_i x I_i w_i)],
    I_i = R_i J_i R_i^T the world inertia about the CM.
    """

    def __init__(self, g: ArrayLike, bodies: Sequence[Mapping], hinges: Sequence[Mapping]):
        if len(bodies) != len(hinges):
            raise ValueError("one hinge per body")
        self.g = np.asarray(g, dtype=float).reshape(3)
        self.mass = [float(body["m"]) for body in bodies]
        self.inertia = [np.asarray(body["J"], dtype=float).reshape(3, 3) for body in bodies]
        self.axis = [_unit(hinge["axis"]) for hinge in hinges]
        self.point_a = [np.asarray(hinge["point_a"], dtype=float).reshape(3) for hinge in hinges]
        self.point_b = [np.asarray(hinge["point_b"], dtype=float).reshape(3) for hinge in hinges]

    def pose(self, q: Array) -> tuple[list[Array], list[Array], list[Array], list[Array]]:
        """Orientations R_i, CM positions r_i, world hinge axes e_i and points P_i."""
        R_a, r_a = np.eye(3), np.zeros(3)
        Rs, rs, es, Ps = [], [], [], []
        for i, angle in enumerate(q):
            e = R_a @ self.axis[i]
            P = r_a + R_a @ self.point_a[i]
            R = R_a @ _rodrigues(self.axis[i], angle)
            r = P - R @ self.point_b[i]
            Rs.append(R)
            rs.append(r)
            es.append(e)
            Ps.append(P)
            R_a, r_a = R, r
        return Rs, rs, es, Ps

    def dynamics(self, q: Array, qd: Array) -> tuple[Array, Array]:
        """Mass matrix M(q) and right-hand side f(q, qd) of M qdd = f."""
        n = len(q)
        Rs, rs, es, Ps = self.pose(q)
        M = np.zeros((n, n))
        f = np.zeros(n)
        w_a, v_a, r_a = np.zeros(3), np.zeros(3), np.zeros(3)  # member A of hinge i (ground)
        e_rate = []  # e_j' = w_{j-1} x e_j
        point_velocity = []  # P_j', P_j being fixed in body j-1
        for i in range(n):
            e_rate.append(_cross(w_a, es[i]))
            point_velocity.append(v_a + _cross(w_a, Ps[i] - r_a))
            w = w_a + qd[i] * es[i]
            v = point_velocity[i] + _cross(w, rs[i] - Ps[i])
            Jw = np.zeros((3, n))
            Jv = np.zeros((3, n))
            aw = np.zeros(3)
            av = np.zeros(3)
            for j in range(i + 1):
                arm = rs[i] - Ps[j]
                Jw[:, j] = es[j]
                Jv[:, j] = _cross(es[j], arm)
                aw += qd[j] * e_rate[j]
                av += qd[j] * (_cross(e_rate[j], arm) + _cross(es[j], v - point_velocity[j]))
            inertia = Rs[i] @ self.inertia[i] @ Rs[i].T
            m = self.mass[i]
            M += m * Jv.T @ Jv + Jw.T @ inertia @ Jw
            f += m * Jv.T @ (self.g - av) - Jw.T @ (inertia @ aw + _cross(w, inertia @ w))
            w_a, v_a, r_a = w, v, rs[i]
        return M, f

    def energy(self, q: Array, qd: Array) -> float:
        """Kinetic plus gravity potential energy."""
        M, _ = self.dynamics(q, qd)
        _, rs, _, _ = self.pose(q)
        return 0.5 * qd @ M @ qd - sum(m * (self.g @ r) for m, r in zip(self.mass, rs))

    def rhs(self, _t: float, y: Array) -> Array:
        n = len(self.mass)
        q, qd = y[:n], y[n:]
        M, f = self.dynamics(q, qd)
        return np.concatenate([qd, np.linalg.solve(M, f)])


def skewed_double_pendulum(t: ArrayLike, *, g: ArrayLike, bodies: Sequence[Mapping],
                           hinges: Sequence[Mapping], theta0: ArrayLike,
                           rate0: ArrayLike) -> dict[str, Array]:
    """Two bodies in an open chain: ground -- hinge 1 -- body 1 -- hinge 2 -- body 2.

    bodies: two mappings {"m": mass (kg), "J": 3x3 inertia about the CM in the body frame}.
    hinges: two mappings {"axis": (3,) in member A's frame (normalised here), "point_a": (3,) in
    A's frame, "point_b": (3,) in B's frame from B's CM}. Hinge 1: A = ground (axis and point in
    the world), B = body 1; hinge 2: A = body 1, B = body 2. R0 = identity for both, so
        R_1 = rot(axis_1, theta_1),   R_2 = R_1 @ rot(axis_2, theta_2),
        r_1 = point_a_1 - R_1 point_b_1,   r_2 = r_1 + R_1 point_a_2 - R_2 point_b_2
    (at theta = 0 both bodies have the world orientation). The axes may be skewed (any
    non-parallel pair). theta0, rate0: initial hinge angles (rad) and rates (rad/s), (2,).
    No friction, springs or stops.

    Returns "theta" (n, 2), "rate" (n, 2), "r" (n, 2, 3) CM positions, "R" (n, 2, 3, 3) and
    "energy" (n,): kinetic + sum_i m_i (-g . r_i), J.
    """
    chain = _Chain(g, bodies, hinges)
    if len(chain.mass) != 2:
        raise ValueError("two bodies and two hinges")
    y0 = np.concatenate([np.asarray(theta0, dtype=float).reshape(2),
                         np.asarray(rate0, dtype=float).reshape(2)])
    y = _integrate(chain.rhs, t, y0)
    poses = [chain.pose(state[:2]) for state in y]
    return {
        "theta": y[:, :2],
        "rate": y[:, 2:],
        "r": np.array([pose[1] for pose in poses]),
        "R": np.array([pose[0] for pose in poses]),
        "energy": np.array([chain.energy(state[:2], state[2:]) for state in y]),
    }


# ------------------------------------------------------ rotation about a fixed point


def _rotate_about_fixed_point(t: ArrayLike, inertia: Array, R0: Array, omega0: Array,
                              moment: Callable[[Array], Array]) -> tuple[Array, Array]:
    """Orientations R (n, 3, 3) and body angular velocities (n, 3) of a body turning about a
    point fixed in it and in the world: Euler's equations inertia W' = (inertia W) x W +
    moment(R) (body frame, inertia and moment about the fixed point) and the unit quaternion
    q = (w, x, y, z) of R, q' = q (x) (0, W) / 2, its norm kept by using q / |q| for R."""
    inverse = np.linalg.inv(inertia)

    def rhs(_t: float, y: Array) -> Array:
        q, W = y[:4], y[4:]
        R = _quaternion_to_matrix(q / np.linalg.norm(q))
        W_rate = inverse @ (_cross(inertia @ W, W) + moment(R))
        q_rate = 0.5 * np.concatenate([[-q[1:] @ W], q[0] * W + _cross(q[1:], W)])
        return np.concatenate([q_rate, W_rate])

    y0 = np.concatenate([_matrix_to_quaternion(R0), R0.T @ omega0])
    y = _integrate(rhs, t, y0)
    q = y[:, :4] / np.linalg.norm(y[:, :4], axis=1, keepdims=True)
    return _quaternion_to_matrix(q), y[:, 4:]


def heavy_top(t: ArrayLike, *, g: ArrayLike, m: float, J: ArrayLike, pivot: ArrayLike,
              R0: ArrayLike, omega0: ArrayLike) -> dict[str, Array]:
    """A rigid body on a spherical joint at the world origin, under gravity g (nonzero).

    m, J: mass and 3x3 inertia about the CM (body frame). pivot: the body point (body frame,
    from the CM) held at the world origin, so the CM is at r = -R @ pivot. R0: initial
    orientation; omega0: initial angular velocity, WORLD frame (the CM velocity follows).
    Euler's equations about the pivot with J_O = J + m (|p|^2 I - p p^T), p = pivot, and the
    gravity moment (-R p) x (m g); quaternion attitude.

    Returns "R" (n, 3, 3), "r" (n, 3) CM position, "omega" (n, 3) world angular velocity,
    "energy" (n,) = omega . (R J_O R^T omega) / 2 + m (-g . r), and "h_vertical" (n,): the
    angular momentum about the pivot, R J_O R^T omega, projected on the upward unit vertical
    -g / |g| (conserved).
    """
    g = np.asarray(g, dtype=float).reshape(3)
    if not np.any(g):
        raise ValueError("zero gravity: use torque_free")
    p = np.asarray(pivot, dtype=float).reshape(3)
    J_O = np.asarray(J, dtype=float).reshape(3, 3) + m * ((p @ p) * np.eye(3) - np.outer(p, p))
    R, W = _rotate_about_fixed_point(t, J_O, _rotation_matrix(R0),
                                     np.asarray(omega0, dtype=float).reshape(3),
                                     lambda R: m * _cross(R.T @ g, p))
    r = -R @ p
    h = np.einsum("nij,jk,nk->ni", R, J_O, W)
    return {
        "R": R,
        "r": r,
        "omega": np.einsum("nij,nj->ni", R, W),
        "energy": 0.5 * np.einsum("ni,ij,nj->n", W, J_O, W) - m * r @ g,
        "h_vertical": -h @ g / np.linalg.norm(g),
    }


def lagrange_top_steady_precession(*, g: ArrayLike, m: float, A: float, C: float, l: float,
                                   tilt: float, spin: float) -> tuple[float, float]:
    """The two steady precession rates (rad/s) of a symmetric (Lagrange) top, (slow, fast).

    The top is heavy_top with J = diag(A, A, C) (about the CM; body z the symmetry axis) and
    pivot = (0, 0, -l), l > 0: the CM lies a distance l from the pivot along +body z. With
    up = -g / |g|:
      tilt  = angle between up and the body z axis (pivot -> CM), in [0, pi] (> pi/2: the CM
              below the pivot), constant in steady precession;
      spin  = n = omega . e_z, the total angular velocity component along the body z axis
              (world e_z = R[:, 2]), constant for a symmetric top;
      rate  = Omega, the right-hand rotation rate of e_z about up.
    Steady precession: A_O Omega^2 cos(tilt) - C n Omega + m |g| l = 0 with the transverse
    inertia about the pivot A_O = A + m l^2. Roots by the cancellation-free formula, so
    |slow| <= |fast| (for tilt = pi/2 the fast root is infinite). Raises ValueError if there
    is no real root (spin too slow).
    """
    A_O = A + m * l * l
    weight = m * float(np.linalg.norm(g)) * l
    Cn = C * spin
    discriminant = Cn * Cn - 4.0 * A_O * weight * math.cos(tilt)
    if discriminant < 0:
        raise ValueError("no steady precession at this tilt: the spin is too slow")
    s = Cn + math.copysign(math.sqrt(discriminant), Cn)
    cos_tilt = math.cos(tilt)
    fast = s / (2.0 * A_O * cos_tilt) if cos_tilt != 0.0 else math.copysign(math.inf, s)
    return 2.0 * weight / s, fast


def lagrange_top_steady_state(*, g: ArrayLike, tilt: float, spin: float,
                              precession: float) -> tuple[Array, Array]:
    """Initial (R0, omega0) of a symmetric top (J = diag(A, A, C), pivot = (0, 0, -l)) in
    steady precession, for heavy_top; tilt, spin and precession as in
    lagrange_top_steady_precession. ``precession`` must be one of its two roots for the same
    top, tilt and spin (any other value starts a nutating top); the state itself does not
    depend on m, A, C or l.

    Horizontal basis: h1 = the normalised part of world x perpendicular to up = -g/|g| (world
    y instead if x is within 60 degrees of vertical), h2 = up x h1. Then
        R0 = rot(h2, tilt) @ [h1 | h2 | up]   (columns),
    so body z = cos(tilt) up + sin(tilt) h1 (tilted towards h1), body y = h2, and
        omega0 = precession * up + (spin - precession cos(tilt)) * body z (world frame).
    The symmetry axis then moves as e_z(t) = cos(tilt) up + sin(tilt) (cos(P t) h1 +
    sin(P t) h2), P = precession.
    """
    up = -_unit(g)
    x_horizontal = np.array([1.0, 0.0, 0.0]) - up[0] * up
    if np.linalg.norm(x_horizontal) < 0.5:
        x_horizontal = np.array([0.0, 1.0, 0.0]) - up[1] * up
    h1 = _unit(x_horizontal)
    h2 = _cross(up, h1)
    R0 = rot(h2, tilt) @ np.column_stack([h1, h2, up])
    omega0 = precession * up + (spin - precession * math.cos(tilt)) * R0[:, 2]
    return R0, omega0


def torque_free(t: ArrayLike, *, J: ArrayLike, R0: ArrayLike,
                omega0: ArrayLike) -> dict[str, Array]:
    """A free rigid body, no gravity or torque (its CM moves uniformly and is not returned).

    J: 3x3 inertia about the CM (body frame); R0: initial orientation; omega0: initial angular
    velocity, WORLD frame. Euler's equations J W' = (J W) x W and a quaternion attitude.

    Returns "R" (n, 3, 3), "omega" (n, 3) world, "omega_body" (n, 3) = R^T omega, "h_world"
    (n, 3) = R J R^T omega (the constant angular momentum about the CM) and "energy" (n,) =
    omega_body . J omega_body / 2.
    """
    J = np.asarray(J, dtype=float).reshape(3, 3)
    R, W = _rotate_about_fixed_point(t, J, _rotation_matrix(R0),
                                     np.asarray(omega0, dtype=float).reshape(3),
                                     lambda R: np.zeros(3))
    return {
        "R": R,
        "omega": np.einsum("nij,nj->ni", R, W),
        "omega_body": W,
        "h_world": np.einsum("nij,jk,nk->ni", R, J, W),
        "energy": 0.5 * np.einsum("ni,ij,nj->n", W, J, W),
    }


# ----------------------------------------------------------------------- Bennett linkage


def _bennett_ratio(alpha: float, beta: float) -> float:
    denominator = math.sin((beta - alpha) / 2)
    if denominator == 0.0:
        raise ValueError("alpha == beta: not a Bennett linkage")
    return math.sin((beta + alpha) / 2) / denominator


def bennett_output_angle(theta: ArrayLike, *, alpha: float, beta: float) -> float | Array:
    """The output angle phi = theta_2 (rad, wrapped to (-pi, pi]) of the Bennett linkage for the
    input angle theta = theta_1, in the construction of bennett_geometry:

        tan(theta/2) tan(phi/2) = sin((beta + alpha)/2) / sin((beta - alpha)/2),

    alpha being the twist of the ground link 1 (joint 1 -> joint 2) and beta that of link 2.
    theta_1 is the DH joint angle at joint 1 (the rotation of the ground link relative to
    link 4 about axis 1 = world z; link 4 turns by -theta_1 about +z relative to the ground)
    and theta_2 the DH joint angle at joint 2 (link 2 turns by +theta_2 about axis 2 relative to
    the ground). The other two joints follow: theta_3 = -theta_1, theta_4 = -theta_2.
    theta = 0 gives phi = pi. A float for a scalar theta, else an array of theta's shape.
    """
    half = np.asarray(theta, dtype=float) / 2
    phi = 2.0 * np.arctan2(_bennett_ratio(alpha, beta) * np.cos(half), np.sin(half))
    phi = np.where(phi > np.pi, phi - 2.0 * np.pi, phi)
    phi = np.where(phi <= -np.pi, phi + 2.0 * np.pi, phi)
    return float(phi) if phi.ndim == 0 else phi


def bennett_geometry(theta: float, *, a: float, alpha: float, beta: float) -> dict[str, Array]:
    """The assembled Bennett linkage at input angle theta (see bennett_output_angle).

    Construction (Denavit-Hartenberg, all offsets zero): four links i = 1..4, link i joining
    joint i to joint i+1 (joint 5 = joint 1), with lengths (a, b, a, b), b = a sin(beta) /
    sin(alpha) (Bennett's condition), and twists (alpha, beta, alpha, beta); alpha, beta in
    (0, pi), alpha != beta. Link i carries the frame F_i (rotation, columns x_i, y_i, z_i; origin
    P_i = joint i's point): z_i = axis of joint i, x_i = direction of link i, the common normal
    from axis i to axis i+1. Then
        P_{i+1} = P_i + a_i x_i,    F_{i+1} = F_i @ Rot_x(alpha_i) @ Rot_z(theta_{i+1}),
    i.e. axis i+1 = z_i turned by the twist alpha_i right-handedly about x_i, and the joint
    angle theta_{i+1} turns link i+1 relative to link i right-handedly about axis i+1 (from x_i
    to x_{i+1}). Link 1 is the ground: F_1 = identity, P_1 = 0 (joint 1 at the origin, axis 1 =
    world z, link 1 along world x), so P_2 = (a, 0, 0) and axis 2 = (0, -sin alpha, cos alpha).
    Joint angles: theta_1 = theta, theta_2 = bennett_output_angle(theta), theta_3 = -theta_1,
    theta_4 = -theta_2; the loop closes: F_4 @ Rot_x(beta) @ Rot_z(theta_1) = F_1 and
    P_4 + b x_4 = P_1.

    As depsim hinges (member A = link i-1, B = link i, for i = 2, 3, 4): axis (0, -sin
    alpha_{i-1}, cos alpha_{i-1}) in A's frame F_{i-1}, R0 = Rot_x(alpha_{i-1}), point
    (a_{i-1}, 0, 0) on A and (0, 0, 0) on B (frame origins at the joints, not the CMs), and the
    hinge angle is theta_i; the same holds for joint 1 with A = link 4 and B = the ground.
    Joint 1 with A = ground and B = link 4 instead: axis (0, 0, -1) (world), R0 = Rot_x(-beta),
    point 0 on the ground and (b, 0, 0) on link 4, hinge angle theta_1.

    Returns "points" (4, 3) = P_1..P_4, "axes" (4, 3) = z_1..z_4, "frames" (4, 3, 3) = F_1..F_4
    and "angles" (4,) = theta_1..theta_4, all in the world (= ground) frame.
    """
    b = a * math.sin(beta) / math.sin(alpha)
    phi = bennett_output_angle(theta, alpha=alpha, beta=beta)
    angles = np.array([theta, phi, -theta, -phi])
    lengths, twists = (a, b, a, b), (alpha, beta, alpha, beta)
    x, z = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    frames, points = [np.eye(3)], [np.zeros(3)]
    for i in range(3):
        frame = frames[i] @ rot(x, twists[i]) @ rot(z, angles[i + 1])
        points.append(points[i] + lengths[i] * frames[i][:, 0])
        frames.append(frame)
    frames = np.array(frames)
    return {"points": np.array(points), "axes": frames[:, :, 2], "frames": frames,
            "angles": angles}
