"""Summary of a study: percentiles of every metric, failures, and the parameters that drive
each metric (Spearman rank correlation over the successful runs)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["metric_names", "varied_parameters", "ranks", "spearman", "drivers", "metric_table",
           "summarize"]

NON_METRICS = {"failed", "error", "wall_time", "parameter_values"}
# Run statistics worth a line in the summary (all of them are in the Dataset).
SUMMARY_STATS = {"accepted_steps", "rejected_steps", "failed_steps", "position.total",
                 "velocity.total", "acceleration.total", "cg_iterations", "steps", "rejected",
                 "iterations"}


def metric_names(ds) -> list[str]:
    """The per-run scalar metrics of a study Dataset, in file order."""
    return [str(n) for n, v in ds.data_vars.items()
            if v.dims == ("run",) and str(n) not in NON_METRICS]


def varied_parameters(ds) -> list[str]:
    varied = ds.attrs.get("varied", "")
    names = [n.strip() for n in str(varied).split(",") if n.strip()]
    return [n for n in names if n in ds.coords]


def ranks(x: np.ndarray) -> np.ndarray:
    """The ranks of x from 1, ties given their mean rank (scipy.stats.rankdata's "average";
    summaries of thousands of runs rank each parameter once, without importing scipy.stats)."""
    order = np.argsort(x, kind="mergesort")
    inverse = np.empty(order.size, dtype=np.intp)
    inverse[order] = np.arange(order.size)
    ordered = x[order]
    first = np.r_[True, ordered[1:] != ordered[:-1]]  # the start of each run of ties
    group = np.cumsum(first)[inverse]
    bounds = np.r_[np.flatnonzero(first), order.size]
    return 0.5 * (bounds[group] + bounds[group - 1] + 1)


def spearman(x: np.ndarray, y: np.ndarray, x_ranks: np.ndarray | None = None,
             y_ranks: np.ndarray | None = None) -> float:
    """Spearman's rank correlation of the pairs where both are finite (NaN for fewer than 3
    pairs or a constant side): Pearson's correlation of the ranks. x_ranks, y_ranks: the
    ranks, used when every pair is finite (each ranked once for a whole summary)."""
    keep = np.isfinite(x) & np.isfinite(y)
    if keep.sum() < 3 or np.ptp(x[keep]) == 0 or np.ptp(y[keep]) == 0:
        return math.nan
    every = keep.all()
    rx = x_ranks if x_ranks is not None and every else ranks(x[keep])
    ry = y_ranks if y_ranks is not None and every else ranks(y[keep])
    rx, ry = rx - rx.mean(), ry - ry.mean()
    return float(np.dot(rx, ry) / math.sqrt(np.dot(rx, rx) * np.dot(ry, ry)))


def drivers(ds, metric: str, parameters: Sequence[str] | None = None,
            parameter_ranks: dict[str, np.ndarray] | None = None) -> list[tuple[str, float]]:
    """(parameter, Spearman rho) for every varied parameter, largest |rho| first; NaN-free.
    parameter_ranks: each parameter's ranks over the successful runs (_parameter_ranks)."""
    ok = ~np.asarray(ds["failed"].values, dtype=bool)
    y = np.asarray(ds[metric].values, dtype=float)[ok]
    y_ranks = ranks(y) if y.size and np.isfinite(y).all() else None
    out = []
    for name in parameters if parameters is not None else varied_parameters(ds):
        x = np.asarray(ds[name].values, dtype=float)[ok]
        rho = spearman(x, y, (parameter_ranks or {}).get(name), y_ranks)
        if not math.isnan(rho):
            out.append((name, rho))
    return sorted(out, key=lambda item: -abs(item[1]))


def _parameter_ranks(ds, ok: np.ndarray, params: Sequence[str]) -> dict[str, np.ndarray]:
    out = {}
    for name in params:
        x = np.asarray(ds[name].values, dtype=float)[ok]
        if np.isfinite(x).all():
            out[name] = ranks(x)
    return out


def metric_table(ds) -> list[dict]:
    """One row per metric: p5, p50, p95, mean, n (finite values), drivers."""
    ok = ~np.asarray(ds["failed"].values, dtype=bool)
    params = varied_parameters(ds)
    parameter_ranks = _parameter_ranks(ds, ok, params)
    rows = []
    for name in metric_names(ds):
        values = np.asarray(ds[name].values, dtype=float)[ok]
        finite = values[np.isfinite(values)]
        if finite.size:
            p5, p50, p95 = np.percentile(finite, [5, 50, 95])
            mean = float(finite.mean())
        else:
            p5 = p50 = p95 = mean = math.nan
        rows.append({"metric": name, "p5": float(p5), "p50": float(p50), "p95": float(p95),
                     "mean": mean, "n": int(finite.size), "runs": int(ok.sum()),
                     "drivers": drivers(ds, name, params, parameter_ranks)})
    return rows


def _num(x: float) -> str:
    if math.isnan(x):
        return "-"
    if x == 0 or 1e-3 <= abs(x) < 1e5:
        return f"{x:.4g}"
    return f"{x:.3e}"


def summarize(ds, top: int = 3, max_errors: int = 5) -> str:
    """Plain text: what was run, the percentiles table, drivers, failures, timing."""
    runs = int(ds.sizes["run"])
    failed = np.asarray(ds["failed"].values, dtype=bool)
    lines = [f"{ds.attrs.get('title', 'depsim parameter study')}: "
             f"{ds.attrs.get('study_kind', '')}, {runs} runs, {int(failed.sum())} failed"
             + (f", seed {ds.attrs['seed']}" if "seed" in ds.attrs else "")]
    spec = ds.attrs.get("spec")
    if spec:
        lines.append(f"spec: {spec}")
    rows = [r for r in metric_table(ds)
            if not r["metric"].startswith("stats.") or r["metric"][6:] in SUMMARY_STATS]
    width = max([len(r["metric"]) for r in rows] + [6])
    lines.append("")
    lines.append(f"{'metric':<{width}}  {'p5':>10} {'p50':>10} {'p95':>10} {'n':>6}  "
                 f"drivers (Spearman rho)")
    for row in rows:
        name = row["metric"]
        top_drivers = ", ".join(f"{p} {rho:+.2f}" for p, rho in row["drivers"][:top]) or "-"
        if name == "deployed":
            values = np.asarray(ds[name].values, dtype=float)[~failed]
            yes = int(np.nansum(values))
            n = int(np.isfinite(values).sum())
            share = 100.0 * yes / n if n else math.nan
            lines.append(f"{name:<{width}}  {share:9.1f}% of {n} runs deployed; "
                         f"P(not deployed) = {100 - share:.1f}%   drivers: {top_drivers}")
            continue
        lines.append(f"{name:<{width}}  {_num(row['p5']):>10} {_num(row['p50']):>10} "
                     f"{_num(row['p95']):>10} {row['n']:>6}  {top_drivers}")
    if failed.any():
        errors = np.asarray(ds["error"].values)
        indices = np.flatnonzero(failed)
        lines.append("")
        lines.append(f"failed runs: {failed.sum()} of {runs}")
        for i in indices[:max_errors]:
            lines.append(f"  run {int(ds['run'].values[i])}: {errors[i]}")
        if indices.size > max_errors:
            lines.append(f"  ... and {indices.size - max_errors} more (see the 'error' variable)")
    wall = np.asarray(ds["wall_time"].values, dtype=float)
    wall = wall[np.isfinite(wall)]
    if wall.size:
        lines.append("")
        lines.append(f"solver wall time per run: median {np.median(wall):.3g} s, "
                     f"total {wall.sum():.3g} s")
    return "\n".join(lines)
