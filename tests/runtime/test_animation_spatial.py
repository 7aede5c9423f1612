"""A spatial model's animation and mode figures in 3-D (runtime/animation3d.py): each member's
solid placed by its centre and rotation matrix, joints at their points, checked against the
model's own outputs of those points and in the rendered image, from the view asked for, at
equal scales holding the whole run (tests/runtime/models/arm3d.dep: a bar, a body of four
points, a body of two points drawn as its inertia box, a particle, a ground point)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import depsim
from depsim import cli
from depsim.runtime.animation import DPI, animate
from depsim.runtime.animation3d import DEFAULT_VIEW, SpatialGeometry, SpatialScene, solid

ROOT = Path(__file__).resolve().parents[2]
ARM = ROOT / "tests" / "runtime" / "models" / "arm3d.dep"
SIZE = (6 * DPI, 6 * DPI)  # the animation's frame, pixels


@pytest.fixture(scope="module")
def arm():
    sim = depsim.load(ARM).compile("numpy")  # from the cache after the first time
    return sim, sim.run()


def at(result, name: str, k: int) -> np.ndarray:
    """The model's output `name`_x, _y, _z at output time k."""
    return np.array([result.output(f"{name}_{c}")[k] for c in "xyz"])


def project(scene, points) -> np.ndarray:
    """Where world points (k, 3) land in the saved frame: (column, row from the top)."""
    from mpl_toolkits.mplot3d import proj3d

    x, y, _ = proj3d.proj_transform(*np.asarray(points, dtype=float).T, scene.ax.get_proj())
    display = scene.ax.transData.transform(np.column_stack([x, y]))
    return np.column_stack([display[:, 0], scene.figure.bbox.height - display[:, 1]])


def colour_near(pixels, place, rgb, radius: int = 1, tolerance: int = 40) -> bool:
    column, row = (int(round(v)) for v in place)
    patch = pixels[row - radius:row + radius + 1, column - radius:column + radius + 1]
    return bool(np.any(np.all(np.abs(patch - np.array(rgb)) < tolerance, axis=-1)))


# -- solids through a member's points ----------------------------------------------------------

def test_a_solid_is_the_hull_polygon_segment_or_cube_of_the_points():
    box = np.array([(x, 2 * y, 3 * z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    hull = solid(np.vstack([box, np.zeros(3)]), 0.1)  # the centre lies inside
    assert len(hull.faces) == 12 and len(hull.edges) == 12  # two triangles a side, box edges
    lengths = sorted(np.linalg.norm(hull.vertices[i] - hull.vertices[j]) for i, j in hull.edges)
    assert np.allclose(lengths, [2] * 4 + [4] * 4 + [6] * 4)
    flat = solid([(0, 0, 1), (1, 0, 1), (0, 1, 1), (0.2, 0.2, 1)], 0.1)  # one inside
    assert len(flat.faces) == 1 and len(flat.vertices) == 3 and len(flat.edges) == 3
    bar = solid([(-1, 0, 0), (0, 0, 0), (1, 0, 0)], 0.1)
    assert bar.is_line and sorted(bar.vertices[:, 0]) == [-1, 1]
    cube = solid([(1, 2, 3)], 0.5)
    assert len(cube.edges) == 12
    assert np.allclose(cube.vertices.min(axis=0), [0.5, 1.5, 2.5])
    assert np.allclose(cube.vertices.max(axis=0), [1.5, 2.5, 3.5])


def test_a_spatial_models_outlines_hold_its_points_and_inertia_boxes(arm):
    """Points in 3-D; the two-point body gets the corners of the uniform box of its mass and
    principal moments along its principal axes (rz(30 deg)); the ground's declared point."""
    sim, _ = arm
    outlines = sim.outlines()
    assert np.allclose(outlines["upper"], [(0, 0, 0), (-0.3, 0, 0), (0.3, 0, 0)])
    assert np.allclose(outlines["hand"], [(0, 0, 0), (-0.2, 0, 0), (0.1, 0.15, 0),
                                          (0.1, -0.1, 0.05)])
    assert np.allclose(outlines["ground"], [(0, 0, 0.5)])
    weight = outlines["weight"]
    assert np.allclose(weight[:2], [(0, 0, 0), (0, 0, 0.05)]) and len(weight) == 10
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    axes = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    half = np.abs(weight[2:] @ axes).max(axis=0)  # the box's half-sides along its axes
    assert np.allclose(np.abs(weight[2:] @ axes), half)  # every corner at (+-a, +-b, +-c)
    m, moments = 0.3, (0.001, 0.0012, 0.0015)
    for i, moment in enumerate(moments):  # a uniform box: I_x = m (b^2 + c^2) / 3, ...
        others = [half[j] ** 2 for j in range(3) if j != i]
        assert m * sum(others) / 3 == pytest.approx(moment, rel=1e-12)


# -- the drawing against the model -------------------------------------------------------------

def test_each_drawn_point_is_where_the_model_has_it(arm):
    """At every fifth output time: the bar's ends, the hand's finger, the weight's hook, the
    bead and the joints where the model's outputs put them."""
    sim, result = arm
    geometry = SpatialGeometry(sim.module, result.parameters, result.q[0], sim.outlines())
    assert sorted(geometry.joints) == ["elbow", "glue", "shoulder", "socket"]
    joint = {name: k for k, name in enumerate(geometry.joints)}
    for k in range(0, len(result.times), 5):
        placed = geometry.place(result.q[k])
        upper, hand, weight = placed.bodies
        elbow, finger, bead = (at(result, n, k) for n in ("upper_b", "finger", "bead"))
        assert np.min(np.linalg.norm(upper - elbow, axis=1)) < 1e-12
        assert np.min(np.linalg.norm(upper - (0, 0, 0.5), axis=1)) < 1e-9  # (the residual)
        assert np.min(np.linalg.norm(hand - finger, axis=1)) < 1e-12
        assert np.allclose(placed.particles, [bead], rtol=0, atol=1e-12)
        assert np.allclose(placed.joints[joint["shoulder"]], (0, 0, 0.5), rtol=0, atol=1e-9)
        assert np.allclose(placed.joints[joint["elbow"]], elbow, rtol=0, atol=1e-12)
        assert np.allclose(placed.joints[joint["socket"]], finger, rtol=0, atol=1e-12)
        # points of two members, joined: to the run's constraint residual
        assert np.allclose(placed.joints[joint["glue"]], bead, rtol=0, atol=1e-9)
        assert np.min(np.linalg.norm(weight - finger, axis=1)) < 1e-9  # its hook


def test_a_frame_shows_the_mechanism_where_the_model_has_it(arm, tmp_path):
    """The last output time rendered from elevation 20, azimuth 30: a PNG of the frame's
    size, the elbow hinge's black dot, the bead's red dot and the bar's blue line where the
    model's outputs project."""
    sim, result = arm
    last = len(result.times) - 1
    scene = SpatialScene(result, sim.module, result.parameters, [0, last], sim.outlines(),
                         view=(20, 30))
    assert (scene.ax.elev, scene.ax.azim) == (20, 30)
    scene.draw(1)
    path = tmp_path / "frame.png"
    scene.figure.savefig(path, dpi=DPI)
    image = Image.open(path)
    assert image.format == "PNG" and image.size == SIZE
    pixels = np.asarray(image.convert("RGB")).astype(int)
    elbow, bead = at(result, "upper_b", last), at(result, "bead", last)
    shoulder = np.array([0.0, 0.0, 0.5])
    places = project(scene, [elbow, bead, (elbow + shoulder) / 2])
    assert np.all((places > 0) & (places < SIZE[0]))
    assert colour_near(pixels, places[0], (0, 0, 0))  # a free hinge
    assert colour_near(pixels, places[1], (214, 39, 40))  # C3, the bead (in the weld's ring)
    assert colour_near(pixels, places[2], (31, 119, 180))  # C0, the bar
    free = np.column_stack(scene.markers["free"].get_data_3d())
    assert np.allclose(sorted(map(tuple, free)), sorted([tuple(shoulder), tuple(elbow)]))


def test_the_axes_hold_the_whole_run_at_equal_scales(arm):
    sim, result = arm
    frames = list(range(0, len(result.times), 3))
    scene = SpatialScene(result, sim.module, result.parameters, frames, sim.outlines())
    assert (scene.ax.elev, scene.ax.azim) == pytest.approx(DEFAULT_VIEW)
    limits = np.array([scene.ax.get_xlim(), scene.ax.get_ylim(), scene.ax.get_zlim()])
    for k in range(len(frames)):
        scene.draw(k)
        assert np.allclose([scene.ax.get_xlim(), scene.ax.get_ylim(), scene.ax.get_zlim()],
                           limits)
        points = scene.placements[k].points()
        assert np.all((points >= limits[:, 0]) & (points <= limits[:, 1]))
    scale = np.asarray(scene.ax.get_box_aspect()) / np.ptp(limits, axis=1)
    assert np.allclose(scale, scale[0], rtol=1e-9)


def test_upright_is_against_gravity(arm):
    sim, result = arm
    p = np.array(result.parameters)
    names = list(sim.module.PARAMETERS)
    geometry = SpatialGeometry(sim.module, p, result.q[0], sim.outlines())
    assert geometry.vertical_axis() == "z"
    p[[names.index(f"gravity.{c}") for c in "xyz"]] = (0.5, -9.81, 0.0)
    assert SpatialGeometry(sim.module, p, result.q[0]).vertical_axis() == "y"
    p[[names.index(f"gravity.{c}") for c in "xyz"]] = 0.0
    assert SpatialGeometry(sim.module, p, result.q[0]).vertical_axis() == "z"


def test_the_animation_is_a_gif_of_the_moving_mechanism(arm, tmp_path):
    sim, result = arm
    frames = animate(result, sim.module, tmp_path / "arm.gif", max_frames=3,
                     outlines=sim.outlines(result.parameters), view=(10, -120))
    image = Image.open(tmp_path / "arm.gif")
    assert frames == image.n_frames == 3 and image.size == SIZE
    pictures = []
    for k in range(3):
        image.seek(k)
        pictures.append(np.asarray(image.convert("RGB")).astype(int))
    assert np.abs(pictures[0] - pictures[2]).sum() > 0  # it moves


def test_without_outlines_the_members_are_reconstructed_from_the_module(arm):
    """The bar from its length, the hand from its point parameters, the weight from its
    point and its joint's (a line: two points), the ground's point from its parameters."""
    sim, result = arm
    geometry = SpatialGeometry(sim.module, result.parameters, result.q[0])
    upper, hand, weight = geometry.solids
    assert upper.is_line and np.allclose(sorted(upper.vertices[:, 0]), [-0.3, 0.3])
    assert len(hand.faces) == 4  # a tetrahedron of wrist, thumb, finger and centre
    assert weight.is_line
    assert np.allclose(geometry.ground, [(0, 0, 0.5)])


# -- the mode figures --------------------------------------------------------------------------

def test_the_mode_figures_of_a_spatial_model_are_drawn_in_3d(arm, tmp_path):
    from depsim.runtime.mode_figures import animate_modes, plot_modes

    sim, _ = arm
    found = sim.modes(at="t=0", count=2)
    p = sim.defaults
    plot_modes(found, sim.module, tmp_path / "modes.png", p, outlines=sim.outlines(p),
               view=(25, 40))
    assert Image.open(tmp_path / "modes.png").format == "PNG"
    frames = animate_modes(found, sim.module, tmp_path / "modes.gif", p,
                           outlines=sim.outlines(p), count=1, frames_per_mode=4)
    assert frames == Image.open(tmp_path / "modes.gif").n_frames == 4


# -- the command line --------------------------------------------------------------------------

def test_run_animates_a_spatial_model_from_the_view_asked(arm, tmp_path):
    gif, png = tmp_path / "arm.gif", tmp_path / "arm.png"
    assert cli.main(["run", str(ARM), "--t-end", "0.1", "--dt-out", "0.05", "--animate",
                     str(gif), "--view", "15,60", "--plot", str(png)]) == 0
    assert Image.open(gif).size == SIZE and Image.open(png).format == "PNG"


def test_modes_draws_a_spatial_model_from_the_view_asked(arm, tmp_path, capsys):
    png = tmp_path / "modes.png"
    assert cli.main(["modes", str(ARM), "--target", "numpy", "--count", "2", "--plot", str(png),
                     "--view", "15,60"]) == 0
    assert Image.open(png).format == "PNG"
    assert "arm3d: natural frequencies at t = 0 s" in capsys.readouterr().out


@pytest.mark.parametrize(("command", "model", "options", "message"), [
    ("run", ROOT / "examples" / "pendulum.dep", ["--animate", "a.gif", "--view", "30,40"],
     "'pendulum' is a planar model, drawn in its plane"),
    ("modes", ROOT / "examples" / "pendulum.dep", ["--plot", "a.png", "--view", "30,40"],
     "'pendulum' is a planar model, drawn in its plane"),
    ("run", ARM, ["--view", "30,40"], "--view sets the 3-D view of --animate: give one"),
    ("modes", ARM, ["--view", "30,40"],
     "--view sets the 3-D view of --plot or --animate: give one"),
])
def test_a_view_without_a_3d_picture_is_a_usage_error(command, model, options, message,
                                                     tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main([command, str(model), *options]) == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("view", ["30", "30,x", "30,40,50", "nan,3"])
def test_a_bad_view_is_refused(view, capsys):
    with pytest.raises(SystemExit) as stop:
        cli.main(["run", str(ARM), "--animate", "a.gif", f"--view={view}"])
    assert stop.value.code == 2
    assert "is not ELEV,AZIM" in capsys.readouterr().err
