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
    from scipy.special import betaincinv

    tail = (1.0 - confidence) / 2
    low = 0.0 if k == 0 else float(betaincinv(k, n - k + 1, tail))
    high = 1.0 if k == n else float(betaincinv(k + 1, n - k, 1.0 - tail))
    return Probability(int(k), int(n), low, high, confidence)


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
