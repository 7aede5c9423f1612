"""Mode shapes drawn: `plot_modes` (one panel per mode, the mechanism at rest in grey and
displaced along the mode in colour) and `animate_modes` (each mode oscillating in turn, a GIF
or MP4). The members are drawn as the animation draws them (runtime/animation.py; a spatial
model in 3-D, runtime/animation3d.py, from `view`)."""

from __future__ import annotations

import math

import numpy as np

from .animation import DPI, Geometry, _set_limits, _writer
from .animation3d import Drawing, SpatialGeometry, is_spatial, new_axes, set_limits
from .output import atomic_path
from .plot import plot_format

MAX_PANELS = 6
AMPLITUDE = 0.06  # the largest displacement drawn, as a share of the mechanism's size


def _geometry(module, params, q, outlines, view):
    """The drawn geometry of `module`: a SpatialGeometry for a spatial model, else Geometry
    (which takes no view: ValueError)."""
    p = np.asarray(params, dtype=float)
    if is_spatial(module):
        return SpatialGeometry(module, p, q, outlines)
    if view is not None:
        raise ValueError("a view is for a spatial model: a planar one is drawn in its plane")
    return Geometry(module, p, outlines)


def _points(geometry, q) -> np.ndarray:
    """Every point drawn at q, (k, 2) or (k, 3)."""
    if isinstance(geometry, SpatialGeometry):
        return geometry.place(q).points()
    return np.concatenate([outline for outline in geometry.outlines(q)] or [np.zeros((1, 2))])


def _amplitude(geometry, q: np.ndarray, shape: np.ndarray) -> float:
    """The multiple of `shape` drawn: its drawn points' largest displacement AMPLITUDE of the
    mechanism's size (a mode that mostly turns members moves their ends, not their centres)."""
    points = _points(geometry, q)
    finite = np.isfinite(points).all(axis=1)
    size = float(np.max(np.ptp(points[finite], axis=0))) if finite.any() else 1.0
    step = 1e-6 * max(size, 1e-3) / max(float(np.max(np.abs(shape))), 1e-300)
    moved = _points(geometry, q + step * shape)
    largest = float(np.max(np.linalg.norm((moved - points)[finite], axis=1), initial=0.0)) / step
    return AMPLITUDE * max(size, 1e-3) / largest if largest > 0 else 0.0


def _draw(ax, geometry: Geometry, q, colour: str, alpha: float, width: float):
    """The members at q as outlines and polylines (a spatial model's as solids); their
    artists."""
    from matplotlib.patches import Polygon

    if isinstance(geometry, SpatialGeometry):
        return Drawing(ax, geometry, colour, 0.1 * alpha, width).update(geometry.place(q))

    artists = []
    for outline, closed in zip(geometry.outlines(q), geometry.closed):
        if closed:
            artists.append(ax.add_patch(Polygon(outline, closed=True, fill=False, lw=width,
                                                edgecolor=colour, alpha=alpha)))
        else:
            artists += ax.plot(outline[:, 0], outline[:, 1], "-", lw=width + 1, color=colour,
                               alpha=alpha, solid_capstyle="round")
    return artists


def _axes(figure, geometry, view, position):
    if isinstance(geometry, SpatialGeometry):
        return new_axes(figure, geometry, view, position)
    return figure.add_subplot(*position)


def _frame(ax, geometry, states) -> None:
    """Limits holding the mechanism at each of `states`, at equal scales."""
    if isinstance(geometry, SpatialGeometry):
        set_limits(ax, np.concatenate([_points(geometry, x) for x in states]))
        return
    _set_limits(ax, [(geometry.outlines(x), geometry.shapes(x)[1]) for x in states])
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)


def plot_modes(found, module, path, params, outlines=None, count: int = MAX_PANELS,
               view=None) -> None:
    """The first `count` (at most MAX_PANELS) mode shapes of `found` (a Modes of `module` at
    parameters `params`) as one image, its format by the extension of `path` (PLOT_FORMATS).
    view: a spatial model's (elevation, azimuth) in degrees (runtime/animation3d.py)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    image_format = plot_format(path)
    geometry = _geometry(module, params, found.q, outlines, view)
    shown = max(1, min(count, MAX_PANELS, len(found.frequencies)))
    columns = min(3, shown)
    rows = math.ceil(shown / columns)
    figure = Figure(figsize=(4.2 * columns, 4.0 * rows + 0.4), layout="constrained", dpi=100)
    FigureCanvasAgg(figure)
    axes = [_axes(figure, geometry, view, (rows, columns, k + 1))
            for k in range(rows * columns)]
    for k, ax in enumerate(axes):
        if k >= min(shown, len(found.frequencies)):
            ax.axis("off")
            continue
        displaced = found.q + _amplitude(geometry, found.q, found.shapes[k]) * found.shapes[k]
        _draw(ax, geometry, found.q, "0.6", 0.8, 1.0)
        _draw(ax, geometry, displaced, "C0", 1.0, 1.6)
        _frame(ax, geometry, (found.q, displaced))
        ax.set_title(f"mode {k + 1}: {found.frequencies[k]:.4g} Hz", fontsize=10)
    if not len(found.frequencies):
        text = getattr(axes[0], "text2D", axes[0].text)  # a 3-D axes' text takes a z
        text(0.5, 0.5, "no mode: the constraints hold every coordinate", ha="center",
             transform=axes[0].transAxes)
    figure.suptitle(f"{found.model}: mode shapes at {found.at}")
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format=image_format, dpi=100)


def animate_modes(found, module, path, params, outlines=None, count: int = MAX_PANELS,
                  frames_per_mode: int = 24, fps: float = 12.0, view=None) -> int:
    """Each of the first `count` modes oscillating for one cycle, in turn, as a GIF or an MP4
    (`path`'s extension); returns the frame count. view: a spatial model's (elevation,
    azimuth) in degrees (runtime/animation3d.py)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    writer = _writer(path, fps)
    geometry = _geometry(module, params, found.q, outlines, view)
    shown = min(count, len(found.frequencies))
    scales = [_amplitude(geometry, found.q, found.shapes[k]) for k in range(shown)]
    figure = Figure(figsize=(6, 6), dpi=DPI)
    FigureCanvasAgg(figure)
    ax = _axes(figure, geometry, view, (1, 1, 1))
    extremes = [found.q + sign * scales[k] * found.shapes[k] for k in range(shown)
                for sign in (-1, 1)] or [found.q]
    _frame(ax, geometry, extremes)
    count_frames = 0
    with atomic_path(path) as tmp, writer.saving(figure, tmp, dpi=DPI):
        for k in range(shown):
            for frame in range(frames_per_mode):
                phase = math.sin(2 * math.pi * frame / frames_per_mode)
                for artist in list(ax.patches) + list(ax.lines) + list(ax.collections):
                    artist.remove()
                _draw(ax, geometry, found.q, "0.7", 0.8, 1.0)
                _draw(ax, geometry, found.q + phase * scales[k] * found.shapes[k], "C0", 1.0,
                      1.6)
                ax.set_title(f"{found.model}: mode {k + 1}, {found.frequencies[k]:.4g} Hz")
                writer.grab_frame()
                count_frames += 1
    return count_frames
