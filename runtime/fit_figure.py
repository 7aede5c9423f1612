"""`plot_fit`: a fit's figure, per measured column the measured values, the model at the
estimates and at the start, with the residuals below (docs/calibration.md)."""

from __future__ import annotations

import numpy as np

from .output import atomic_path
from .plot import DPI, display_values, plot_format


def plot_fit(fit, path) -> None:
    """Write `fit_figure(fit)` in the format of the extension of `path` (PLOT_FORMATS;
    OutputError for another), with matplotlib's Agg canvas, atomically."""
    image_format = plot_format(path)
    figure = fit_figure(fit)
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format=image_format, dpi=DPI)


def fit_figure(fit):
    """Two panels per column, sharing the time axis: measured (dots), fitted (line) and start
    (dashed) values, then the residuals (model - measured) with -+2 sigma. Angles in degrees.
    Measured event times are marked by black lines, the fitted ones by red dashed lines."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    count = max(1, len(fit.columns))
    figure = Figure(figsize=(8, 3.4 * count + 0.6), layout="constrained", dpi=DPI)
    FigureCanvasAgg(figure)
    axes = figure.subplots(2 * count, 1, sharex=True, squeeze=False,
                           gridspec_kw={"height_ratios": [2, 1] * count})[:, 0]
    for j, column in enumerate(fit.columns):
        top, bottom = axes[2 * j], axes[2 * j + 1]
        measured, unit = display_values(fit.measured[:, j], fit.column_units[j])
        fitted, _ = display_values(fit.fitted[:, j], fit.column_units[j])
        start, _ = display_values(fit.initial[:, j], fit.column_units[j])
        residual, _ = display_values(fit.fitted[:, j] - fit.measured[:, j],
                                     fit.column_units[j])
        band, _ = display_values(np.array([2 * fit.sigmas[j]]), fit.column_units[j])
        label = f" [{unit}]" if unit else ""
        top.plot(fit.times, measured, ".", ms=1.5, color="0.45", label="measured")
        top.plot(fit.times, start, "--", lw=1.0, color="tab:orange", label="start")
        top.plot(fit.times, fitted, lw=1.2, color="tab:blue", label="fitted")
        top.set_ylabel(f"{column}{label}")
        bottom.plot(fit.times, residual, ".", ms=1.5, color="tab:blue")
        bottom.axhline(0, color="0.3", lw=0.6)
        for sign in (-1, 1):
            bottom.axhline(sign * band[0], color="0.5", lw=0.6, ls=":")
        bottom.set_ylabel(f"residual{label}")
        for ax in (top, bottom):
            ax.grid(True, alpha=0.3)
            _mark_events(ax, fit)
    if not fit.columns:  # event times alone
        _mark_events(axes[0], fit)
        axes[0].set_ylabel("event times")
    else:
        axes[0].legend(loc="best", fontsize=8, markerscale=4)
    axes[-1].set_xlabel("t [s]")
    figure.suptitle(f"{fit.model}: fit of {', '.join(fit.parameters)}")
    return figure


def _mark_events(ax, fit) -> None:
    for measured, fitted in zip(fit.event_measured, fit.event_fitted):
        ax.axvline(measured, color="black", lw=0.7)
        ax.axvline(fitted, color="tab:red", lw=0.8, ls="--")
