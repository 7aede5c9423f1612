"""One step of the paper's method (section 2.2): lambda(t) linear over the step, three passes.

Over t_i -> t_i + h the multipliers are lambda(t) = lambda_i + s (lambda_{i+1} - lambda_i),
s = (t - t_i)/h, and the motion M q'' = f - Phi_q^T lambda(t) is integrated by one
Dormand-Prince step with the dissipated powers as extra quadrature states,
y = (q, qd, work). lambda_{i+1} is found by the iteration (6), three times:

1. position:     re-integrate until v_pos(q_{i+1}) is small      -> q_{i+1}          C = h^2/6
2. velocity:     until v_vel(q_{i+1}, qd_{i+1}) is small          -> qd_{i+1}         C = h/2
3. acceleration: at (q_{i+1}, qd_{i+1}) until v_acc is small      -> qdd, lambda_{i+1} C = 1

The velocity pass applies the frozen-Phi_q effect of lambda_{i+1} on qd_{i+1},
-(h/2) M^-1 Phi_q^T d(lambda), to the position pass's trajectory ("project", global order 4);
re-integrating instead ("reintegrate") leaves qd_{i+1} on a trajectory that ends O(h^4) away
from q_{i+1} (global order 3). The third pass needs no integration: qdd_{i+1} depends on
lambda_{i+1} alone. docs/method.md gives the reasoning and the measurements.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .dopri import DenseStep, RKStep, StepInterpolant, dopri_step
from .multipliers import (Measurement, PassReport, iterate_multipliers, max_abs,
                          product_scale)

VELOCITY_PASSES = ("project", "reintegrate")

# Each pass iterates until max|v| <= CONSTRAINT_FRACTION * tol * max(1, scale): a leftover
# position error of order tol feeds the energy balance step after step (docs/method.md).
CONSTRAINT_FRACTION = 0.01
ROUNDOFF = 16 * np.finfo(float).eps


def constraint_tolerance(tol: float) -> float:
    """The iteration tolerance of the three passes for an integration tolerance tol."""
    return max(CONSTRAINT_FRACTION * tol, ROUNDOFF)


@dataclass(slots=True)
class State:
    """The accepted state at time t (s): q, qd, qdd (NQ,), lam (nc,), work (ND,) in J."""

    t: float
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    lam: np.ndarray
    work: np.ndarray


@dataclass(slots=True)
class StepOutcome:
    """A converged step: the new state, its dense output, the RK step of the trajectory (for
    the error estimate), one report per pass, the integrations spent and Phi_q at the end."""

    state: State
    dense: StepInterpolant
    rk: RKStep
    reports: tuple[PassReport, PassReport, PassReport]
    integrations: int
    jacobian: np.ndarray  # (nc, NQ)


class Stepper:
    """Takes steps of the iterative multiplier method for one system; `constraints` (a
    ConstraintSet) may be replaced between steps."""

    def __init__(self, system, constraints, tol: float, velocity_pass: str = "project"):
        if velocity_pass not in VELOCITY_PASSES:
            raise ValueError(f"velocity_pass must be one of {VELOCITY_PASSES}")
        self.velocity_pass = velocity_pass
        self.system = system
        self.constraints = constraints
        self.tol = tol
        self.constraint_tol = constraint_tolerance(tol)
        self.rhs_evaluations = 0
        self.integrations = 0

    def motion(self, t0: float, h: float, lam0: np.ndarray, lam1: np.ndarray):
        """The right-hand side y' = (qd, qdd, power) of (1) with lambda linear from lam0 at
        t0 to lam1 at t0 + h."""
        nq, system, cs = self.system.nq, self.system, self.constraints
        slope = (lam1 - lam0) / h

        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            self.rhs_evaluations += 1
            q, qd = y[:nq], y[nq:2 * nq]
            lam = lam0 + (t - t0) * slope
            qdd = system.mass.solve(system.force(q, qd, t) - cs.jacobian_transpose_times(q, t, lam))
            return np.concatenate((qd, qdd, system.dissipation(q, qd, t)))

        return rhs

    def derivative(self, state: State) -> np.ndarray:
        """dy/dt at an accepted state: the first RK stage (free: qdd is known)."""
        power = self.system.dissipation(state.q, state.qd, state.t)
        return np.concatenate((state.qd, state.qdd, power))

    def acceleration(self, q, qd, t, lam_guess, J=None):
        """Pass 3: lambda and qdd at (q, qd, t) from (1) and (2c); returns (lam, qdd, report).
        J: Phi_q at (q, t) when already known. Also gives lambda at a (re)start."""
        cs, system = self.constraints, self.system
        J = cs.jacobian(q, t) if J is None else J
        f = system.force(q, qd, t)
        gamma = cs.gamma(q, qd, t)

        def measure(lam):
            qdd = system.mass.solve(f - J.T @ lam)
            scale = max(max_abs(gamma), product_scale(J, qdd))
            return Measurement(gamma - J @ qdd, J, scale, qdd)

        lam, final, report = iterate_multipliers("acceleration", lam_guess, measure, 1.0,
                                                 self.constraint_tol, system.mass)
        return lam, final.payload, report

    def step(self, state: State, h: float, lam_predicted: np.ndarray) -> StepOutcome:
        """Advance `state` by h (s), the iteration starting from lam_predicted (nc,).

        Raises multipliers.PassFailure when a pass does not converge.
        """
        integrate = self._integrator(state, h)
        lam1, rk_pos, J1, report_pos = self._position_pass(integrate, state.t + h,
                                                           lam_predicted, h)
        q1 = rk_pos.y1[:self.system.nq].copy()
        lam1, rk, qd1, report_vel = self._velocity_pass(integrate, q1, J1, state.t + h, lam1,
                                                        rk_pos, h)
        lam1, qdd1, report_acc = self.acceleration(q1, qd1, state.t + h, lam1, J1)
        work1 = rk.y1[2 * self.system.nq:].copy()
        new = State(state.t + h, q1, qd1, qdd1, lam1, work1)
        dense = StepInterpolant(state, new, DenseStep(rk))
        return StepOutcome(new, dense, rk, (report_pos, report_vel, report_acc),
                           integrate.count, J1)

    def _integrator(self, state: State, h: float):
        """integrate(lam1) -> RKStep of the step with lambda_{i+1} = lam1 (last one cached)."""
        y0 = np.concatenate((state.q, state.qd, state.work))
        k1 = self.derivative(state)
        cache: dict[bytes, RKStep] = {}

        def integrate(lam1: np.ndarray) -> RKStep:
            key = lam1.tobytes()
            if key not in cache:
                cache.clear()
                integrate.count += 1
                self.integrations += 1
                rhs = self.motion(state.t, h, state.lam, lam1)
                cache[key] = dopri_step(rhs, state.t, y0, k1, h)
            return cache[key]

        integrate.count = 0
        return integrate

    def _position_pass(self, integrate, t1: float, lam1: np.ndarray, h: float):
        nq, cs = self.system.nq, self.constraints

        def measure(lam):
            rk = integrate(lam)
            q1 = rk.y1[:nq]
            return Measurement(cs.v_pos(q1, t1), cs.jacobian(q1, t1), max_abs(q1), rk)

        lam1, final, report = iterate_multipliers("position", lam1, measure, h * h / 6.0,
                                                  self.constraint_tol, self.system.mass)
        return lam1, final.payload, final.J, report

    def _velocity_pass(self, integrate, q1, J1, t1: float, lam_pos, rk_pos: RKStep, h: float):
        nq, mass = self.system.nq, self.system.mass
        phi_t1 = self.constraints.phi_t(q1, t1)

        def measure(lam):
            if self.velocity_pass == "reintegrate":
                rk = integrate(lam)
                qd1 = rk.y1[nq:2 * nq]
            else:  # the frozen-Phi_q effect of lambda_{i+1} on qd_{i+1}
                rk = rk_pos
                qd1 = rk.y1[nq:2 * nq] - (h / 2) * mass.solve(J1.T @ (lam - lam_pos))
            return Measurement(-(J1 @ qd1) - phi_t1, J1, product_scale(J1, qd1), (rk, qd1))

        lam1, final, report = iterate_multipliers("velocity", lam_pos, measure, h / 2.0,
                                                  self.constraint_tol, mass)
        rk, qd1 = final.payload
        return lam1, rk, qd1.copy(), report
