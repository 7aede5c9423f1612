"""`animate`: the mechanism moving, as a GIF (matplotlib animation, PillowWriter) or, when
ffmpeg is installed, an MP4 (FFMpegWriter): the file's extension chooses (ANIMATION_FORMATS).

Rigid members are drawn as outlines through their points: the convex polygon of a body's
points, a box along a bar (or any member whose points lie on a line), a square the size of its
radius of gyration around a body of one point. Members lying on one another (a stowed array's
panels) stay apart: each has its own colour, and the boxes of later members are thinner, so
stacked panels show as nested boxes. Beams are node polylines; hinges are dots: a black
circle while free, a red square once its latch has engaged, an orange diamond while a stop
or stick-slip lock holds it. A member's points come from `outlines` when given ({member:
points in its own frame}, what the model text declares: `depsim.api.Simulator.outlines`);
otherwise they are reconstructed as below. The geometry comes from the generated module:

* preferred (docs/deployment.md, section 7, asked of codegen): `POINTS` (names), `points(q, p)`
  -> (NPT, 2) world positions (m), `MEMBER_POINTS` (one tuple of point indices per member,
  drawn as a polyline) and `HINGE_POINTS` (the index of each hinge's point);
* otherwise it is reconstructed from what every module has: rigid members from their
  (x, y, phi) coordinates (a bar of parameter `<m>.length` as its two ends, another body as
  the polyline through its hinges), particles from their (x, y) (a small square), beams from
  their node coordinates, and each hinge's
  position from its rows "<h>.x", "<h>.y" of Phi_q (for a rigid member with centre r_m,
  d Phi_x / d phi_m = -s (y_P - y_m) and d Phi_y / d phi_m = s (x_P - x_m), s = +1 for
  member a, -1 for member b).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .output import OutputError, atomic_path, check_format, check_output

MAX_FRAMES = 200
DPI = 80
ANIMATION_FORMATS = ("gif", "mp4")  # mp4: only where matplotlib finds ffmpeg


def check_animation_path(path: str | os.PathLike) -> None:
    """OutputError unless an animation can be written to `path`: a writable place
    (`output.check_output`) with a known extension, and ffmpeg installed for an MP4."""
    check_output(path, ANIMATION_FORMATS)
    _writer(path, fps=1.0)


def _writer(path: str | os.PathLike, fps: float):
    """The matplotlib writer for the format of `path`; OutputError if it cannot be had."""
    check_format(path, ANIMATION_FORMATS)
    if Path(path).suffix.lower() == ".gif":
        from matplotlib.animation import PillowWriter

        return PillowWriter(fps=fps)
    from matplotlib.animation import FFMpegWriter, writers

    if not writers.is_available("ffmpeg"):
        raise OutputError(f"cannot write {path}: an MP4 needs ffmpeg, which is not installed "
                          "(or not on PATH); install it, or write a .gif")
    return FFMpegWriter(fps=fps)


def animate(result, module, path, fps: float = 20.0, max_frames: int = MAX_FRAMES,
            params=None, outlines=None, view=None) -> int:
    """Write an animation of `result` (a Result of `module`) to `path`, a GIF or an MP4 by its
    extension (OutputError for another, or for an MP4 without ffmpeg); returns the frame count.

    Frames are the output times, thinned evenly to at most `max_frames` (the last always
    included); `fps` frames per second. params: the module parameters (default: the run's).
    outlines: {member: (k, 2) points in its frame (m, from its centre of mass)}, else the
    points are reconstructed from the module (module docstring). A spatial model is drawn in
    3-D (runtime/animation3d.py: outlines of (k, 3) points) from `view`, (elevation, azimuth)
    in degrees (default the isometric view, animation3d.DEFAULT_VIEW); a planar model takes
    no view (ValueError).
    The file is written through `output.atomic_path`, so a failure leaves no partial file.
    """
    from .animation3d import SpatialScene, is_spatial

    writer = _writer(path, fps)
    p = np.asarray(result.parameters if params is None else params, dtype=float)
    frames = _frame_indices(len(result.times), max_frames)
    if is_spatial(module):
        scene = SpatialScene(result, module, p, frames, outlines, view)
        figure, draw = scene.figure, scene.draw
    elif view is not None:
        raise ValueError("a view is for a spatial model: a planar one is drawn in its plane")
    else:
        figure, draw = _planar_scene(result, Geometry(module, p, outlines), frames)
    with atomic_path(path) as tmp, writer.saving(figure, tmp, dpi=DPI):
        for k in range(len(frames)):  # one draw per frame (FuncAnimation draws twice)
            draw(k)
            writer.grab_frame()
    return len(frames)


def _planar_scene(result, geometry: Geometry, frames: list[int]):
    """The planar animation's figure and its draw(k), which shows frame k."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    shapes = [geometry.shapes(result.q[i]) for i in frames]
    drawn = [geometry.outlines(result.q[i]) for i in frames]
    states = [_hinge_states(result, i) for i in frames]

    figure = Figure(figsize=(6, 6), dpi=DPI)
    figure.subplots_adjust(left=0.13, right=0.97, bottom=0.09, top=0.94)
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    _set_limits(ax, [(outline, hinges) for outline, (_, hinges) in zip(drawn, shapes)])
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    from matplotlib.colors import to_rgba
    from matplotlib.patches import Polygon

    # a solid edge and a light fill each: members lying on one another show as nested boxes
    bodies = [ax.add_patch(Polygon(np.zeros((3, 2)), closed=True, lw=1.6, zorder=2 + i,
                                   edgecolor=f"C{i % 10}", facecolor=to_rgba(f"C{i % 10}", 0.3)))
              if closed else None for i, closed in enumerate(geometry.closed)]
    lines = [ax.plot([], [], "-", lw=2.5, color=f"C{i % 10}", solid_capstyle="round")[0]
             if not closed else None for i, closed in enumerate(geometry.closed)]
    styles = {"free": ("o", "black"), "latched": ("s", "tab:red"), "held": ("D", "tab:orange")}
    markers = {s: ax.plot([], [], ls="none", marker=m, color=c, ms=7, label=s)[0]
               for s, (m, c) in styles.items()}
    ax.legend(loc="upper right", fontsize=8)
    title = ax.set_title("")

    def draw(k):
        hinges = shapes[k][1]
        for body, line, outline in zip(bodies, lines, drawn[k]):
            if body is not None:
                body.set_xy(outline)
            else:
                line.set_data(outline[:, 0], outline[:, 1])
        for state, marker in markers.items():
            chosen = [j for j, s in enumerate(states[k]) if s == state]
            marker.set_data(hinges[chosen, 0], hinges[chosen, 1])
        title.set_text(f"{result.model}   t = {result.times[frames[k]]:.2f} s")
        return [*filter(None, bodies + lines), *markers.values(), title]

    return figure, draw


def _frame_indices(n: int, max_frames: int) -> list[int]:
    if n <= max_frames:
        return list(range(n))
    return sorted(set(np.linspace(0, n - 1, max_frames).round().astype(int).tolist()))


def _hinge_states(result, i: int) -> list[str]:
    """'latched' after the hinge's latch event, 'held' while another lock holds it, else
    'free'."""
    t = result.times[i]
    latched = {e.hinge for e in result.events if e.kind == "latch" and e.t < t}
    torque = result.hinge_torque
    out = []
    for k, h in enumerate(result.hinge_names):
        if h in latched:
            out.append("latched")
        elif torque is not None and np.isfinite(torque[i, k]):
            out.append("held")
        else:
            out.append("free")
    return out


def _set_limits(ax, shapes) -> None:
    every = np.concatenate([np.concatenate(members + [hinges]) for members, hinges in shapes])
    every = every[np.isfinite(every).all(axis=1)]
    lo, hi = every.min(axis=0), every.max(axis=0)
    centre, half = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 1e-3) * 1.1
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)


class Geometry:
    """Member polylines and outlines, hinge positions (m) of a module at any q (module
    docstring). outlines: {member: (k, 2) points in its frame}, else reconstructed."""

    def __init__(self, module, p, outlines=None):
        self.module = module
        self.p = p
        self.given = {name: np.asarray(points, dtype=float).reshape(-1, 2)
                      for name, points in (outlines or {}).items()}
        self.preferred = all(hasattr(module, n) for n in ("points", "MEMBER_POINTS",
                                                          "HINGE_POINTS"))
        if self.preferred:
            names = getattr(module, "MEMBERS", None)
            self.member_names = tuple(names or (f"member{i}" for i in
                                                range(len(module.MEMBER_POINTS))))
            self.closed = (False,) * len(self.member_names)
        else:
            self._reconstruct()
            closed = len(self.rigid) + len(self.particles)
            self.closed = (True,) * closed + (False,) * (len(self.member_names) - closed)
        self._local: list[np.ndarray] | None = None  # each rigid member's outline, own frame

    def outlines(self, q) -> list[np.ndarray]:
        """What is drawn of each member at q (m, world): a closed outline (k, 2) for a
        rigid member (`self.closed`), the polyline of `shapes` for a beam."""
        members, hinges = self.shapes(q)
        if self.preferred:
            return members
        if self._local is None:
            self._local = self._local_outlines(q, hinges)
        out = []
        for k, member in enumerate(self.rigid):
            ix, iy, iphi = (self.coords[f"{member}.{c}"] for c in ("x", "y", "phi"))
            c, s = np.cos(q[iphi]), np.sin(q[iphi])
            out.append(self._local[k] @ np.array([[c, s], [-s, c]]) + [q[ix], q[iy]])
        for member in self.particles:  # a square the size of the thickest bar
            centre = np.array([q[self.coords[f"{member}.x"]], q[self.coords[f"{member}.y"]]])
            out.append(member_outline(centre[None], self._particle_size))
        return out + members[len(self.rigid) + len(self.particles):]

    def _local_outlines(self, q, hinges) -> list[np.ndarray]:
        """Each rigid member's outline in its own frame, from its points: those given, else
        its bar ends, declared points and hinge points. Boxes get thinner member by member,
        so members lying on one another stay apart."""
        points = [self.given.get(m) if m in self.given else self._points(m, q, hinges)
                  for m in self.rigid]
        spans = [_span(p) for p in points if _span(p) > 0]
        size = float(np.median(spans)) if spans else 1.0
        lengths = spans + [_span(shape) for shape in self.shapes(q)[0] if _span(shape) > 0]
        self._particle_size = 0.04 * (float(np.median(lengths)) if lengths else 1.0)
        count = max(1, len(self.rigid) - 1)
        return [member_outline(p, size * (0.08 - 0.06 * k / count))
                for k, p in enumerate(points)]

    def _points(self, member: str, q, hinges) -> np.ndarray:
        """A member's points in its frame from the module: the ends of a bar with a
        `<m>.length` parameter, points with `<m>.<point>.local_x/_y` parameters, and the
        hinges on it (placed at q)."""
        params = {name: i for i, name in enumerate(self.module.PARAMETERS)}
        found = [np.zeros(2)]
        if f"{member}.length" in params:
            half = 0.5 * self.p[params[f"{member}.length"]]
            found += [np.array([-half, 0.0]), np.array([half, 0.0])]
        for name, i in params.items():
            head, _, tail = name.rpartition(".local_x")
            if not tail and head.startswith(f"{member}.") and f"{head}.local_y" in params:
                found.append(np.array([self.p[i], self.p[params[f"{head}.local_y"]]]))
        ix, iy, iphi = (self.coords[f"{member}.{c}"] for c in ("x", "y", "phi"))
        c, s = np.cos(q[iphi]), np.sin(q[iphi])
        for k in self._own[member]:
            if np.all(np.isfinite(hinges[k])):
                d = hinges[k] - [q[ix], q[iy]]
                found.append(np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]]))
        return np.array(found)

    def shapes(self, q) -> tuple[list[np.ndarray], np.ndarray]:
        """(one (k, 2) polyline per member, hinge positions (NH, 2))."""
        if self.preferred:
            pts = np.asarray(self.module.points(q, self.p), dtype=float)
            members = [pts[list(ids)] for ids in self.module.MEMBER_POINTS]
            return members, pts[list(self.module.HINGE_POINTS)]
        hinges = self._hinge_positions(q)
        return [draw(q, hinges) for draw in self._drawers], hinges

    # -- reconstruction from the coordinates and Phi_q ----------------------------------------
    def _reconstruct(self) -> None:
        module = self.module
        coords = {name: i for i, name in enumerate(module.COORDINATES)}
        params = {name: i for i, name in enumerate(module.PARAMETERS)}
        rigid, particles, beams = [], [], {}
        for name in module.COORDINATES:
            member, _, field = name.rpartition(".")
            if field == "phi" and f"{member}.x" in coords:
                rigid.append(member)
            elif field == "x" and ".n" in member and f"{member}.dx" in coords:
                beam, _, node = member.rpartition(".")
                beams.setdefault(beam, []).append((int(node[1:]), coords[name]))
            elif field == "x" and f"{member}.y" in coords and f"{member}.phi" not in coords:
                particles.append(member)
        self.coords = coords
        self.rigid = rigid
        self.particles = particles
        self._particle_size = 0.05
        self._own: dict[str, list[int]] = {}  # the hinges on each rigid member
        self.member_names = tuple(rigid) + tuple(particles) + tuple(beams)
        self._rows = self._hinge_rows()
        self._drawers = [self._rigid_drawer(m, params) for m in rigid]
        self._drawers += [self._particle_drawer(m) for m in particles]
        self._drawers += [self._beam_drawer(sorted(nodes)) for nodes in beams.values()]

    def _hinge_rows(self):
        names = tuple(self.module.CONSTRAINTS)
        rows = []
        for h in self.module.HINGES:
            rows.append((names.index(f"{h}.x"), names.index(f"{h}.y"))
                        if f"{h}.x" in names and f"{h}.y" in names else None)
        return rows

    def _hinge_positions(self, q) -> np.ndarray:
        J = np.zeros((self.module.NC, self.module.NQ))
        J[self.module.PHI_Q_ROWS, self.module.PHI_Q_COLS] = self.module.phi_q(q, 0.0, self.p)
        out = np.full((len(self.module.HINGES), 2), np.nan)
        for k, rows in enumerate(self._rows):
            if rows is not None:
                out[k] = self._joint_point(J, q, *rows)
        return out

    def _joint_point(self, J, q, rx, ry) -> np.ndarray:
        """The hinge point from its two rows (module docstring); NaN if no member found."""
        for col in np.flatnonzero(J[rx]):
            name = self.module.COORDINATES[col]
            member, _, field = name.rpartition(".")
            if field != "x":
                continue
            s = 1.0 if J[rx, col] > 0 else -1.0
            if member in self.rigid:
                phi = self.coords[f"{member}.phi"]
                x, y = q[col], q[self.coords[f"{member}.y"]]
                return np.array([x + s * J[ry, phi], y - s * J[rx, phi]])
            if f"{member}.dx" in self.coords or member in self.particles:  # a node, a particle
                return np.array([q[col], q[self.coords[f"{member}.y"]]])
        return np.full(2, np.nan)

    def _rigid_drawer(self, member: str, params):
        ix, iy, iphi = (self.coords[f"{member}.{c}"] for c in ("x", "y", "phi"))
        length = params.get(f"{member}.length")
        own = [k for k, h in enumerate(self.module.HINGES)
               if self._rows[k] is not None and self._touches(member, k)]
        self._own[member] = own

        def draw(q, hinges):
            centre = np.array([q[ix], q[iy]])
            if length is not None:
                half = 0.5 * self.p[length] * np.array([np.cos(q[iphi]), np.sin(q[iphi])])
                return np.stack((centre - half, centre + half))
            points = [hinges[k] for k in own if np.all(np.isfinite(hinges[k]))]
            if len(points) < 2:
                return np.stack([centre] + points) if points else np.stack((centre, centre))
            axis = np.array([np.cos(q[iphi]), np.sin(q[iphi])])
            return np.stack(sorted(points, key=lambda r: float((r - centre) @ axis)))

        return draw

    def _touches(self, member: str, k: int) -> bool:
        rows = {i for i, j in zip(self.module.PHI_Q_ROWS, self.module.PHI_Q_COLS)
                if self.module.COORDINATES[j] == f"{member}.x"}
        return self._rows[k][0] in rows

    def _particle_drawer(self, member: str):
        ix, iy = self.coords[f"{member}.x"], self.coords[f"{member}.y"]

        def draw(q, hinges):
            return np.array([[q[ix], q[iy]]])

        return draw

    def _beam_drawer(self, nodes):
        def draw(q, hinges):
            return np.array([[q[i], q[i + 1]] for _, i in nodes])

        return draw


def member_outline(points: np.ndarray, half: float) -> np.ndarray:
    """A closed outline (k, 2) around a member's points (its own frame, m): their convex
    polygon; a box of half-width `half` along them when they lie on a line (a bar); a square
    of half-side `half` around a single point."""
    points = np.unique(np.asarray(points, dtype=float).reshape(-1, 2), axis=0)
    span = _span(points)
    if len(points) >= 3 and span > 0:
        hull = _convex_hull(points)
        if len(hull) >= 3 and _area(hull) > 1e-6 * span * span:
            return hull
    if span == 0:
        centre = points[0] if len(points) else np.zeros(2)
        return centre + half * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float)
    distances = np.linalg.norm(points[:, None] - points[None], axis=2)
    i, j = np.unravel_index(np.argmax(distances), distances.shape)
    axis = (points[j] - points[i]) / span
    normal = half * np.array([-axis[1], axis[0]])
    return np.array([points[i] - normal, points[j] - normal, points[j] + normal,
                     points[i] + normal])


def _span(points: np.ndarray) -> float:
    """The largest distance between two of the points."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(points) < 2:
        return 0.0
    return float(np.linalg.norm(points[:, None] - points[None], axis=2).max())


def _convex_hull(points: np.ndarray) -> np.ndarray:
    """The convex hull's corners, counter-clockwise (Andrew's monotone chain)."""
    ordered = sorted(map(tuple, points))

    def chain(sequence):
        out: list = []
        for point in sequence:
            while len(out) >= 2 and _cross(out[-2], out[-1], point) <= 0:
                out.pop()
            out.append(point)
        return out

    lower, upper = chain(ordered), chain(reversed(ordered))
    return np.array(lower[:-1] + upper[:-1])


def _cross(o, a, b) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _area(polygon: np.ndarray) -> float:
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
