"""The accelerated multiplier iteration, the paper's eq. (6):

    lambda^m = lambda^{m-1} - alpha * A v^{m-1} / C

v is one level's constraint error, C the sensitivity of that level to lambda_{i+1} over the
step (h^2/6, h/2, 1), and A ~ S^-1 with S = Phi_q M^-1 Phi_q^T. A is applied by Jacobi-
preconditioned conjugate gradients on S using only products with Phi_q, M^-1 and Phi_q^T:
no constraint matrix is ever factorised. alpha starts at 1 and is halved whenever a trial
would not reduce the error, so the accepted errors decrease monotonically.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

MAX_ITERATIONS = 25  # outer iterations of (6) per pass
MAX_HALVINGS = 4  # alpha = 1, 1/2, ..., 1/16 before giving up on a decrease


class Schur:
    """S = J M^-1 J^T for a dense Jacobian J (nc, NQ), applied as a product.

    For a small nc the product is formed once per Jacobian (nc x nc, a matrix product; still
    no factorisation); otherwise every application is J (M^-1 (J^T x)).
    """

    EXPLICIT_BELOW = 96

    def __init__(self, J: np.ndarray, mass):
        self.J = J
        self.mass = mass
        self.explicit = None
        if J.shape[0] < self.EXPLICIT_BELOW:
            self.explicit = J @ mass.solve(J.T)
            self.diag = np.diag(self.explicit).copy()
        elif mass.diagonal:
            self.diag = (J * J) @ mass.inverse_diagonal
        else:
            self.diag = np.einsum("ij,ji->i", J, mass.solve(J.T))

    def apply(self, x: np.ndarray) -> np.ndarray:
        """S x, shape (nc,)."""
        if self.explicit is not None:
            return self.explicit @ x
        return self.J @ self.mass.solve(self.J.T @ x)


_last_schur: list = [None]


def schur_for(J: np.ndarray, mass) -> Schur:
    """Schur(J, mass), reused while the same Jacobian array object comes back (the three
    passes of a step share Phi_q at q_{i+1})."""
    cached = _last_schur[0]
    if cached is None or cached.J is not J or cached.mass is not mass:
        cached = Schur(J, mass)
        _last_schur[0] = cached
    return cached


@dataclass(slots=True)
class CGResult:
    x: np.ndarray
    iterations: int
    converged: bool


def pcg(schur: Schur, b: np.ndarray, rtol: float = 1e-10, maxiter: int | None = None) -> CGResult:
    """Solve S x = b by Jacobi-preconditioned conjugate gradients (S symmetric semi-definite).

    A row whose diagonal of S vanishes (a zero Jacobian row) is left out of the preconditioner;
    its residual then never falls, which `converged=False` reports.
    """
    n = b.shape[0]
    maxiter = 2 * n + 10 if maxiter is None else maxiter
    scale = schur.diag.max() if n else 0.0
    live = schur.diag > 1e-14 * scale
    inv_diag = np.where(live, 1.0 / np.where(live, schur.diag, 1.0), 0.0)
    x = np.zeros(n)
    r = b.copy()
    target2 = rtol * rtol * (b @ b)
    z = inv_diag * r
    d = z.copy()
    rz = r @ z
    for k in range(maxiter):
        if r @ r <= target2:
            return CGResult(x, k, True)
        Sd = schur.apply(d)
        curvature = d @ Sd
        if not curvature > 0.0:
            break
        step = rz / curvature
        x += step * d
        r -= step * Sd
        z = inv_diag * r
        rz_new = r @ z
        d = z + (rz_new / rz) * d if rz > 0 else z
        rz = rz_new
    return CGResult(x, maxiter, bool(r @ r <= target2))


@dataclass(slots=True)
class Measurement:
    """One evaluation of a level's error: v (nc,), the Jacobian J (nc, NQ) where it was
    measured, the magnitude `scale` of the terms v balances (for round-off), and `payload`
    (whatever produced v: an RK trajectory, an acceleration)."""

    v: np.ndarray
    J: np.ndarray
    scale: float
    payload: object = None


@dataclass(slots=True)
class PassReport:
    """One pass of one step: max|v| before each update and after the last, iterations of (6)
    and conjugate-gradient iterations spent."""

    stage: str
    errors: list[float] = field(default_factory=list)
    iterations: int = 0
    cg_iterations: int = 0


class PassFailure(Exception):
    """A pass did not converge (internal: the step controller retries or raises SolverError)."""

    def __init__(self, stage: str, row: int, residual: float, reason: str, scale: float):
        super().__init__(f"{stage} pass: {reason}")
        self.stage, self.row, self.residual = stage, row, residual
        self.reason, self.scale = reason, scale


def iterate_multipliers(stage: str, lam: np.ndarray, measure: Callable[[np.ndarray], Measurement],
                        C: float, tol: float, mass, alpha: float = 1.0):
    """Iterate (6) from `lam` until max|v| <= tol * max(1, scale).

    Returns (lam, measurement, report). Raises PassFailure naming the worst row when the
    error stops decreasing or MAX_ITERATIONS pass.
    """
    current = measure(lam)
    error = max_abs(current.v)
    report = PassReport(stage, [error])
    limit = tol * max(1.0, current.scale)
    while not error <= limit:
        if not np.isfinite(error):
            _fail(stage, current, "the state or the forces became non-finite")
        if report.iterations >= MAX_ITERATIONS:
            _fail(stage, current, f"not below {limit:.2e} after {MAX_ITERATIONS} iterations")
        cg = pcg(schur_for(current.J, mass), current.v)
        report.cg_iterations += cg.iterations
        if not cg.converged:
            _fail(stage, current, "the multiplier system S = Phi_q M^-1 Phi_q^T is singular "
                  "or inconsistent here (conjugate gradients did not converge)")
        step = alpha * cg.x / C
        for _ in range(MAX_HALVINGS + 1):
            trial = measure(lam - step)
            trial_error = max_abs(trial.v)
            if trial_error < error:
                break
            step = 0.5 * step
        else:
            _fail(stage, current, "the error stopped decreasing")
        lam, current, error = lam - step, trial, trial_error
        report.iterations += 1
        report.errors.append(error)
        limit = tol * max(1.0, current.scale)
    return lam, current, report


def product_scale(J: np.ndarray, x: np.ndarray) -> float:
    """max_i sum_j |J_ij x_j|: the size of the terms J x sums, which sets its round-off."""
    return max_abs(np.abs(J) @ np.abs(x))


def max_abs(v: np.ndarray) -> float:
    """max |v_i|, 0 for an empty v."""
    return float(np.abs(v).max()) if v.size else 0.0


def _fail(stage: str, current: Measurement, reason: str):
    row = int(np.argmax(np.abs(current.v)))
    raise PassFailure(stage, row, float(abs(current.v[row])), reason, current.scale)


def project_velocity(J: np.ndarray, mass, qd: np.ndarray, phi_t: np.ndarray, tol: float):
    """Plastic impact: qd+ = qd - M^-1 J^T mu with J qd+ + phi_t = 0, the M-orthogonal
    projection of qd (NQ,) onto the velocity constraints, by the iteration (6) with C = 1.
    Returns (qd+, mu (nc,) in N s, report)."""
    def measure(mu):
        qd_new = qd - mass.solve(J.T @ mu)
        return Measurement(-(J @ qd_new) - phi_t, J, product_scale(J, qd_new), qd_new)

    mu, final, report = iterate_multipliers("velocity", np.zeros(J.shape[0]), measure, 1.0,
                                            tol, mass)
    return final.payload, mu, report
