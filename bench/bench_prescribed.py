"""What prescribing the multipliers over a step costs in accuracy, on a motion with no
singular position: a rigid body on a pin, in body coordinates, at fixed steps.

    .venv/bin/python bench/bench_prescribed.py            # about a minute
    .venv/bin/python bench/bench_prescribed.py --steps 1000,2000

depsim's step integrates q'' = M^-1 (f(q) - Phi_q(q)^T lambda(t)) with lambda(t) prescribed
over the step (the multipliers' profile), then its passes move the end back onto the rows.
A solver on the index-1 equations instead solves lambda from the state at every stage, which
in body coordinates gives exactly what DOPRI5 gives on the joint coordinate itself. This
bench integrates the same motion three ways with the same Dormand-Prince 5(4) tableau and the
same fixed steps, all in plain NumPy, and prints the hinge angle's error at t_end against the
one-angle ODE converged (DOP853, rtol 1e-13):

index-1      lambda(q, qd) solved at every stage (S = Phi_q M^-1 Phi_q^T, gamma), no
             projection: the joint-coordinate accuracy.
exact(t)     lambda*(t), the converged motion's own multipliers, prescribed at the stage times;
             the end then projected onto the rows M-orthogonally (positions by Newton, then
             velocities). No interpolation error and no pass limit at all: what prescribing
             the force costs by itself.
profile      a model of depsim's step: lambda(t) the cubic through the last three accepted
             multipliers and the step's end value; the end value iterated (Newton) until the
             end position meets the rows to 1e-15 (the position pass), the velocities moved
             along M^-1 Phi_q^T with Phi_q frozen at the end until they meet the velocity
             rows (the velocity pass); the accepted state's multipliers solved from it (the
             acceleration pass) and kept for the next profiles. The first three steps are
             index-1 steps (depsim starts with a linear profile instead).

The body: the one-angle motion of bench_conditioning.py's single parallelogram (I_eff 5/3 kg
m^2 about the pin, weight's moment 2 kg m times g, released at rest 10 deg above the
horizontal), as one body of 3.2 kg with its centre 0.625 m from the pin, 0-20 s (about 17
swings).
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np
from scipy.integrate import solve_ivp

G = 9.81
INERTIA, WEIGHT = 5.0 / 3.0, 2.0 * G  # about the pin, kg m^2; the weight's moment, N m
MASS = 3.2  # kg
CENTRE = 2.0 / MASS  # m from the pin
CENTRAL = INERTIA - MASS * CENTRE ** 2  # kg m^2 about the centre
INVERSE_MASS = 1.0 / np.array([MASS, MASS, CENTRAL])
FORCE = np.array([0.0, -MASS * G, 0.0])

# Dormand-Prince 5(4): the stages' rows, the fifth-order weights, the nodes
A = [[], [1 / 5], [3 / 40, 9 / 40], [44 / 45, -56 / 15, 32 / 9],
     [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729],
     [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
     [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84]]
B = [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0]
C = [0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1, 1]


def jacobian(q):
    """Phi_q of the pin (the body's point at -CENTRE along its axis held at the origin)."""
    c, s = math.cos(q[2]), math.sin(q[2])
    return np.array([[1.0, 0.0, CENTRE * s], [0.0, 1.0, -CENTRE * c]])


def rows(q):
    return np.array([q[0] - CENTRE * math.cos(q[2]), q[1] - CENTRE * math.sin(q[2])])


def index1_multipliers(q, qd):
    """lambda from M q'' + Phi_q^T lambda = f, Phi_q q'' = gamma."""
    J = jacobian(q)
    c, s, w = math.cos(q[2]), math.sin(q[2]), qd[2]
    gamma = np.array([-CENTRE * c * w * w, -CENTRE * s * w * w])
    S = (J * INVERSE_MASS) @ J.T
    return np.linalg.solve(S, J @ (INVERSE_MASS * FORCE) - gamma)


def state_at(angle, rate):
    c, s = math.cos(angle), math.sin(angle)
    return (np.array([CENTRE * c, CENTRE * s, angle]),
            np.array([-CENTRE * s * rate, CENTRE * c * rate, rate]))


def dopri_step(q, qd, h, multipliers):
    """One DOPRI5 step of M q'' = f - Phi_q^T lambda, lambda = multipliers(u, q, qd) at the
    stage (u: its node in the step)."""
    y = np.concatenate([q, qd])
    k = []
    for stage in range(7):
        ys = y + h * sum(A[stage][j] * k[j] for j in range(stage)) if stage else y
        lam = multipliers(C[stage], ys[:3], ys[3:])
        k.append(np.concatenate([ys[3:], INVERSE_MASS * (FORCE - jacobian(ys[:3]).T @ lam)]))
    y = y + h * sum(B[j] * k[j] for j in range(7))
    return y[:3], y[3:]


def project(q, qd):
    """The end onto the rows, M-orthogonally: positions by Newton, then the velocities."""
    for _ in range(6):
        J = jacobian(q)
        q = q - INVERSE_MASS * (J.T @ np.linalg.solve((J * INVERSE_MASS) @ J.T, rows(q)))
    J = jacobian(q)
    qd = qd - INVERSE_MASS * (J.T @ np.linalg.solve((J * INVERSE_MASS) @ J.T, J @ qd))
    return q, qd


def lagrange(nodes, u):
    weights = []
    for j, uj in enumerate(nodes):
        w = 1.0
        for m, um in enumerate(nodes):
            if m != j:
                w *= (u - um) / (uj - um)
        weights.append(w)
    return weights


def profile_step(q, qd, h, t, history):
    """The model of depsim's step (the module's text) from the accepted (t_j, lambda_j)."""
    used = history[-3:]
    nodes = [(tj - t) / h for tj, _ in used] + [1.0]

    def profile(end):
        values = [lam for _, lam in used] + [end]
        return lambda u, qs, qds: sum(w * v for w, v in zip(lagrange(nodes, u), values))

    end = used[-1][1].copy()
    for _ in range(10):  # the position pass: Newton on the end value, re-integrating
        q1, qd1 = dopri_step(q, qd, h, profile(end))
        residual = rows(q1)
        if np.abs(residual).max() <= 1e-15:
            break
        sensitivity = np.zeros((2, 2))
        for a in range(2):
            delta = np.zeros(2)
            delta[a] = 1e-4 * max(1.0, abs(end[a]))
            sensitivity[:, a] = (rows(dopri_step(q, qd, h, profile(end + delta))[0])
                                 - residual) / delta[a]
        end = end - np.linalg.solve(sensitivity, residual)
    q1, qd1 = dopri_step(q, qd, h, profile(end))
    # the velocity pass: qd1 moves by -h (integral of the end's basis) M^-1 J^T d(lambda)
    J = jacobian(q1)
    qd1 = qd1 - INVERSE_MASS * (J.T @ np.linalg.solve((J * INVERSE_MASS) @ J.T, J @ qd1))
    return q1, qd1


def run(steps: int, way: str, t_end: float, release: float, reference) -> float:
    h = t_end / steps
    q, qd = state_at(math.radians(release), 0.0)
    history = [(0.0, index1_multipliers(q, qd))]
    for i in range(steps):
        t = i * h
        if way == "index-1" or (way == "profile" and len(history) < 3):
            q, qd = dopri_step(q, qd, h, lambda u, qs, qds: index1_multipliers(qs, qds))
        elif way == "exact(t)":
            q, qd = project(*dopri_step(q, qd, h, lambda u, qs, qds:
                                        index1_multipliers(*state_at(*reference(t + u * h)))))
        else:
            q, qd = profile_step(q, qd, h, t, history)
        history.append((t + h, index1_multipliers(q, qd)))
    return q[2] - reference(t_end)[0]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", default="1000,2000,4000", help="fixed step counts")
    parser.add_argument("--t-end", type=float, default=20.0, help="s")
    parser.add_argument("--release", type=float, default=10.0, help="deg above the horizontal")
    args = parser.parse_args(argv)
    counts = [int(item) for item in args.steps.split(",") if item]
    converged = solve_ivp(lambda t, y: [y[1], -WEIGHT * math.cos(y[0]) / INERTIA],
                          (0.0, args.t_end), [math.radians(args.release), 0.0],
                          method="DOP853", rtol=1e-13, atol=1e-14, dense_output=True)
    reference = converged.sol
    ways = ["index-1", "exact(t)", "profile"]
    print(f"A body on a pin, 0-{args.t_end:g} s, fixed DOPRI5 steps: the hinge angle's error "
          "at the end (rad), and each against index-1's")
    print(f"{'steps':>6} " + " ".join(f"{way:>10}" for way in ways) + "  "
          + " ".join(f"{way + ' / index-1':>20}" for way in ways[1:]))
    for steps in counts:
        errors = [run(steps, way, args.t_end, args.release, reference) for way in ways]
        print(f"{steps:>6} " + " ".join(f"{e:>10.2e}" for e in errors) + "  "
              + " ".join(f"{abs(e / errors[0]):>20.3g}" for e in errors[1:]), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
