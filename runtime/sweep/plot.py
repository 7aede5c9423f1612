"""Plot a study: one row per metric, its histogram and its scatter against the varied
parameters that drive it most. Written with matplotlib's Agg canvas (no display needed), in the
format the file's extension names (PNG, PDF, SVG, ...: depsim.runtime.plot.PLOT_FORMATS)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..output import atomic_path
from ..plot import plot_format
from .summary import drivers, metric_names, varied_parameters

__all__ = ["plot_study", "plotted_metrics"]


def plotted_metrics(ds, limit: int = 8) -> list[str]:
    """The metrics worth a row: events, deployed, peaks, finals and user metrics before run
    statistics; constant or empty metrics are left out."""
    ok = ~np.asarray(ds["failed"].values, dtype=bool)
    chosen = []
    names = metric_names(ds)
    names = [n for n in names if not n.startswith("stats.")] + \
        [n for n in names if n.startswith("stats.")]
    for name in names:
        values = np.asarray(ds[name].values, dtype=float)[ok]
        values = values[np.isfinite(values)]
        if values.size and np.ptp(values) > 0:
            chosen.append(name)
        if len(chosen) >= limit:
            break
    return chosen


def plot_study(ds, path: str | os.PathLike, metrics: list[str] | None = None,
               max_parameters: int = 3, dpi: int = 100) -> Path:
    """Write an image (its format from the extension of `path`, OutputError for an unknown
    one): for each metric a histogram and scatter plots against varied parameters. The file
    is written through `output.atomic_path` (no half-written file, ever)."""
    image_format = plot_format(path)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    metrics = metrics if metrics is not None else plotted_metrics(ds)
    params = varied_parameters(ds)
    ok = ~np.asarray(ds["failed"].values, dtype=bool)
    cols = 1 + min(max_parameters, len(params))
    rows = max(1, len(metrics))
    fig = Figure(figsize=(3.6 * cols, 2.6 * rows + 0.4), dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    title = ds.attrs.get("title", "depsim parameter study")
    fig.suptitle(f"{title}: {int(ds.sizes['run'])} runs, {int((~ok).sum())} failed")
    if not metrics:
        ax = fig.add_subplot(1, 1, 1)
        ax.text(0.5, 0.5, "no varying metric to plot", ha="center", va="center")
        ax.set_axis_off()
    for r, name in enumerate(metrics):
        y = np.asarray(ds[name].values, dtype=float)
        finite = ok & np.isfinite(y)
        ax = fig.add_subplot(rows, cols, r * cols + 1)
        units = ds[name].attrs.get("units", "")
        if finite.any():
            ax.hist(y[finite], bins=min(40, max(5, int(np.sqrt(finite.sum())))),
                    color="tab:blue", alpha=0.8)
        ax.set_xlabel(f"{name} [{units}]" if units else name, fontsize=8)
        ax.set_ylabel("runs", fontsize=8)
        ax.tick_params(labelsize=7)
        ranked = [p for p, _ in drivers(ds, name, params)] if params else []
        ranked += [p for p in params if p not in ranked]
        for c, pname in enumerate(ranked[:cols - 1]):
            ax = fig.add_subplot(rows, cols, r * cols + 2 + c)
            x = np.asarray(ds[pname].values, dtype=float)
            ax.scatter(x[finite], y[finite], s=4, alpha=0.5, color="tab:blue")
            bad = ~ok
            if bad.any():  # failed runs along the bottom edge
                ax.scatter(x[bad], np.full(bad.sum(), np.nanmin(y[finite]) if finite.any()
                                           else 0.0), s=10, marker="x", color="tab:red",
                           label="failed")
            rho = dict(drivers(ds, name, [pname])).get(pname)
            ax.set_title(f"rho = {rho:+.2f}" if rho is not None else "", fontsize=8)
            ax.set_xlabel(pname, fontsize=8)
            ax.set_ylabel(name, fontsize=8)
            ax.tick_params(labelsize=7)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=image_format)
    return Path(path)
