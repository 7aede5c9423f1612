"""A spatial model drawn in 3-D (`animate` hands a spatial module to `SpatialScene`; the mode
figures draw with `SpatialGeometry` too): matplotlib's mplot3d on the Agg canvas.

Each rigid member is drawn as a solid through its points (`outlines`: {member: (k, 3) points
in its own frame}, `depsim.api.Simulator.outlines`; otherwise its centre, a bar's ends from
`<m>.length`, the points of the `<m>.<point>.local_x/_y/_z` parameters and its joints'
points), placed by its centre r and rotation matrix R (coordinates "<m>.x", ..., "<m>.R33",
body frame to world): their convex hull, filled lightly with its edges solid; a polygon when
they lie in a plane; a thick line when they lie on a line (a bar); a cube around a single
point. Particles are dots of their own colour, the ground's declared points grey triangles
(the outlines' "ground" entry, else the `ground.<point>.local_*` parameters). Joints are markers
at their points: a hinge a black circle while free, a red square once latched, an orange
diamond while a stop or stick-slip lock holds it (as in the planar animation); a ball joint
or a weld a hollow circle. A joint's point comes from its rows "<j>.x" of Phi_q, which are
linear in q: for a member m of it, d Phi_x / d x_m = s and d Phi_x / d R1k_m = s rho_k,
rho the point in m's frame, s = +1 for member a and -1 for member b (a particle: rho = 0).

The view: elevation and azimuth (deg) about the vertical axis, which is the axis of the
largest component of gravity (z without gravity); by default the isometric view
(DEFAULT_VIEW). The axes have equal scales and hold the whole run, so nothing jumps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .animation import DPI, _convex_hull, _hinge_states

DEFAULT_VIEW = (math.degrees(math.atan(1 / math.sqrt(2))), -45.0)  # isometric: 35.26, -45 deg
ROTATION = tuple(f"R{i}{j}" for i in "123" for j in "123")
CUBE = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)


def is_spatial(module) -> bool:
    """Whether `module` is a spatial model's (its system state has a z)."""
    return "com_z" in tuple(getattr(module, "SYSTEM_STATE", ()))


def check_view(view) -> tuple[float, float]:
    """(elevation, azimuth) in degrees as floats; ValueError unless two finite numbers."""
    try:
        elevation, azimuth = (float(v) for v in view)
    except (TypeError, ValueError):
        raise ValueError(f"view {view!r}: expected (elevation, azimuth) in degrees") from None
    if not (math.isfinite(elevation) and math.isfinite(azimuth)):
        raise ValueError(f"view {view!r}: the angles must be finite numbers")
    return elevation, azimuth


@dataclass(frozen=True)
class Solid:
    """A rigid member's drawing in its own frame: `vertices` (k, 3) m, `faces` (index
    tuples, filled polygons) and `edges` (index pairs, lines)."""

    vertices: np.ndarray
    faces: tuple[tuple[int, ...], ...]
    edges: tuple[tuple[int, int], ...]

    @property
    def is_line(self) -> bool:
        return not self.faces


def solid(points, half: float) -> Solid:
    """The drawing through a member's points (its frame, m): their convex hull (triangles,
    edges where the faces meet at an angle); the convex polygon when they lie in a plane;
    the segment between the two farthest when on a line; a cube of half-side `half` around
    a single point."""
    points = np.unique(np.asarray(points, dtype=float).reshape(-1, 3), axis=0)
    span = _span3(points)
    if span == 0:
        centre = points[0] if len(points) else np.zeros(3)
        return solid(centre + half * CUBE, half)
    centre = points.mean(axis=0)
    _, sizes, directions = np.linalg.svd(points - centre)
    rank = int(np.sum(sizes > 1e-6 * span))  # thinner than a micron a metre: flat
    if rank == 1:
        distances = np.linalg.norm(points[:, None] - points[None], axis=2)
        i, j = np.unravel_index(np.argmax(distances), distances.shape)
        return Solid(points[[i, j]], (), ((0, 1),))
    if rank == 2:
        plane = directions[:2]
        corners = centre + _convex_hull((points - centre) @ plane.T) @ plane
        ring = tuple(range(len(corners)))
        return Solid(corners, (ring,), tuple(zip(ring, ring[1:] + ring[:1])))
    return _hull(points)


def _hull(points: np.ndarray) -> Solid:
    """The convex hull of points spanning three dimensions: its triangles, and the edges
    between triangles that are not in one plane."""
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points)
    edges = set()
    for k, (simplex, neighbours) in enumerate(zip(hull.simplices, hull.neighbors)):
        for opposite, other in enumerate(neighbours):
            if other > k and hull.equations[k, :3] @ hull.equations[other, :3] < 1 - 1e-9:
                edge = [v for m, v in enumerate(simplex) if m != opposite]
                edges.add((int(min(edge)), int(max(edge))))
    faces = tuple(tuple(int(v) for v in simplex) for simplex in hull.simplices)
    return Solid(points, faces, tuple(sorted(edges)))


def _span3(points: np.ndarray) -> float:
    """The largest distance between two of the points (k, 3)."""
    if len(points) < 2:
        return 0.0
    return float(np.linalg.norm(points[:, None] - points[None], axis=2).max())


@dataclass(frozen=True)
class Placement:
    """What is drawn at one state (m, world): each body's solid's vertices, the particles
    (NP, 3) and the joints' points (NJ, 3)."""

    bodies: list[np.ndarray]
    particles: np.ndarray
    joints: np.ndarray

    def points(self) -> np.ndarray:
        """Every drawn point, (k, 3)."""
        return np.concatenate(self.bodies + [self.particles, self.joints, np.zeros((0, 3))])


class SpatialGeometry:
    """The solids, particles, joint points and ground points of a spatial module (module
    docstring). p: the parameters; q: any state (a joint's rows are linear in q);
    outlines: {member: (k, 3) points in its frame, "ground": world points}."""

    def __init__(self, module, p, q, outlines=None):
        self.module = module
        self.p = np.asarray(p, dtype=float)
        coords = {name: i for i, name in enumerate(module.COORDINATES)}
        self.coords = coords
        self.bodies = tuple(n[:-4] for n in module.COORDINATES if n.endswith(".R11"))
        self.particles = tuple(n[:-2] for n in module.COORDINATES
                               if n.endswith(".z") and f"{n[:-2]}.R11" not in coords)
        self._centres = [[coords[f"{m}.{c}"] for c in "xyz"] for m in self.bodies]
        self._rotations = [[coords[f"{m}.{c}"] for c in ROTATION] for m in self.bodies]
        self._particles = [[coords[f"{m}.{c}"] for c in "xyz"] for m in self.particles]
        self.joints, self._attachments = self._joint_points(np.asarray(q, dtype=float))
        hinges = tuple(module.HINGES)
        self.hinge_of = tuple(hinges.index(j) if j in hinges else -1 for j in self.joints)
        given = dict(outlines or {})
        self.ground = (np.asarray(given.pop("ground"), dtype=float).reshape(-1, 3)
                       if "ground" in given else self._ground_points())
        self.solids = self._solids(given)

    def place(self, q) -> Placement:
        """Everything drawn at q (m, world)."""
        q = np.asarray(q, dtype=float)
        frames = [(q[c], q[r].reshape(3, 3)) for c, r in zip(self._centres, self._rotations)]
        bodies = [r + s.vertices @ R.T for (r, R), s in zip(frames, self.solids)]
        particles = np.array([q[c] for c in self._particles]).reshape(-1, 3)
        joints = np.full((len(self.joints), 3), np.nan)
        for k, (kind, m, rho) in enumerate(self._attachments):
            if kind == "body":
                joints[k] = frames[m][0] + frames[m][1] @ rho
            elif kind == "particle":
                joints[k] = particles[m]
        return Placement(bodies, particles, joints)

    def vertical_axis(self) -> str:
        """The axis drawn upright: that of gravity's largest component, z without gravity."""
        params = tuple(self.module.PARAMETERS)
        g = [self.p[params.index(f"gravity.{c}")] if f"gravity.{c}" in params else 0.0
             for c in "xyz"]
        return "xyz"[int(np.argmax(np.abs(g)))] if np.any(g) else "z"

    def _joint_points(self, q):
        """The joints with a point (rows "<j>.x", "<j>.y", "<j>.z") and, for each, where it
        sits: ("body", index, rho in its frame), ("particle", index, None) or ("", -1,
        None) when neither member moves."""
        names = tuple(self.module.CONSTRAINTS)
        J = np.zeros((self.module.NC, self.module.NQ))
        J[self.module.PHI_Q_ROWS, self.module.PHI_Q_COLS] = self.module.phi_q(q, 0.0, self.p)
        joints, attachments = [], []
        for row, (name, joint) in enumerate(zip(names, self.module.CONSTRAINT_JOINTS)):
            if name != f"{joint}.x" or not {f"{joint}.y", f"{joint}.z"} <= set(names):
                continue
            joints.append(joint)
            attachments.append(self._attachment(J[row]))
        return tuple(joints), attachments

    def _attachment(self, row):
        for m, centre in enumerate(self._centres):
            s = row[centre[0]]
            if s != 0:
                return "body", m, row[self._rotations[m][:3]] / s
        for m, columns in enumerate(self._particles):
            if row[columns[0]] != 0:
                return "particle", m, None
        return "", -1, None

    def _ground_points(self) -> np.ndarray:
        """The points of the `ground.<point>.local_x/_y/_z` parameters."""
        return np.array(self._declared("ground")).reshape(-1, 3)

    def _declared(self, member: str) -> list[np.ndarray]:
        params = {name: i for i, name in enumerate(self.module.PARAMETERS)}
        out = []
        for name in params:
            head, _, tail = name.rpartition(".local_x")
            if not tail and head.startswith(f"{member}.") and \
                    {f"{head}.local_y", f"{head}.local_z"} <= set(params):
                out.append(self.p[[params[f"{head}.local_{c}"] for c in "xyz"]])
        return out

    def _solids(self, given) -> list[Solid]:
        """Each body's solid through its points: those given, else its centre, a bar's
        ends, its declared points and its joints' points."""
        params = {name: i for i, name in enumerate(self.module.PARAMETERS)}
        points = []
        for m, member in enumerate(self.bodies):
            if member in given:
                points.append(np.asarray(given[member], dtype=float).reshape(-1, 3))
                continue
            found = [np.zeros(3)] + self._declared(member)
            if f"{member}.length" in params:
                half = 0.5 * self.p[params[f"{member}.length"]]
                found += [np.array([-half, 0.0, 0.0]), np.array([half, 0.0, 0.0])]
            found += [rho for kind, k, rho in self._attachments if kind == "body" and k == m]
            points.append(np.array(found))
        spans = [_span3(np.unique(p, axis=0)) for p in points]
        size = float(np.median([s for s in spans if s > 0] or [0.5]))
        return [solid(p, 0.08 * size) for p in points]


class Drawing:
    """The artists of the mechanism on a 3-D axes, moved by `update(placement)`: each body's
    faces (filled, `alpha`) and edges, each particle's dot; in its own colour each, or all
    in `colour`. A bar's line is thicker, and thinner member by member, so bars lying on
    one another stay apart."""

    def __init__(self, ax, geometry: SpatialGeometry, colour: str | None = None,
                 alpha: float = 0.25, width: float = 1.6):
        from matplotlib.colors import to_rgba
        from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

        self.geometry = geometry
        count = max(1, len(geometry.bodies) - 1)
        self.faces, self.edges, self.dots = [], [], []
        for k, body in enumerate(geometry.solids):
            c = colour or f"C{k % 10}"
            self.faces.append(ax.add_collection3d(Poly3DCollection(
                [], facecolor=to_rgba(c, alpha), edgecolor="none", zorder=1), autolim=False)
                if not body.is_line else None)
            bar = 2.5 * width - 1.5 * width * k / count
            self.edges.append(ax.add_collection3d(Line3DCollection(
                [], colors=[c], linewidths=bar if body.is_line else width, zorder=2,
                capstyle="round"), autolim=False))
        for k in range(len(geometry.particles)):
            c = colour or f"C{(len(geometry.bodies) + k) % 10}"
            self.dots.append(ax.plot([], [], [], ls="none", marker="o", ms=7, color=c,
                                     zorder=3)[0])

    def update(self, placement: Placement) -> list:
        """Move the artists to `placement`; the artists."""
        for face, edge, body, vertices in zip(self.faces, self.edges, self.geometry.solids,
                                              placement.bodies):
            if face is not None:
                face.set_verts([vertices[list(f)] for f in body.faces])
            edge.set_segments([vertices[list(e)] for e in body.edges])
        for dot, point in zip(self.dots, placement.particles):
            dot.set_data_3d([point[0]], [point[1]], [point[2]])
        return [*filter(None, self.faces), *self.edges, *self.dots]


def set_limits(ax, points: np.ndarray) -> None:
    """Axes holding every point (k, 3), at equal scales (the box's sides in proportion to
    the ranges), no side thinner than a sixth of the longest."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    points = points[np.isfinite(points).all(axis=1)]
    if not len(points):
        points = np.zeros((1, 3))
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    half = 1.08 * np.maximum(half, max(float(half.max()), 1e-3) / 6)
    for axis, c, h in zip("xyz", centre, half):
        getattr(ax, f"set_{axis}lim")(c - h, c + h)
        getattr(ax, f"set_{axis}label")(f"{axis} [m]")
        # ticks as far apart on every side
        ax.locator_params(axis=axis, nbins=max(2, round(5 * h / half.max())))
    ax.set_box_aspect(2 * half, zoom=0.85)
    ax.tick_params(labelsize=7)


def new_axes(figure, geometry: SpatialGeometry, view=None, position=(1, 1, 1)):
    """A 3-D axes on `figure` at `position` (rows, columns, index) seen from `view`
    (elevation, azimuth in deg; DEFAULT_VIEW), upright along `geometry.vertical_axis()`;
    artists drawn in the order added."""
    elevation, azimuth = check_view(DEFAULT_VIEW if view is None else view)
    ax = figure.add_subplot(*position, projection="3d", computed_zorder=False)
    ax.view_init(elev=elevation, azim=azimuth, vertical_axis=geometry.vertical_axis())
    return ax


HINGE_STYLES = {"free": ("o", "black"), "latched": ("s", "tab:red"),
                "held": ("D", "tab:orange")}


class SpatialScene:
    """The 3-D animation's figure for `result` of a spatial `module`: `figure`, `ax`, and
    `draw(k)`, which shows frame k (the output time `result.times[frames[k]]`) and returns
    its artists. p: the parameters; outlines and view as `SpatialGeometry` and `new_axes`."""

    def __init__(self, result, module, p, frames, outlines=None, view=None):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.result, self.frames = result, list(frames)
        self.geometry = geometry = SpatialGeometry(module, p, result.q[self.frames[0]],
                                                   outlines)
        self.placements = [geometry.place(result.q[i]) for i in self.frames]
        self.states = [_hinge_states(result, i) for i in self.frames]
        self.figure = Figure(figsize=(6, 6), dpi=DPI)
        self.figure.subplots_adjust(left=0.02, right=0.98, bottom=0.02, top=0.95)
        FigureCanvasAgg(self.figure)
        self.ax = ax = new_axes(self.figure, geometry, view)
        set_limits(ax, np.concatenate([placement.points() for placement in self.placements]
                                      + [geometry.ground]))
        self.drawing = Drawing(ax, geometry)
        if len(geometry.ground):
            x, y, z = geometry.ground.T
            ax.plot(x, y, z, ls="none", marker="^", ms=7, color="0.4", label="ground",
                    zorder=3)
        styles = dict(HINGE_STYLES) if module.HINGES else {}
        if any(h < 0 for h in geometry.hinge_of):
            styles["ball, weld"] = ("o", "none")
        self.markers = {s: ax.plot([], [], [], ls="none", marker=m, ms=7, label=s, zorder=4,
                                   color="black" if c == "none" else c,
                                   markerfacecolor=c)[0] for s, (m, c) in styles.items()}
        if self.markers or len(geometry.ground):
            ax.legend(loc="upper right", fontsize=8)
        self.title = ax.set_title("")

    def joint_states(self, k: int) -> list[str]:
        """Each joint's marker at frame k: its hinge's state, else "ball, weld"."""
        return [self.states[k][h] if h >= 0 else "ball, weld" for h in self.geometry.hinge_of]

    def draw(self, k: int) -> list:
        """Show frame k: the members, the joints' markers by state, the time."""
        placement = self.placements[k]
        artists = self.drawing.update(placement)
        states = self.joint_states(k)
        for state, marker in self.markers.items():
            chosen = placement.joints[[j for j, s in enumerate(states) if s == state]]
            marker.set_data_3d(chosen[:, 0], chosen[:, 1], chosen[:, 2])
        t = self.result.times[self.frames[k]]
        self.title.set_text(f"{self.result.model}   t = {t:.2f} s")
        return [*artists, *self.markers.values(), self.title]
