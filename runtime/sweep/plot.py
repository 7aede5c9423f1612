"""Plot a study: what a mechanism engineer reads first, top to bottom.

1. Deployment (models with latches): the share of runs deployed by each time (the empirical
   CDF of the time to deploy, which levels off at the share deployed) with its percentiles;
   the shares of runs deployed, not deployed and failed, with P(not deployed) and its
   Clopper-Pearson interval.
2. Latches and loads: each latch's time, each hinge's peak lock torque and peak force as
   intervals (median, p25-p75, p5-p95, all runs), with the limits given (`limits`) and the
   probability of exceeding them.
3. Sensitivity: Spearman's rank correlation of the metrics that vary with every varied
   parameter, as a colour table (at most 40 rows), and the parameters ranked by how strongly
   they drive the time to deploy and the largest peak loads.
4. Drivers: those metrics against the parameter that drives each most (runs that failed, or
   whose event never came, marked).
A model without latches or loads gets the empirical CDFs of its metrics in place of 1 and 2.
Intervals and tables have one row per latch, hinge or metric, so 4 or 40 stay legible (the
figure grows). Angles are shown in degrees. Drawn with matplotlib's Agg canvas (no display
needed), in the format the file's extension names (depsim.runtime.plot.PLOT_FORMATS).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ..output import atomic_path
from ..plot import display_values, plot_format
from .probability import exceedance, not_deployed
from .summary import drivers, metric_names, metric_unit, varied_parameters, varying

__all__ = ["plot_study", "study_figure", "plotted_metrics"]

WIDTH = 11.0  # in
ROW = 0.26  # in: one row of an interval plot or of the sensitivity table
MAX_TABLE_ROWS = 40


def plotted_metrics(ds, limit: int | None = None) -> list[str]:
    """The metrics worth showing (at most `limit`): those that vary (`summary.varying`),
    deployment, events, peaks, dissipated energies, finals and user metrics before run
    statistics."""
    names = [n for n in metric_names(ds) if n != "deployed"]
    varies = varying(ds, names)
    chosen = [n for n in names if varies[n] and not n.startswith("stats.")]
    chosen += [n for n in names if varies[n] and n.startswith("stats.")]
    return chosen[:limit]


def plot_study(ds, path: str | os.PathLike, metrics: list[str] | None = None,
               limits: dict[str, float] | None = None, dpi: int = 100) -> Path:
    """Write the study's figure (`study_figure`) to `path`, in the format of its extension
    (OutputError for an unknown one), through `output.atomic_path` (never half-written).
    limits: {metric: SI value}, drawn with the probability of exceeding them."""
    image_format = plot_format(path)
    figure = study_figure(ds, metrics, limits)
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format=image_format, dpi=dpi)
    return Path(path)


def study_figure(ds, metrics: list[str] | None = None, limits: dict[str, float] | None = None):
    """The study's matplotlib Figure (module docstring); `metrics`: those of the sensitivity
    table and the CDFs (default `plotted_metrics`)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    view = _View(ds, metrics, limits or {})
    sections = view.sections()
    figure = Figure(figsize=(WIDTH, sum(h for h, _ in sections) + 0.5), layout="constrained")
    FigureCanvasAgg(figure)
    failed = int((~view.ok).sum())
    figure.suptitle(f"{ds.attrs.get('title', 'depsim parameter study')}: "
                    f"{_runs(int(ds.sizes['run']))}, {failed} failed", fontsize=12)
    parts = figure.subfigures(len(sections), 1, height_ratios=[h for h, _ in sections])
    for part, (_, draw) in zip(np.atleast_1d(parts), sections):
        draw(part)
    return figure


class _View:
    """What the figure shows of a study: the metrics of each section, in display units."""

    def __init__(self, ds, metrics, limits):
        self.ds, self.limits = ds, limits
        self.ok = ~np.asarray(ds["failed"].values, dtype=bool)
        self.params = varied_parameters(ds)
        self.metrics = metrics if metrics is not None else plotted_metrics(ds)
        names = metric_names(ds)
        self.latches = [n for n in names if n.startswith("event.") and n.endswith(".latch.t")]
        self.torques = [n for n in names if n.startswith("peak.") and n.endswith(".torque")]
        self.forces = [n for n in names if n.startswith("peak.") and n.endswith(".force")]

    def values(self, name: str) -> tuple[np.ndarray, str]:
        """The successful runs' values of a metric, in display units, and that unit."""
        values = np.asarray(self.ds[name].values, dtype=float)[self.ok]
        return display_values(values, metric_unit(self.ds, name))

    def sections(self) -> list[tuple[float, object]]:
        """(height in inches, draw(subfigure)) of each section, top to bottom."""
        out = []
        if "deployed" in self.ds:
            out.append((3.0, self.deployment))
        rows = max(len(self.latches), len(self.torques), len(self.forces))
        if rows:
            out.append((max(2.6, ROW * rows + 1.2), self.intervals_section))
        if not out:
            out.append((2.6 * math.ceil(min(6, max(1, len(self.metrics))) / 3),
                        self.distributions))
        if self.params and self.table_rows():
            height = ROW * max(len(self.table_rows()), len(self.params)) + 1.8
            out.append((height, self.sensitivity))
        if self.params and self.key_metrics():
            out.append((3.0, self.scatter))
        return out

    # -- 1. deployment --------------------------------------------------------------------
    def deployment(self, part) -> None:
        """The share of runs deployed by each time, and the outcomes' shares."""
        left, right = part.subplots(1, 2, width_ratios=(2.2, 1))
        missing = not_deployed(self.ds)
        times = np.asarray(self.ds["time_to_deploy"].values, dtype=float)[self.ok] \
            if "time_to_deploy" in self.ds else np.array([])
        deployed = np.sort(times[np.isfinite(times)])
        if missing is not None and missing.n and deployed.size:
            y = np.arange(1, deployed.size + 1) / missing.n
            left.step(np.r_[deployed[0], deployed], np.r_[0, y], where="post",
                      color="tab:green", lw=1.6)
            left.axhspan(1 - missing.high, 1 - missing.low, color="tab:green", alpha=0.15,
                         label="95 % CI of the share deployed")
            left.legend(loc="lower right", fontsize=7)
            _percentile_marks(left, deployed)
        left.set_ylim(0, 1.05)
        left.set_title("share of runs deployed by time t (levels off at the share deployed)",
                       fontsize=9)
        left.set_xlabel("time to full deployment [s]", fontsize=8)
        left.set_ylabel("share of runs", fontsize=8)
        _style(left)
        self.outcomes(right, missing)

    def outcomes(self, ax, missing) -> None:
        """Deployed, not deployed and failed runs as shares of all runs; P(not deployed)
        with its Clopper-Pearson interval."""
        runs = int(self.ds.sizes["run"])
        failed = runs - int(self.ok.sum())
        counts = [missing.n - missing.k, missing.k, failed] if missing else [0, 0, failed]
        labels = ["deployed", "not deployed", "failed (no answer)"]
        colours = ["tab:green", "tab:orange", "tab:red"]
        ax.barh(range(3), [c / runs for c in counts], color=colours, height=0.55)
        share = missing.n / runs if missing is not None else 0.0
        ends = [c / runs for c in counts]
        if missing is not None and missing.n:  # past the interval's end
            ends[1] = max(ends[1], missing.high * share)
        for k, count in enumerate(counts):
            ax.annotate(f"{count} ({100 * count / runs:.1f} %)", (ends[k], k),
                        xytext=(4, 0), textcoords="offset points", va="center", fontsize=7)
        if missing is not None and missing.n:  # P(not deployed) is a share of the completed
            ax.errorbar(missing.p * share, 1, xerr=[[(missing.p - missing.low) * share],
                                                    [(missing.high - missing.p) * share]],
                        color="black", capsize=3, lw=0.9)
            ax.set_title(f"P(not deployed) = {100 * missing.p:.1f} %\n(95 % CI "
                         f"{100 * missing.low:.1f} to {100 * missing.high:.1f} %, "
                         "Clopper-Pearson)", fontsize=9)
        ax.set_yticks(range(3), labels)
        ax.set_ylim(2.6, -0.6)
        ax.set_xlim(0, 1.3)
        ax.set_xlabel(f"share of the {_runs(runs)}" if runs != 1 else "share of the run",
                      fontsize=8)
        _style(ax, grid="x")

    # -- 2. latch times and peak loads ------------------------------------------------------
    def intervals_section(self, part) -> None:
        """A panel each for the latch times, peak lock torques and peak forces, one row per
        hinge."""
        axes = part.subplots(1, 3)
        for ax, names, what, suffix in ((axes[0], self.latches, "latch time", ".latch.t"),
                                        (axes[1], self.torques, "peak lock torque", ".torque"),
                                        (axes[2], self.forces, "peak hinge force", ".force")):
            if not names:
                ax.set_axis_off()
                continue
            labels = [n.split(".", 1)[1][:-len(suffix)] for n in names]
            self.intervals(ax, names, labels, what)

    def intervals(self, ax, names: list[str], labels: list[str], what: str) -> None:
        """One row per metric, top down: min-max (thin), p5-p95, p25-p75 (thick), median."""
        unit = ""
        for row, name in enumerate(names):
            values, unit = self.values(name)
            values = values[np.isfinite(values)]
            if not values.size:
                continue
            lo, p5, p25, p50, p75, p95, hi = np.percentile(values, [0, 5, 25, 50, 75, 95, 100])
            ax.hlines(row, lo, hi, color="0.6", lw=0.8)
            ax.hlines(row, p5, p95, color="tab:blue", lw=2.2)
            ax.hlines(row, p25, p75, color="tab:blue", lw=5.5)
            ax.plot(p50, row, "o", ms=4.5, mfc="white", mec="black", mew=0.8, zorder=3)
        for name in names:
            if name in self.limits:
                self._limit(ax, name)
        ax.set_yticks(range(len(names)), labels)
        ax.set_ylim(max(len(names), 3) - 0.5, -0.5)
        ax.set_title(f"{what}s: median (o), p25-p75,\np5-p95 (thin: all runs)", fontsize=9)
        ax.set_xlabel(f"{what} [{unit}]" if unit and unit != "1" else what, fontsize=8)
        _style(ax, grid="x")

    def _limit(self, ax, name: str) -> None:
        (value,), unit = display_values(np.array([self.limits[name]]),
                                        metric_unit(self.ds, name))
        chance = exceedance(self.ds, name, self.limits[name])
        ax.axvline(value, color="tab:red", lw=1.0, ls="--")
        unit = f" {unit}" if unit and unit != "1" else ""
        ax.annotate(f"{name} > {value:.4g}{unit}: P = {100 * chance.p:.1f} %", (value, 0.0),
                    xycoords=("data", "axes fraction"), xytext=(3, 3),
                    textcoords="offset points", color="tab:red", fontsize=7)

    # -- without deployment or loads -----------------------------------------------------------
    def distributions(self, part) -> None:
        names = (self.metrics or [])[:6]
        if not names:
            ax = part.subplots()
            ax.text(0.5, 0.5, "no metric varies over the runs", ha="center", va="center")
            ax.set_axis_off()
            return
        axes = np.atleast_1d(part.subplots(math.ceil(len(names) / 3), min(3, len(names))))
        for ax, name in zip(axes.ravel(), names):
            values, unit = self.values(name)
            values = np.sort(values[np.isfinite(values)])
            if values.size:
                ax.step(values, np.arange(1, values.size + 1) / values.size, where="post")
                _percentile_marks(ax, values)
            ax.set_xlabel(f"{name} [{unit}]" if unit and unit != "1" else name, fontsize=8)
            ax.set_ylabel("share of runs <= x", fontsize=8)
            _style(ax)
        for ax in axes.ravel()[len(names):]:
            ax.set_axis_off()

    # -- 3. sensitivity --------------------------------------------------------------------------
    def table_rows(self) -> list[str]:
        """The metrics of the sensitivity table, at most MAX_TABLE_ROWS: the time to deploy,
        latch times, peak torques and forces, energies, finals and user metrics before the
        latches' other numbers and the peaks' times (run statistics only if nothing else)."""
        groups = (lambda n: n == "time_to_deploy", lambda n: n in self.latches,
                  lambda n: n in self.torques, lambda n: n in self.forces,
                  lambda n: not n.startswith(("event.", "peak.", "stats.")),
                  lambda n: n.startswith("event."), lambda n: n.startswith("peak."))

        def rank(name: str) -> int:
            return next((k for k, test in enumerate(groups) if test(name)), len(groups))

        candidates = [m for m in self.metrics if not m.startswith("stats.")] or self.metrics
        members = [[m for m in candidates if rank(m) == k] for k in range(len(groups) + 1)]
        members = [group for group in members if group]
        # each group its share of the rows first (40 latches leave room for the loads),
        # then the rows left over in the groups' order
        share = max(4, MAX_TABLE_ROWS // max(1, len(members)))
        chosen = {m for group in members for m in group[:share]}
        for m in (m for group in members for m in group[share:]):
            if len(chosen) >= MAX_TABLE_ROWS:
                break
            chosen.add(m)
        return [m for group in members for m in group if m in chosen][:MAX_TABLE_ROWS]

    def sensitivity(self, part) -> None:
        """The colour table of rho (metrics x parameters) and, beside it, the parameters
        ranked by how strongly they drive each key metric."""
        rows = self.table_rows()
        table = np.full((len(rows), len(self.params)), np.nan)
        for i, name in enumerate(rows):
            rho = dict(drivers(self.ds, name, self.params))
            table[i] = [rho.get(p, np.nan) for p in self.params]
        keys = self.key_metrics() or rows[:1]
        share = min(2.2, 0.35 + 0.15 * len(self.params))
        grid = part.add_gridspec(len(keys), 2, width_ratios=(share, 1.0))
        ax = part.add_subplot(grid[:, 0])
        image = ax.imshow(np.ma.masked_invalid(table), cmap="RdBu_r", vmin=-1, vmax=1,
                          aspect="auto", interpolation="nearest")
        if table.size <= 400:
            for (i, j), rho in np.ndenumerate(table):
                if np.isfinite(rho):
                    ax.text(j, i, f"{rho:+.2f}", ha="center", va="center", fontsize=7,
                            color="white" if abs(rho) > 0.6 else "black")
        ax.set_yticks(range(len(rows)), rows, fontsize=7)
        tilt = len(self.params) > 3
        ax.set_xticks(range(len(self.params)), self.params, fontsize=7,
                      rotation=30 if tilt else 0, ha="right" if tilt else "center")
        shown = len([m for m in self.metrics if not m.startswith("stats.")])
        more = f" ({len(rows)} of {shown} metrics)" if shown > len(rows) else ""
        ax.set_title(f"Spearman rank correlation of each metric\nwith each varied parameter"
                     f"{more}", fontsize=9)
        part.colorbar(image, ax=ax, label="rho", shrink=0.9, aspect=30, pad=0.01)
        for k, name in enumerate(keys):
            self.ranked(part.add_subplot(grid[k, 1]), name, last=k == len(keys) - 1)

    def ranked(self, ax, name: str, last: bool = True) -> None:
        """Every varied parameter's rho with metric `name`, strongest on top (a sensitivity
        chart); `last`: the lowest chart, which carries the axis' label."""
        ranked = drivers(self.ds, name, self.params)
        ranked += [(p, math.nan) for p in self.params if p not in dict(ranked)]
        rho = np.array([r for _, r in ranked])
        ax.barh(range(len(ranked)), np.nan_to_num(rho), height=0.5,
                color=["tab:red" if r > 0 else "tab:blue" for r in rho])
        for k, r in enumerate(rho):
            if np.isfinite(r):
                ax.annotate(f"{r:+.2f}", (r, k), xytext=(3 if r >= 0 else -3, 0),
                            textcoords="offset points", va="center", fontsize=7,
                            ha="left" if r >= 0 else "right")
        ax.set_yticks(range(len(ranked)), [p for p, _ in ranked])
        ax.set_ylim(max(len(ranked), 3) - 0.5, -0.5)
        ax.set_xlim(-1.15, 1.15)
        ax.axvline(0, color="black", lw=0.6)
        ax.set_title(f"what drives {name}, strongest first", fontsize=9)
        if last:
            ax.set_xlabel("Spearman rho (+: the metric rises with the parameter)", fontsize=8)
        _style(ax, grid="x")

    # -- 4. drivers -------------------------------------------------------------------------------
    def key_metrics(self) -> list[str]:
        """Up to three: the time to deploy, the largest peak torque and force, else the first
        metrics shown; each only if it varies."""
        chosen = []
        if "time_to_deploy" in self.metrics:
            chosen.append("time_to_deploy")
        for group in (self.torques, self.forces):
            largest = self._largest([n for n in group if n in self.metrics])
            if largest:
                chosen.append(largest)
        chosen += [m for m in self.metrics if m not in chosen and not m.startswith("stats.")]
        return chosen[:3]

    def _largest(self, names: list[str]) -> str | None:
        medians = {n: np.nanmedian(self.values(n)[0]) for n in names
                   if np.isfinite(self.values(n)[0]).any()}
        return max(medians, key=medians.get) if medians else None

    def scatter(self, part) -> None:
        names = self.key_metrics()
        axes = np.atleast_1d(part.subplots(1, 3))
        all_runs = np.asarray(self.ds["failed"].values, dtype=bool)
        for ax, name in zip(axes, names):
            ranked = drivers(self.ds, name, self.params)
            parameter, rho = ranked[0] if ranked else (self.params[0], math.nan)
            x, x_unit = display_values(np.asarray(self.ds[parameter].values, dtype=float),
                                       metric_unit(self.ds, parameter))
            y, unit = display_values(np.asarray(self.ds[name].values, dtype=float),
                                     metric_unit(self.ds, name))
            good = ~all_runs & np.isfinite(y)
            ax.scatter(x[good], y[good], s=8, alpha=0.6, color="tab:blue")
            edge = np.nanmin(y[good]) if good.any() else 0.0
            missing = ~all_runs & ~np.isfinite(y)
            if missing.any():  # a time that never came: not deployed, not latched
                top = np.nanmax(y[good]) if good.any() else 1.0
                ax.scatter(x[missing], np.full(missing.sum(), top), marker="^", s=14,
                           color="tab:orange", label="not deployed"
                           if name == "time_to_deploy" else "never happened")
            if all_runs.any():
                ax.scatter(x[all_runs], np.full(all_runs.sum(), edge), marker="x", s=14,
                           color="tab:red", label="failed")
            if missing.any() or all_runs.any():
                ax.legend(fontsize=7, loc="best")
            ax.set_title(f"rho = {rho:+.2f}" if math.isfinite(rho) else "", fontsize=8)
            ax.set_xlabel(f"{parameter} [{x_unit}]" if x_unit else parameter, fontsize=8)
            ax.set_ylabel(f"{name} [{unit}]" if unit and unit != "1" else name, fontsize=8)
            _style(ax)
        for ax in axes[len(names):]:
            ax.set_axis_off()


def _percentile_marks(ax, values: np.ndarray) -> None:
    """p5, p50 and p95 of `values` as dotted lines, labelled at the axes' top, staggered."""
    for k, (q, value) in enumerate(zip((5, 50, 95), np.percentile(values, [5, 50, 95]))):
        ax.axvline(value, color="0.35", lw=0.7, ls=":")
        ax.annotate(f"p{q} {value:.4g}", (value, 1.0), xycoords=("data", "axes fraction"),
                    xytext=(2, -9 - 9 * k), textcoords="offset points", fontsize=7,
                    color="0.25")


def _runs(count: int) -> str:
    return f"{count} run{'s' * (count != 1)}"


def _style(ax, grid: str = "both") -> None:
    ax.tick_params(labelsize=7)
    ax.grid(True, axis=grid, alpha=0.3)
