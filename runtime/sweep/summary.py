"""Summary of a study: the probability of not deploying (and of a metric above a limit) with
its confidence interval, percentiles of every metric that varies, in its unit, the parameters
that drive it (Spearman rank correlation over the successful runs), and failures."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from ..plot import display_values
from .probability import exceedance, not_deployed

__all__ = ["metric_names", "varied_parameters", "ranks", "spearman", "drivers", "metric_table",
           "summarize", "metric_unit", "varying"]

NON_METRICS = {"failed", "error", "wall_time", "parameter_values"}
# Run statistics worth a line in the summary (all of them are in the Dataset).
SUMMARY_STATS = {"accepted_steps", "rejected_steps", "failed_steps", "position.total",
                 "velocity.total", "acceleration.total", "cg_iterations", "steps", "rejected",
                 "iterations"}
DEFAULT_TOL = 1e-8  # a study file that does not say its tol


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


def metric_unit(ds, name: str) -> str:
    """The SI unit of a metric or parameter ("" when unknown)."""
    return str(ds[name].attrs.get("units", "") or "")


def varying(ds, names: Sequence[str] | None = None) -> dict[str, bool]:
    """Whether each metric varies over the successful runs by more than the integration can
    resolve: its spread (max - min) exceeds tol x the largest magnitude of its unit in the
    study (its own values, the other metrics' and the varied parameters' of that unit; for
    a pure number or an unknown unit, its own values). A latched hinge's final angle, which
    differs between runs only by the solver's tolerance, does not vary."""
    ok = ~np.asarray(ds["failed"].values, dtype=bool)
    tol = float(ds.attrs.get("tol", DEFAULT_TOL))
    tol = tol if math.isfinite(tol) and tol > 0 else DEFAULT_TOL
    names = list(names) if names is not None else metric_names(ds)
    spreads, scales = {}, {}
    for name in names + varied_parameters(ds):
        values = np.asarray(ds[name].values, dtype=float)[ok]
        values = values[np.isfinite(values)]
        size = float(np.abs(values).max()) if values.size else 0.0
        spreads[name] = float(np.ptp(values)) if values.size else 0.0
        unit = metric_unit(ds, name)
        key = unit if unit not in ("", "1") else f"own:{name}"
        scales[key] = max(scales.get(key, 0.0), size)
    out = {}
    for name in names:
        unit = metric_unit(ds, name)
        scale = scales[unit if unit not in ("", "1") else f"own:{name}"]
        out[name] = spreads[name] > tol * scale
    return out


def metric_table(ds) -> list[dict]:
    """One row per metric: its unit, p5, p50, p95, mean (SI), n (finite values), whether it
    varies (`varying`) and its drivers (none for a metric that does not vary)."""
    ok = ~np.asarray(ds["failed"].values, dtype=bool)
    params = varied_parameters(ds)
    parameter_ranks = _parameter_ranks(ds, ok, params)
    names = metric_names(ds)
    varies = varying(ds, names)
    rows = []
    for name in names:
        values = np.asarray(ds[name].values, dtype=float)[ok]
        finite = values[np.isfinite(values)]
        if finite.size:
            p5, p50, p95 = np.percentile(finite, [5, 50, 95])
            mean = float(finite.mean())
        else:
            p5 = p50 = p95 = mean = math.nan
        rows.append({"metric": name, "unit": metric_unit(ds, name), "p5": float(p5),
                     "p50": float(p50), "p95": float(p95), "mean": mean,
                     "n": int(finite.size), "runs": int(ok.sum()), "varies": varies[name],
                     "drivers": drivers(ds, name, params, parameter_ranks)
                     if varies[name] else []})
    return rows


def _num(x: float, digits: int = 4) -> str:
    if math.isnan(x):
        return "-"
    if x == 0 or 1e-3 <= abs(x) < 1e5:
        return f"{x:.{digits}g}"
    return f"{x:.{digits - 1}e}"


def _digits(values: Sequence[float]) -> int:
    """Significant digits that tell the values apart (4 to 10): a spread of 1 mm on 8 m
    needs 6."""
    finite = [v for v in values if math.isfinite(v)]
    spread = max(finite) - min(finite) if finite else 0.0
    size = max((abs(v) for v in finite), default=0.0)
    if spread <= 0 or size <= 0:
        return 4
    return int(min(10, max(4, math.ceil(math.log10(size / spread)) + 2)))


def _shown(values, unit: str) -> tuple[list[float], str]:
    """Values and unit as printed: angles in degrees, the rest in SI."""
    converted, shown = display_values(np.asarray(values, dtype=float), unit)
    return converted.tolist(), shown


def summarize(ds, top: int = 3, max_errors: int = 5,
              limits: Mapping[str, float] | None = None) -> str:
    """Plain text: what was run; the probability of not deploying and of each metric above
    its limit in `limits` ({metric: SI value}), with their 95 % Clopper-Pearson intervals;
    a table of the metrics that vary (unit, percentiles, drivers); those that do not;
    failures; timing."""
    runs = int(ds.sizes["run"])
    failed = np.asarray(ds["failed"].values, dtype=bool)
    kind = str(ds.attrs.get("study_kind", "")).replace("_", " ")
    seed = f", seed {ds.attrs['seed']}" if "seed" in ds.attrs else ""
    lines = [f"{ds.attrs.get('title', 'depsim parameter study')}: {kind}, "
             f"{runs} run{'s' * (runs != 1)}, {int(failed.sum())} failed{seed}"]
    if ds.attrs.get("spec"):
        lines.append(f"spec: {ds.attrs['spec']}")
    lines += [""] + _probabilities(ds, limits or {})
    rows = [r for r in metric_table(ds) if r["metric"] != "deployed"  # the line above
            and (not r["metric"].startswith("stats.") or r["metric"][6:] in SUMMARY_STATS)]
    lines += _table([r for r in rows if r["varies"]], top)
    lines += _steady([r for r in rows if not r["varies"]])
    lines += _failures(ds, failed, max_errors)
    wall = np.asarray(ds["wall_time"].values, dtype=float)
    wall = wall[np.isfinite(wall)]
    if wall.size:
        lines += ["", f"solver wall time per run: median {np.median(wall):.3g} s, "
                      f"total {wall.sum():.3g} s"]
    return "\n".join(lines)


def _probabilities(ds, limits: Mapping[str, float]) -> list[str]:
    lines = []
    missing = not_deployed(ds)
    if missing is not None:
        lines.append(f"deployed in {missing.n - missing.k} of {missing.n} completed "
                     f"run{'s' * (missing.n != 1)}; "
                     f"P(not deployed) = {missing.text()}")
    for metric, limit in limits.items():
        if metric not in ds:
            raise ValueError(f"no metric '{metric}' in this study")
        (value,), unit = _shown([limit], metric_unit(ds, metric))
        lines.append(f"P({metric} > {_num(value)}{' ' + unit if unit else ''}) = "
                     f"{exceedance(ds, metric, limit).text()}")
    return lines + [""] if lines else []


def _table(rows: list[dict], top: int) -> list[str]:
    if not rows:
        return ["no metric varies over the runs"]
    shown = [(_shown([r["p5"], r["p50"], r["p95"]], r["unit"]), r) for r in rows]
    width = max(len(r["metric"]) for r in rows)
    unit_width = max([len(unit) for (_, unit), _ in shown] + [4])
    lines = [f"{'metric':<{width}}  {'unit':<{unit_width}} {'p5':>10} {'p50':>10} {'p95':>10} "
             f"{'n':>6}  drivers (Spearman rho)"]
    for (values, unit), row in shown:
        top_drivers = ", ".join(f"{p} {rho:+.2f}" for p, rho in row["drivers"][:top]) or "-"
        lines.append(f"{row['metric']:<{width}}  {unit:<{unit_width}} "
                     + " ".join(f"{_num(v, _digits(values)):>10}" for v in values)
                     + f" {row['n']:>6}  {top_drivers}")
    return lines


def _steady(rows: list[dict], listed: int = 12) -> list[str]:
    """The metrics that do not vary, with their value, on wrapped lines."""
    if not rows:
        return []
    items = []
    for row in rows[:listed]:
        (value,), unit = _shown([row["p50"]], row["unit"])
        unit = f" {unit}" if unit and unit != "1" else ""
        items.append(f"{row['metric']} = {_num(value)}{unit}")
    if len(rows) > listed:
        items.append(f"and {len(rows) - listed} more")
    count = f"{len(rows)} metric{'s' * (len(rows) != 1)}"
    lines, line = ["", f"not varying (to the integration tolerance), {count}:"], " "
    for item in items:
        if len(line) + len(item) > 96:
            lines.append(line.rstrip(","))
            line = " "
        line += f" {item},"
    return lines + [line.rstrip(",")]


def _failures(ds, failed: np.ndarray, max_errors: int) -> list[str]:
    if not failed.any():
        return []
    errors = np.asarray(ds["error"].values)
    indices = np.flatnonzero(failed)
    lines = ["", f"failed runs: {failed.sum()} of {failed.size}"]
    for i in indices[:max_errors]:
        lines.append(f"  run {int(ds['run'].values[i])}: {errors[i]}")
    if indices.size > max_errors:
        lines.append(f"  ... and {indices.size - max_errors} more (see the 'error' variable)")
    return lines
