"""Latches and hard stops: engagement geometry, the compliant latch's contact torque, and the
event-time projections (plastic impact, position and velocity projections).

All formulas are in docs/deployment.md (sections 2-4); this module has no run state, so each
function ports to C as is. Hinge angles theta (rad), rates (rad/s), torques (N m), impulses
(N m s for a lock row, N s for a joint's force rows).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .multipliers import (Measurement, iterate_multipliers, max_abs, product_scale,
                          project_velocity)


def approach_side(theta0: float, rate0: float, lock: float) -> float:
    """+1 when theta approaches `lock` from below (theta0 < lock), -1 from above; at the lock
    angle itself the side the hinge moves to (+1 when at rest)."""
    if theta0 != lock:
        return 1.0 if theta0 < lock else -1.0
    return -1.0 if rate0 < 0 else 1.0


def latch_gap(theta: float, lock: float, side: float) -> float:
    """side (lock - theta): positive before the latch is reached, zero at it (rad)."""
    return side * (lock - theta)


def contact_torque(overshoot: float, overshoot_rate: float, stiffness: float,
                   damping: float) -> float:
    """A compliant latch's push P = max(0, k delta + c delta') (N m), delta = side (theta - lock)
    the overshoot (rad): a one-sided spring-damper that pushes the hinge back and never pulls.
    The torque on theta is -side P."""
    return max(0.0, stiffness * overshoot + damping * overshoot_rate)


def contact_power(overshoot: float, overshoot_rate: float, stiffness: float,
                  damping: float) -> float:
    """Power the compliant latch removes (W, >= 0): (P - k delta) delta'. Equals c delta'^2 while
    P > 0; while P is clipped at 0, -k delta delta' > 0 (the spring's energy is released)."""
    push = contact_torque(overshoot, overshoot_rate, stiffness, damping)
    return (push - stiffness * overshoot) * overshoot_rate


def contact_energy(overshoot: float, stiffness: float) -> float:
    """The compliant latch spring's potential k max(delta, 0)^2 / 2 (J)."""
    return 0.5 * stiffness * max(overshoot, 0.0) ** 2


@dataclass(frozen=True, slots=True)
class Impact:
    """A plastic impact: velocities after (NQ,), the impulse mu of each row (name -> mu; the
    generalized impulse is -Phi_q^T mu), the kinetic energy removed (J), the unilateral rows
    released because their impulse would pull, and the CG iterations spent."""

    qd: np.ndarray
    impulses: dict
    energy_loss: float
    released: tuple[str, ...]
    cg_iterations: int


def plastic_impact(constraints, mass, q, qd, t, tol, unilateral: dict | None = None) -> Impact:
    """qd+ = qd - M^-1 J^T mu with J qd+ + Phi_t = 0 on every row of `constraints`: the
    M-orthogonal projection of qd onto the new velocity constraints, solved by the iteration
    (6) with C = 1 (CG on S = J M^-1 J^T, no factorisation). `unilateral` maps a row name to
    its pushing sign s (+1: it may only take mu >= 0, -1: mu <= 0); a row whose impulse would
    pull is released and the projection repeated without it (an active-set loop).

    Raises multipliers.PassFailure when the projection does not converge."""
    unilateral = dict(unilateral or {})
    released: list[str] = []
    cs, cg = constraints, 0
    while True:
        J = cs.jacobian(q, t)
        qd_new, mu, report = project_velocity(J, mass, qd, cs.phi_t(q, t), tol)
        cg += report.cg_iterations
        impulses = dict(zip(cs.names, map(float, mu)))
        pulling = {n: s * impulses[n] for n, s in unilateral.items()
                   if n in impulses and s * impulses[n] < 0}
        if not pulling:
            break
        worst = min(pulling, key=pulling.get)
        released.append(worst)
        cs = cs.without([worst])
    loss = 0.5 * float(qd @ (mass.matrix @ qd) - qd_new @ (mass.matrix @ qd_new))
    return Impact(qd_new, impulses, loss, tuple(released), cg)


def project_positions(constraints, mass, q, t, tol) -> np.ndarray:
    """q moved M-orthogonally onto Phi(q) = 0: q+ = q - M^-1 J(q)^T mu, mu by the iteration (6)
    with C = 1. Used after a lock row is added at an event, whose angle the event located on the
    dense output to within the step's local error."""
    J0 = constraints.jacobian(q, t)

    def measure(mu):
        moved = q - mass.solve(J0.T @ mu)
        return Measurement(constraints.v_pos(moved, t), constraints.jacobian(moved, t),
                           max_abs(moved), moved)

    _, final, _ = iterate_multipliers("position", np.zeros(constraints.nc), measure, 1.0, tol,
                                      mass)
    return final.payload


def project_velocities(constraints, mass, q, qd, t, tol) -> np.ndarray:
    """qd moved M-orthogonally onto Phi_q qd + Phi_t = 0 (a plastic impact without records)."""
    J = constraints.jacobian(q, t)
    moved, _, _ = project_velocity(J, mass, qd, constraints.phi_t(q, t), tol)
    return moved


def acceleration_multipliers(system, constraints, q, qd, t, tol, guess=None) -> np.ndarray:
    """lambda (nc,) at (q, qd, t) from (1) and (2c), by the acceleration pass: the holding
    torques of lock rows, the reactions of joints. Raises PassFailure if it does not converge."""
    J = constraints.jacobian(q, t)
    f = system.force(q, qd, t)
    gamma = constraints.gamma(q, qd, t)

    def measure(lam):
        qdd = system.mass.solve(f - J.T @ lam)
        scale = max(max_abs(gamma), product_scale(J, qdd))
        return Measurement(gamma - J @ qdd, J, scale, qdd)

    start = np.zeros(constraints.nc) if guess is None else guess
    lam, _, _ = iterate_multipliers("acceleration", start, measure, 1.0, tol, system.mass)
    return lam
