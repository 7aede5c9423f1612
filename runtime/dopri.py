"""Dormand-Prince 5(4): one explicit step, its error estimate and its continuous extension.

Coefficients from Dormand & Prince (1980); the quartic dense output is Shampine's (1986), as
in Hairer, Norsett & Wanner, Solving ODEs I, sec. II.6, and scipy's RK45. The step is local
extrapolation (the 5th-order solution advances), the estimate is of the 4th-order one, so the
local error estimate behaves like h^5 (ERROR_ORDER).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

ERROR_ORDER = 5  # the estimated local error is O(h^ERROR_ORDER)

C = np.array([0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1])
A = (
    (),
    (1 / 5,),
    (3 / 40, 9 / 40),
    (44 / 45, -56 / 15, 32 / 9),
    (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729),
    (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656),
)
B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
E = np.array([-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
P = np.array([
    [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0, 0, 0, 0],
    [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0, 127303824393 / 49829197408, -318862633887 / 49829197408,
     701980252875 / 199316789632],
    [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
])
A_ROWS = tuple(np.array(row) for row in A)


@dataclass(slots=True)
class RKStep:
    """One DOPRI step from (t0, y0) over h: y1 (n,), error estimate (n,), stages K (7, n)."""

    t0: float
    h: float
    y0: np.ndarray
    y1: np.ndarray
    error: np.ndarray
    K: np.ndarray


def dopri_step(rhs: Callable[[float, np.ndarray], np.ndarray], t0: float, y0: np.ndarray,
               k1: np.ndarray, h: float) -> RKStep:
    """Advance y' = rhs(t, y) from (t0, y0) with first stage k1 = rhs(t0, y0); 6 evaluations."""
    K = np.empty((7, y0.shape[0]))
    K[0] = k1
    for s in range(1, 6):
        K[s] = rhs(t0 + C[s] * h, y0 + h * (A_ROWS[s] @ K[:s]))
    y1 = y0 + h * (B @ K[:6])
    K[6] = rhs(t0 + h, y1)
    return RKStep(t0, h, y0, y1, h * (E @ K), K)


class DenseStep:
    """The continuous extension of one step: y(t) for t in [t0, t0 + h], 4th order."""

    def __init__(self, step: RKStep):
        self.t0, self.h, self.y0 = step.t0, step.h, step.y0
        self.Q = step.K.T @ P

    def __call__(self, t: float) -> np.ndarray:
        x = (t - self.t0) / self.h
        powers = np.array([x, x * x, x ** 3, x ** 4])
        return self.y0 + self.h * (self.Q @ powers)


class StepInterpolant:
    """Dense output of an accepted step of the multiplier method: y(t) = (q, qd, work).

    q follows the quintic Hermite interpolant of the two accepted states (q, qd, qdd at both
    ends, where all three constraint levels hold) and qd the cubic Hermite interpolant of
    (qd, qdd): both O(h^5) or better, and neither divides the step's local error by h (the
    derivative of the quintic would). The RK continuous extension of the position pass's
    trajectory is not used for them: it carries the excursion of the interpolated lambda in
    the constraint-normal directions, O(h^4) in q and O(h^3) in qd (docs/method.md). The
    dissipated work (quadrature states) comes from the RK extension `work_dense`.
    """

    def __init__(self, start, end, work_dense: DenseStep):
        self.t0, self.h = start.t, end.t - start.t
        h = self.h
        self.nq = start.q.shape[0]
        self.positions = np.stack((start.q, h * start.qd, h * h * start.qdd,
                                   end.q, h * end.qd, h * h * end.qdd))
        self.velocities = np.stack((start.qd, h * start.qdd, end.qd, h * end.qdd))
        self.work_dense = work_dense

    def __call__(self, t: float) -> np.ndarray:
        x = (t - self.t0) / self.h
        x2, x3 = x * x, x ** 3
        x4, x5 = x3 * x, x3 * x2
        quintic = np.array([1 - 10 * x3 + 15 * x4 - 6 * x5, x - 6 * x3 + 8 * x4 - 3 * x5,
                            0.5 * (x2 - 3 * x3 + 3 * x4 - x5), 10 * x3 - 15 * x4 + 6 * x5,
                            -4 * x3 + 7 * x4 - 3 * x5, 0.5 * (x3 - 2 * x4 + x5)])
        cubic = np.array([2 * x3 - 3 * x2 + 1, x3 - 2 * x2 + x, 3 * x2 - 2 * x3, x3 - x2])
        q = quintic @ self.positions
        qd = cubic @ self.velocities
        return np.concatenate((q, qd, self.work_dense(t)[2 * self.nq:]))
