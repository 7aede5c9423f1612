"""Step size control and the multiplier predictor.

The paper's (4)-(5): the new step h_new = fac h comes from the user's tolerance, combining the
error of the multiplier interpolation (proportional to h^4) with the ODE method's own error
(proportional to h^N, N = 5 for the Dormand-Prince 5(4) estimate). Both are measured in the
same weighted RMS norm (1 means "at tolerance"); the step is accepted when

    E(1) = err_lam + err_ode <= 1,     E(fac) = err_lam fac^4 + err_ode fac^N,

and fac solves E(fac) = SAFETY, clipped to [FAC_MIN, FAC_MAX]. See docs/method.md.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from .dopri import ERROR_ORDER

SAFETY = 0.6  # target E(fac): about 0.9^5, the classical safety factor
FAC_MIN, FAC_MAX = 0.2, 5.0
INTERPOLATION_ORDER = 4
RHO_TARGET = 0.2  # wanted contraction rate of the position pass


def weights(y0: np.ndarray, y1: np.ndarray, tol: float) -> np.ndarray:
    """Scale of each state component: tol * (1 + max(|y0|, |y1|)) (absolute = relative)."""
    return tol * (1.0 + np.maximum(np.abs(y0), np.abs(y1)))


def rms(x: np.ndarray, scale: np.ndarray) -> float:
    return float(np.sqrt(np.mean((x / scale) ** 2))) if x.size else 0.0


def interpolation_error(h, history, lam1, J1, mass, scale_q) -> float:
    """err_lam: the position excursion (h^4/24) M^-1 Phi_q^T lambda'' that linear
    interpolation of lambda causes inside a step, lambda'' from the divided difference of the
    last two accepted lambdas and lam1 (nc,). 0 when fewer than two are known."""
    if len(history) < 2 or lam1.size == 0:
        return 0.0
    (t_a, lam_a), (t_b, lam_b) = history[-2], history[-1]
    h_prev = t_b - t_a
    second = 2.0 * ((lam1 - lam_b) / h - (lam_b - lam_a) / h_prev) / (h + h_prev)
    excursion = h ** 4 / 24.0 * mass.solve(J1.T @ second)
    return rms(excursion, scale_q)


def step_factor(err_lam: float, err_ode: float, accepted: bool) -> float:
    """fac = h_new / h solving err_lam fac^4 + err_ode fac^N = SAFETY, clipped to
    [FAC_MIN, FAC_MAX] (to 1 after a rejection). E is increasing and convex in log fac, so
    Newton's method in log fac from the smaller single-term root converges monotonically."""
    high = FAC_MAX if accepted else 1.0

    def excess(fac):
        return err_lam * fac ** INTERPOLATION_ORDER + err_ode * fac ** ERROR_ORDER - SAFETY

    if excess(high) <= 0.0:
        return high
    if excess(FAC_MIN) >= 0.0:
        return FAC_MIN
    x = np.log(min((SAFETY / e) ** (1.0 / n) for e, n in
                   ((err_lam, INTERPOLATION_ORDER), (err_ode, ERROR_ORDER)) if e > 0.0))
    for _ in range(6):
        a = err_lam * np.exp(INTERPOLATION_ORDER * x)
        b = err_ode * np.exp(ERROR_ORDER * x)
        x -= (a + b - SAFETY) / (INTERPOLATION_ORDER * a + ERROR_ORDER * b)
    return float(np.clip(np.exp(x), FAC_MIN, high))


def convergence_factor(report) -> float:
    """Largest fac the position pass's convergence allows: its contraction rate
    rho = e_m / e_{m-1} grows like (omega h)^2 (omega: the fastest motion under frozen
    lambda, e.g. the geometric stiffness of a loaded joint), so keep rho near RHO_TARGET."""
    errors = report.errors
    rho = max((b / a for a, b in zip(errors, errors[1:]) if a > 0), default=0.0)
    if rho <= RHO_TARGET:
        return FAC_MAX
    return max(0.5, np.sqrt(RHO_TARGET / rho))


class LambdaHistory:
    """The last accepted (t, lambda) values and the predictor of the position pass.

    For frozen Phi_q the position pass converges to the lambda_{i+1} whose linear
    interpolation moves q_{i+1} as the true lambda(t) would:

        lambda_{i+1} = lambda_i + 6 * integral_0^1 (1 - s) (lambda(t_i + s h) - lambda_i) ds
                     = lambda_i + h lambda' + (h^2/4) lambda'' + (h^3/20) lambda^(3) + ...

    which is not lambda(t_{i+1}): the chord must undercut a curved lambda (docs/method.md).
    The predictor evaluates that integral (3-point Gauss-Legendre, exact here) for the
    polynomial through the last POINTS accepted values.
    """

    POINTS = 4  # cubic extrapolation
    NODES = 0.5 * (np.polynomial.legendre.leggauss(3)[0] + 1.0)
    WEIGHTS = 0.5 * np.polynomial.legendre.leggauss(3)[1] * (1.0 - NODES)

    def __init__(self, t: float, lam: np.ndarray):
        self.points: deque = deque([(t, lam)], maxlen=self.POINTS)

    def add(self, t: float, lam: np.ndarray) -> None:
        self.points.append((t, lam))

    def __len__(self):
        return len(self.points)

    def __getitem__(self, k):
        return self.points[k]

    def _lagrange(self, t: float) -> list[float]:
        """Weights of the points in the polynomial through them, evaluated at t."""
        ts = [p[0] for p in self.points]
        weights = []
        for j, tj in enumerate(ts):
            weight = 1.0
            for m, tm in enumerate(ts):
                if m != j:
                    weight *= (t - tm) / (tj - tm)
            weights.append(weight)
        return weights

    def predict(self, t: float) -> np.ndarray:
        """The position pass's starting lambda_{i+1} for a step ending at t (s)."""
        t_i, lam_i = self.points[-1]
        if len(self.points) == 1:
            return lam_i
        h = t - t_i
        coefficients = np.zeros(len(self.points))
        for s, w in zip(self.NODES, self.WEIGHTS):
            coefficients += w * np.array(self._lagrange(t_i + s * h))
        coefficients *= 6.0
        coefficients[-1] += 1.0 - 6.0 * self.WEIGHTS.sum()
        return sum(c * lam for c, (_, lam) in zip(coefficients, self.points))


def initial_step(rhs, t0: float, y0: np.ndarray, f0: np.ndarray, tol: float, span: float) -> float:
    """Hairer-Norsett-Wanner's starting step (Solving ODEs I, II.4) for y' = rhs(t, y)."""
    scale = weights(y0, y0, tol)
    d0, d1 = rms(y0, scale), rms(f0, scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, span)
    f1 = rhs(t0 + h0, y0 + h0 * f0)
    d2 = rms(f1 - f0, scale) / h0
    if max(d1, d2) <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / ERROR_ORDER)
    return min(100 * h0, h1, span)
