"""The number engineers quote for a Monte Carlo study: the probability of an outcome (not
deploying, a load above a limit), estimated as k of n runs, with its exact (Clopper-Pearson)
confidence interval."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

__all__ = ["Probability", "probability", "not_deployed", "exceedance"]

CONFIDENCE = 0.95


@dataclasses.dataclass(frozen=True)
class Probability:
    """An outcome seen in `k` of `n` runs: its estimate k / n and the two-sided Clopper-Pearson
    interval [low, high] at `confidence` (exact: it covers the true probability at least that
    often, for every n, even k = 0)."""

    k: int
    n: int
    low: float
    high: float
    confidence: float = CONFIDENCE

    @property
    def p(self) -> float:
        return self.k / self.n if self.n else math.nan

    def text(self) -> str:
        """'7.1 % (95 % CI 4.0 to 11.6 %, Clopper-Pearson; 14 of 197 runs)'."""
        if not self.n:
            return "- (no run to count)"
        return (f"{_percent(self.p)} % ({100 * self.confidence:g} % CI {_percent(self.low)} "
                f"to {_percent(self.high)} %, Clopper-Pearson; {self.k} of {self.n} "
                f"run{'s' * (self.n != 1)})")


def probability(k: int, n: int, confidence: float = CONFIDENCE) -> Probability:
    """k of n runs, with the Clopper-Pearson interval: the p whose binomial tails leave
    (1 - confidence) / 2 on each side, from the beta distribution's quantiles."""
    if not 0 <= k <= n:
        raise ValueError(f"k = {k} of n = {n} runs")
    if n == 0:
        return Probability(0, 0, math.nan, math.nan, confidence)
    tail = (1.0 - confidence) / 2
    low = 0.0 if k == 0 else beta_quantile(tail, k, n - k + 1)
    high = 1.0 if k == n else beta_quantile(1.0 - tail, k + 1, n - k)
    return Probability(int(k), int(n), low, high, confidence)


# The beta distribution's quantiles, here rather than scipy.special.betaincinv: importing
# scipy.special took 0.15 to 0.6 s of `depsim sweep`'s summary (tests/runtime/
# test_sweep_summary.py checks these against scipy's).

def beta_cdf(x: float, a: float, b: float) -> float:
    """The regularized incomplete beta function I_x(a, b) (a, b > 0): Lentz's evaluation of
    its continued fraction (Numerical Recipes' betacf), on the side of the mean where it
    converges fast."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    front = math.exp(a * math.log(x) + b * math.log1p(-x) - _log_beta(a, b))
    if x < (a + 1.0) / (a + b + 2.0):
        return front * _beta_fraction(x, a, b) / a
    return 1.0 - front * _beta_fraction(1.0 - x, b, a) / b


def beta_quantile(y: float, a: float, b: float) -> float:
    """The x in [0, 1] with I_x(a, b) = y: Newton's steps on the CDF, kept inside the bracket
    that the CDF's values narrow (a bisection where a step would leave it)."""
    if y <= 0.0:
        return 0.0
    if y >= 1.0:
        return 1.0
    low, high = 0.0, 1.0
    x = a / (a + b)
    log_beta = _log_beta(a, b)
    for _ in range(400):
        error = beta_cdf(x, a, b) - y
        if error == 0.0:
            return x
        if error > 0.0:
            high = x
        else:
            low = x
        density = math.exp((a - 1.0) * math.log(x) + (b - 1.0) * math.log1p(-x) - log_beta)
        step = error / density if density > 0.0 else math.inf
        following = x - step
        if not low < following < high:
            following = 0.5 * (low + high)
        if abs(following - x) <= 4e-16 * x or high - low <= 4e-16 * high:
            return following
        x = following
    return x


def _log_beta(a: float, b: float) -> float:
    return math.lgamma(a) + math.lgamma(b) - math.lgamma(a + b)


def _beta_fraction(x: float, a: float, b: float) -> float:
    """The continued fraction of I_x(a, b) (modified Lentz)."""
    tiny = 1e-300
    c, d = 1.0, 1.0 - (a + b) * x / (a + 1.0)
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 100_000):
        for numerator in (m * (b - m) * x / ((a + 2 * m - 1.0) * (a + 2 * m)),
                          -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1.0))):
            d = 1.0 + numerator * d
            d = 1.0 / (d if abs(d) > tiny else tiny)
            c = 1.0 + numerator / c
            c = c if abs(c) > tiny else tiny
            h *= d * c
        if abs(d * c - 1.0) < 1e-16:
            break
    return h


def not_deployed(ds, confidence: float = CONFIDENCE) -> Probability | None:
    """P(not deployed) over the runs that completed (failed runs have no answer and are not
    counted); None for a model without latches."""
    if "deployed" not in ds:
        return None
    values = _completed(ds, "deployed")
    values = values[np.isfinite(values)]
    return probability(int((values == 0).sum()), int(values.size), confidence)


def exceedance(ds, metric: str, limit: float, confidence: float = CONFIDENCE) -> Probability:
    """P(metric > limit) over the runs that completed with a value of the metric (an event
    that never happened has none: its time is NaN)."""
    values = _completed(ds, metric)
    values = values[np.isfinite(values)]
    return probability(int((values > limit).sum()), int(values.size), confidence)


def _completed(ds, metric: str) -> np.ndarray:
    ok = ~np.asarray(ds["failed"].values, dtype=bool)
    return np.asarray(ds[metric].values, dtype=float)[ok]


def _percent(x: float) -> str:
    value = 100 * x
    return f"{value:.2g}" if 0 < value < 1 else f"{value:.1f}"
