"""A local sensitivity study: the deployment metrics' derivatives at one point and the spread
they predict to first order, from one run with forward sensitivities (docs/calibration.md;
docs/method.md, 12) instead of a Monte Carlo's thousands.

    study = local_study(result, spreads={"h1.friction": 0.068, "cable_k": 289.0})
    print(study.text())

For each metric m the table gives its value at the point, dm/dp for each parameter, the
elasticity (p / m) dm/dp, and with spreads sigma_p the first-order standard deviation
sqrt(sum (dm/dp sigma_p)^2) with each parameter's share of its variance. It is a first look:
it holds while m is close to linear over the spread, which a latch that may not engage, a
change of the events' order or a saturating load break; the Monte Carlo answers then.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np


@dataclasses.dataclass(frozen=True)
class LocalStudy:
    """The metrics' derivatives at one point. Shapes: m metrics, k parameters."""

    parameters: tuple[str, ...]  # (k,)
    point: np.ndarray  # (k,) the parameters' values (SI)
    spreads: np.ndarray  # (k,) their standard deviations (SI; NaN: none given)
    metrics: tuple[str, ...]  # (m,) deployment metrics (depsim.runtime.sweep.metrics names)
    values: np.ndarray  # (m,) at the point
    derivatives: np.ndarray  # (m, k) d metric / d parameter (SI per SI)

    @property
    def sigma(self) -> np.ndarray:
        """(m,) each metric's first-order standard deviation from the parameters' spreads
        (those with a spread)."""
        spread = np.where(np.isfinite(self.spreads), self.spreads, 0.0)
        return np.sqrt(np.sum((self.derivatives * spread) ** 2, axis=1))

    @property
    def elasticities(self) -> np.ndarray:
        """(m, k) (p / m) dm/dp: the metric's relative change per relative change of p."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.derivatives * self.point[None, :] / self.values[:, None]

    def to_dict(self) -> dict:
        """Plain JSON-ready data (NaN as None)."""
        def number(x: float):
            return float(x) if math.isfinite(x) else None

        return {"parameters": {name: {"value": number(v), "sigma": number(s)} for name, v, s
                               in zip(self.parameters, self.point, self.spreads)},
                "metrics": {name: {"value": number(self.values[i]),
                                   "sigma": number(self.sigma[i]),
                                   "derivatives": {p: number(self.derivatives[i, j])
                                                   for j, p in enumerate(self.parameters)}}
                            for i, name in enumerate(self.metrics)}}

    def text(self) -> str:
        """The table: per metric its value, first-order sigma and, per parameter, dm/dp and
        the share of the metric's variance it brings."""
        has_spread = bool(np.any(np.isfinite(self.spreads)))
        lines = ["local sensitivities (first order, from one run's forward sensitivities)"]
        lines += [f"  {name} = {value:.6g}" + (f" +- {spread:.3g} (1 sigma)"
                                                   if math.isfinite(spread) else "")
                  for name, value, spread in zip(self.parameters, self.point, self.spreads)]
        width = max([len(m) for m in self.metrics] + [6])
        header = f"  {'metric':<{width}}  {'value':>12}" + ("  1-sigma" if has_spread else "")
        for name in self.parameters:
            header += f"  {'d/d ' + name:>20}" + ("   share" if has_spread else "")
        lines.append(header)
        variance = self.sigma ** 2
        spread = np.where(np.isfinite(self.spreads), self.spreads, 0.0)
        for i, metric in enumerate(self.metrics):
            row = f"  {metric:<{width}}  {self.values[i]:12.6g}"
            if has_spread:
                row += f"  {self.sigma[i]:7.3g}"
            for j in range(len(self.parameters)):
                row += f"  {self.derivatives[i, j]:20.6g}"
                if has_spread:  # (no share of a spread at the round-off of the value)
                    part = (self.derivatives[i, j] * spread[j]) ** 2
                    resolved = self.sigma[i] > 1e-12 * abs(self.values[i])
                    row += f"  {100 * part / variance[i]:5.1f}%" if resolved else "       "
            lines.append(row)
        return "\n".join(lines)


def local_study(result, spreads: Mapping[str, float] | None = None) -> LocalStudy:
    """The deployment metrics of `result` (a Result with sensitivities) and their
    derivatives: time_to_deploy (the last latch's time), each event's first time
    (event.<name>.t) and each output's final value (final.<output>). ValueError for a result
    without sensitivities."""
    s = result.sensitivities
    if s is None:
        raise ValueError("a local study needs a run with sensitivities")
    spreads = dict(spreads or {})
    k = len(s.parameters)
    point = np.array([result.parameters[result.parameter_names.index(n)] for n in s.parameters])
    metrics, values, rows = [], [], []
    first = {}
    for index, event in enumerate(result.events):
        if event.t > 0 and event.name not in first:
            first[event.name] = index
    deployment = result.deployment
    if deployment is not None and deployment.deployed and deployment.time is not None:
        last = [i for i in first.values() if result.events[i].t == deployment.time]
        if last:
            metrics.append("time_to_deploy")
            values.append(deployment.time)
            rows.append(s.event_times[last[0]])
    for name, index in first.items():
        metrics.append(f"event.{name}.t")
        values.append(result.events[index].t)
        rows.append(s.event_times[index])
    for j, name in enumerate(result.output_names):
        metrics.append(f"final.{name}")
        values.append(result.outputs[-1, j] if len(result.times) else math.nan)
        rows.append(s.outputs[-1, :, j] if len(result.times) else np.full(k, math.nan))
    return LocalStudy(parameters=tuple(s.parameters), point=point,
                      spreads=np.array([spreads.get(n, math.nan) for n in s.parameters],
                                       dtype=float),
                      metrics=tuple(metrics), values=np.array(values, dtype=float),
                      derivatives=np.array(rows, dtype=float).reshape(len(metrics), k))
