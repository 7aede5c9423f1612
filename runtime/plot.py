"""`plot_outputs`: every output of a Result against time, one panel each, as an image in the
format its file extension names (PNG, PDF, SVG, ...: PLOT_FORMATS)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .output import atomic_path, check_format

# What matplotlib's Agg canvas writes without anything else installed (not pgf: it needs LaTeX)
PLOT_FORMATS = ("png", "pdf", "svg", "svgz", "eps", "ps", "jpg", "jpeg", "tif", "tiff", "webp")


def plot_format(path: str | os.PathLike) -> str:
    """The format `path` asks for by its extension; OutputError when not one of PLOT_FORMATS."""
    check_format(path, PLOT_FORMATS)
    return Path(path).suffix.lower().lstrip(".")


def plot_outputs(result, path) -> None:
    """Write `outputs_figure(result)` as an image, in the format of the extension of `path`
    (PLOT_FORMATS; OutputError for another). Renders with matplotlib's Agg canvas (no
    display, no pyplot state); the file is written atomically."""
    image_format = plot_format(path)
    figure = outputs_figure(result)
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format=image_format, dpi=DPI)


DPI = 100


def outputs_figure(result):
    """One panel per output vs time (s), titled with the model name. Outputs in "rad" are
    drawn in degrees, "rad/s" in deg/s; latch events (kind "latch") are marked by red vertical
    lines labelled with the hinge (labels of latches close in time are stacked, never
    overlapping), other events by grey ones."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    count = max(1, len(result.output_names))
    figure = Figure(figsize=(8, 2.2 * count + 0.6), layout="constrained", dpi=DPI)
    FigureCanvasAgg(figure)  # no pyplot, no global backend switch
    axes = figure.subplots(count, 1, sharex=True, squeeze=False)[:, 0]
    for ax, name, unit, column in zip(axes, result.output_names, result.output_units,
                                      result.outputs.T):
        values, unit = display_values(column, unit)
        ax.plot(result.times, values, lw=1.2)
        ax.set_ylabel(f"{name} [{unit}]" if unit else name)
        ax.grid(True, alpha=0.3)
        for event in result.events:
            latch = event.kind == "latch"
            ax.axvline(event.t, color="tab:red" if latch else "0.6", lw=0.9 if latch else 0.6,
                       ls="--")
    axes[-1].set_xlabel("t [s]")
    figure.suptitle(result.model)
    labels = [axes[0].annotate(event.hinge, (event.t, 1.0),
                               xycoords=("data", "axes fraction"), xytext=(2, -10),
                               textcoords="offset points", color="tab:red", fontsize=8)
              for event in result.events if event.kind == "latch"]
    if labels:
        _stack_labels(figure, labels)
    return figure


def _stack_labels(figure, labels) -> None:
    """Move each label down to the first row where it clears the label before it: drawn
    once to know the layout and the labels' widths."""
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    ends: list[float] = []  # the right edge (pixels) of the last label of each row
    for label in sorted(labels, key=lambda text: text.xy[0]):
        box = label.get_window_extent(renderer)
        row = next((k for k, end in enumerate(ends) if box.x0 > end + 2), len(ends))
        if row == len(ends):
            ends.append(-np.inf)
        label.xyann = (2, -10 - 10 * row)
        ends[row] = box.x1


def display_values(values: np.ndarray, unit: str) -> tuple[np.ndarray, str]:
    """Values and their unit as shown: angles (rad, rad/s) in degrees, the rest as is (SI)."""
    if unit == "rad":
        return np.degrees(values), "deg"
    if unit == "rad/s":
        return np.degrees(values), "deg/s"
    return values, unit
