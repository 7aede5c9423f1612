"""Mode shapes drawn: `plot_modes` (one panel per mode, the mechanism at rest in grey and
displaced along the mode in colour) and `animate_modes` (each mode oscillating in turn, a GIF
or MP4). The members are drawn as the animation draws them (runtime/animation.py)."""

from __future__ import annotations

import math

import numpy as np

from .animation import DPI, Geometry, _set_limits, _writer
from .output import atomic_path
from .plot import plot_format

MAX_PANELS = 6
AMPLITUDE = 0.06  # the largest displacement drawn, as a share of the mechanism's size


def _amplitude(geometry: Geometry, q: np.ndarray, shape: np.ndarray) -> float:
    """The multiple of `shape` drawn: its drawn points' largest displacement AMPLITUDE of the
    mechanism's size (a mode that mostly turns members moves their ends, not their centres)."""
    points = np.concatenate([outline for outline in geometry.outlines(q)] or [np.zeros((1, 2))])
    finite = np.isfinite(points).all(axis=1)
    size = float(np.max(np.ptp(points[finite], axis=0))) if finite.any() else 1.0
    step = 1e-6 * max(size, 1e-3) / max(float(np.max(np.abs(shape))), 1e-300)
    moved = np.concatenate([outline for outline in geometry.outlines(q + step * shape)]
                           or [np.zeros((1, 2))])
    largest = float(np.max(np.linalg.norm((moved - points)[finite], axis=1), initial=0.0)) / step
    return AMPLITUDE * max(size, 1e-3) / largest if largest > 0 else 0.0


def _draw(ax, geometry: Geometry, q, colour: str, alpha: float, width: float):
    """The members at q as outlines and polylines; their artists."""
    from matplotlib.patches import Polygon

    artists = []
    for outline, closed in zip(geometry.outlines(q), geometry.closed):
        if closed:
            artists.append(ax.add_patch(Polygon(outline, closed=True, fill=False, lw=width,
                                                edgecolor=colour, alpha=alpha)))
        else:
            artists += ax.plot(outline[:, 0], outline[:, 1], "-", lw=width + 1, color=colour,
                               alpha=alpha, solid_capstyle="round")
    return artists


def plot_modes(found, module, path, params, outlines=None, count: int = MAX_PANELS) -> None:
    """The first `count` (at most MAX_PANELS) mode shapes of `found` (a Modes of `module` at
    parameters `params`) as one image, its format by the extension of `path` (PLOT_FORMATS)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    image_format = plot_format(path)
    geometry = Geometry(module, np.asarray(params, dtype=float), outlines)
    shown = max(1, min(count, MAX_PANELS, len(found.frequencies)))
    columns = min(3, shown)
    rows = math.ceil(shown / columns)
    figure = Figure(figsize=(4.2 * columns, 4.0 * rows + 0.4), layout="constrained", dpi=100)
    FigureCanvasAgg(figure)
    axes = figure.subplots(rows, columns, squeeze=False).ravel()
    for k, ax in enumerate(axes):
        if k >= min(shown, len(found.frequencies)):
            ax.axis("off")
            continue
        displaced = found.q + _amplitude(geometry, found.q, found.shapes[k]) * found.shapes[k]
        _draw(ax, geometry, found.q, "0.6", 0.8, 1.0)
        _draw(ax, geometry, displaced, "C0", 1.0, 1.6)
        _set_limits(ax, [(geometry.outlines(x), geometry.shapes(x)[1])
                         for x in (found.q, displaced)])
        ax.set_aspect("equal")
        ax.grid(True, alpha=0.3)
        ax.set_title(f"mode {k + 1}: {found.frequencies[k]:.4g} Hz", fontsize=10)
    if not len(found.frequencies):
        axes[0].text(0.5, 0.5, "no mode: the constraints hold every coordinate",
                     ha="center", transform=axes[0].transAxes)
    figure.suptitle(f"{found.model}: mode shapes at {found.at}")
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format=image_format, dpi=100)


def animate_modes(found, module, path, params, outlines=None, count: int = MAX_PANELS,
                  frames_per_mode: int = 24, fps: float = 12.0) -> int:
    """Each of the first `count` modes oscillating for one cycle, in turn, as a GIF or an MP4
    (`path`'s extension); returns the frame count."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    writer = _writer(path, fps)
    geometry = Geometry(module, np.asarray(params, dtype=float), outlines)
    shown = min(count, len(found.frequencies))
    scales = [_amplitude(geometry, found.q, found.shapes[k]) for k in range(shown)]
    figure = Figure(figsize=(6, 6), dpi=DPI)
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    extremes = [found.q + sign * scales[k] * found.shapes[k] for k in range(shown)
                for sign in (-1, 1)] or [found.q]
    _set_limits(ax, [(geometry.outlines(x), geometry.shapes(x)[1]) for x in extremes])
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    count_frames = 0
    with atomic_path(path) as tmp, writer.saving(figure, tmp, dpi=DPI):
        for k in range(shown):
            for frame in range(frames_per_mode):
                phase = math.sin(2 * math.pi * frame / frames_per_mode)
                for artist in list(ax.patches) + list(ax.lines):
                    artist.remove()
                _draw(ax, geometry, found.q, "0.7", 0.8, 1.0)
                _draw(ax, geometry, found.q + phase * scales[k] * found.shapes[k], "C0", 1.0,
                      1.6)
                ax.set_title(f"{found.model}: mode {k + 1}, {found.frequencies[k]:.4g} Hz")
                writer.grab_frame()
                count_frames += 1
    return count_frames
