"""An independent reference for single closed loops of hinges with one degree of freedom (the
Bricard and Bennett linkages), and the data of Bricard's mechanism as the IFToMM multibody
benchmark A04 gives it.

Nothing here comes from depsim. The loop is written in joint coordinates by the product of
exponentials (each joint a twist, the members' poses the product of the joints' screw motions
from the reference configuration) and integrated by scipy's DOP853 at rtol = atol = 1e-12:

* Joints 0..n close a loop ground - body 1 - ... - body n - ground; joint i joins body i to
  body i + 1 (body 0 and body n + 1 the ground). In the reference configuration (every joint
  angle 0) joint i passes through ``points[i]`` along the unit ``axes[i]`` (world frame).
* Body k's displacement from its reference is g_k = exp(xi_0 phi_0) ... exp(xi_(k-1)
  phi_(k-1)), a rotation R_k and a translation d_k (x -> R_k x + d_k); joint i's current twist
  is xi_i = (a, p x a) with a = R_i a_i and p = R_i p_i + d_i (the ground's joint n stays put).
* The loop closes when sum_i phi_i' xi_i = 0: six equations on n + 1 rates whose one
  solution (the mobility) is phi' = nu u, nu_driver = 1 (least squares on the others: the
  redundant equation costs nothing), u the driving joint's rate. Accelerations follow from
  sum_i (phi_i'' xi_i + phi_i' [V_i, xi_i]) = 0, V_i the twist of the body that carries joint i.
* The motion is Kane's equation for the one speed u: the bodies' inertia forces (centre of
  mass accelerations, I omega' + omega x I omega) and gravity along their partial velocities.

Units SI; gravity ``g`` (3,); a body's ``centre`` and ``inertia`` (3x3, about the centre) in the
world frame in the reference configuration. Every simulation returns arrays sampled at the
given output times ``t`` (t[0] = 0), time along the first axis.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from .spatial import _rodrigues as _rotation  # Rodrigues about a unit axis

Array = NDArray[np.float64]

RTOL = 1e-12
ATOL = 1e-12


def _bracket(V: Array, xi: Array) -> Array:
    """[V, xi] of two twists (angular; linear at the origin): d xi / dt for xi carried by V."""
    w, v, a, b = V[:3], V[3:], xi[:3], xi[3:]
    return np.concatenate([np.cross(w, a), np.cross(w, b) + np.cross(v, a)])


class HingeLoop:
    """A closed loop of n bodies and n + 1 hinges (module docstring)."""

    def __init__(self, *, g: ArrayLike, points: Sequence[ArrayLike], axes: Sequence[ArrayLike],
                 masses: Sequence[float], centres: Sequence[ArrayLike],
                 inertias: Sequence[ArrayLike], driver: int = 0):
        self.g = np.asarray(g, dtype=float)
        self.points = [np.asarray(p, dtype=float) for p in points]
        self.axes = [np.asarray(a, dtype=float) / np.linalg.norm(a) for a in axes]
        self.masses = [float(m) for m in masses]
        self.centres = [np.asarray(c, dtype=float) for c in centres]
        self.inertias = [np.asarray(i, dtype=float) for i in inertias]
        self.n = len(self.masses)
        if len(self.points) != self.n + 1 or len(self.axes) != self.n + 1:
            raise ValueError("a loop of n bodies has n + 1 joints")
        self.driver = driver
        self.others = [i for i in range(self.n + 1) if i != driver]

    def poses(self, phi: Array) -> tuple[list[Array], list[Array], Array]:
        """Each body's displacement (R_k, d_k), the ground's first, and the joints' current
        twists as the columns of a 6 x (n + 1) matrix."""
        R, d = [np.eye(3)], [np.zeros(3)]
        for j in range(self.n):
            turn = _rotation(self.axes[j], phi[j])
            d.append(R[-1] @ (self.points[j] - turn @ self.points[j]) + d[-1])
            R.append(R[-1] @ turn)
        twists = np.empty((6, self.n + 1))
        for i in range(self.n + 1):
            k = i if i < self.n else 0
            a = R[k] @ self.axes[i]
            p = R[k] @ self.points[i] + d[k]
            twists[:, i] = np.concatenate([a, np.cross(p, a)])
        return R, d, twists

    def _solve_others(self, twists: Array, right: Array) -> Array:
        """Joint values x with x_driver = 0 and twists x = right (consistent, least squares)."""
        x = np.zeros(self.n + 1)
        x[self.others] = np.linalg.lstsq(twists[:, self.others], right, rcond=None)[0]
        return x

    def mobility(self, twists: Array) -> Array:
        """nu: the joints' rates per unit rate of the driving joint."""
        nu = self._solve_others(twists, -twists[:, self.driver])
        nu[self.driver] = 1.0
        return nu

    def _bodies(self, phi: Array, u: float):
        """Per body: mass, world inertia, centre, twist V (u as given) and partial twist
        (u = 1); with the joint rates and the twists."""
        R, d, twists = self.poses(phi)
        nu = self.mobility(twists)
        rates = nu * u
        V, Vp, bodies = np.zeros(6), np.zeros(6), []
        for k in range(1, self.n + 1):
            V = V + rates[k - 1] * twists[:, k - 1]
            Vp = Vp + nu[k - 1] * twists[:, k - 1]
            centre = R[k] @ self.centres[k - 1] + d[k]
            inertia = R[k] @ self.inertias[k - 1] @ R[k].T
            bodies.append((self.masses[k - 1], inertia, centre, V.copy(), Vp.copy()))
        return bodies, rates, twists

    def rhs(self, _t: float, y: Array) -> Array:
        phi, u = y[:self.n], y[self.n]
        bodies, rates, twists = self._bodies(phi, u)
        carried = [_bracket(bodies[i - 1][3] if 0 < i < self.n else np.zeros(6), twists[:, i])
                   * rates[i] for i in range(self.n + 1)]
        accelerations = self._solve_others(twists, -np.sum(carried, axis=0))  # at u' = 0
        inertia_sum, force_sum, A = 0.0, 0.0, np.zeros(6)
        for k, (m, I, c, V, Vp) in enumerate(bodies, start=1):
            A = A + accelerations[k - 1] * twists[:, k - 1] + carried[k - 1]
            w, v_c = V[:3], V[3:] + np.cross(V[:3], c)
            a_c = A[3:] + np.cross(A[:3], c) + np.cross(w, v_c)
            wp, vp = Vp[:3], Vp[3:] + np.cross(Vp[:3], c)
            inertia_sum += m * vp @ vp + wp @ I @ wp
            force_sum += m * (self.g - a_c) @ vp - (I @ A[:3] + np.cross(w, I @ w)) @ wp
        return np.concatenate([rates[:self.n], [force_sum / inertia_sum]])

    def energy(self, phi: Array, u: float) -> float:
        """Kinetic plus gravity energy (zero at the world origin)."""
        bodies, _, _ = self._bodies(phi, u)
        total = 0.0
        for m, I, c, V, _ in bodies:
            w, v_c = V[:3], V[3:] + np.cross(V[:3], c)
            total += 0.5 * m * v_c @ v_c + 0.5 * w @ I @ w - m * self.g @ c
        return total

    def point(self, phi: Array, body: int, reference_point: ArrayLike) -> Array:
        """Where the point of body ``body`` (1..n) that was at ``reference_point`` (world, in
        the reference configuration) is now."""
        R, d, _ = self.poses(phi)
        return R[body] @ np.asarray(reference_point, dtype=float) + d[body]

    def simulate(self, t: ArrayLike, *, rate0: float = 0.0,
                 points: Sequence[tuple[int, ArrayLike]] = ()) -> dict[str, Array]:
        """Released from the reference configuration with the driving joint at ``rate0``:
        the joint angles ``phi`` (n, joint n left out) and the driving rate ``u``, the energy,
        ``closure`` (the loop's twist sum relative to the twists' size, over the output times)
        and the world positions of ``points`` (body, reference point) as ``points`` (t, k, 3)."""
        t = np.asarray(t, dtype=float)
        y0 = np.concatenate([np.zeros(self.n), [rate0]])
        solution = solve_ivp(self.rhs, (t[0], t[-1]), y0, method="DOP853", rtol=RTOL,
                             atol=ATOL, t_eval=t)
        if not solution.success:
            raise RuntimeError(solution.message)
        phi, u = solution.y[:self.n].T, solution.y[self.n]
        energy, closure, where = [], [], []
        for phi_k, u_k in zip(phi, u):
            R, d, _ = self.poses(phi_k)
            energy.append(self.energy(phi_k, u_k))
            # joint n seen from body n must be where the ground holds it
            a = R[self.n] @ self.axes[self.n]
            p = R[self.n] @ self.points[self.n] + d[self.n]
            closure.append(max(np.max(np.abs(a - self.axes[self.n])),
                               np.max(np.abs(p - self.points[self.n]))))
            where.append([self.point(phi_k, body, q) for body, q in points])
        return {"phi": phi, "u": u, "energy": np.array(energy), "closure": np.array(closure),
                "points": np.array(where).reshape(len(t), len(points), 3)}


# -- Bricard's mechanism, IFToMM multibody benchmark A04 ---------------------------------------

def bricard_a04(*, driver: int = 0, cross_section: float = 0.1) -> HingeLoop:
    """Bricard's mechanism of benchmark A04: five rods of 1 m and 1 kg (uniform, a square
    cross-section of ``cross_section`` m) and six hinges closing a loop through the ground,
    gravity 9.81 m/s^2 along -y, released at rest. Joints (reference configuration): O =
    (0, 0, 0) about y, (1, 0, 0) about z, P3 = (1, -1, 0) about x, (1, -1, 1) about y,
    (0, -1, 1) about z, (0, 0, 1) about x; rod k runs from joint k - 1 to joint k. Mobile (one
    degree of freedom) although Grubler's count is 0: one of the loop's six closure
    equations is redundant at every position. ``driver`` 0, 2 or 4: those joints turn one
    way through a swing (0 to pi and back); the rates of joints 1, 3 and 5 vanish when joint 0
    is at 90 degrees, where they cannot drive."""
    points = [(0, 0, 0), (1, 0, 0), (1, -1, 0), (1, -1, 1), (0, -1, 1), (0, 0, 1)]
    axes = [(0, 1, 0), (0, 0, 1), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 0, 0)]
    m, L, w = 1.0, 1.0, cross_section
    centres, inertias = [], []
    for k in range(5):
        start, end = np.array(points[k], float), np.array(points[k + 1], float)
        along = (end - start) / np.linalg.norm(end - start)
        centres.append((start + end) / 2)
        across = m * (L * L + w * w) / 12
        inertias.append(across * np.eye(3) + (m * w * w / 6 - across) * np.outer(along, along))
    return HingeLoop(g=(0, -9.81, 0), points=points, axes=axes, masses=[m] * 5,
                     centres=centres, inertias=inertias, driver=driver)


BRICARD_P3 = (2, (1.0, -1.0, 0.0))  # the benchmark's reported point: rod 2's end, joint 2
