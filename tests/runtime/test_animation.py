"""The animation draws each rigid member's outline through its points (runtime/animation.py):
the polygon of a body's points, a box along a bar, a square the size of its radius of gyration
around a one-point body; members lying on one another stay apart (nested boxes)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import depsim
from depsim.runtime.animation import Geometry, animate, member_outline
from depsim.runtime.interface import initial_state

ROOT = Path(__file__).resolve().parents[2]


def rotate(points, phi, centre):
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c * x - s * y + centre[0], s * x + c * y + centre[1]] for x, y in points])


def same_corners(a, b) -> bool:
    key = lambda p: (round(p[0], 9), round(p[1], 9))  # noqa: E731
    return sorted(map(key, a)) == sorted(map(key, b))


def test_an_outline_is_the_polygon_box_or_square_of_the_points():
    triangle = np.array([[0.0, 0.0], [1.0, 0.0], [0.2, 0.5], [0.3, 0.1]])  # one inside
    assert same_corners(member_outline(triangle, 0.1), triangle[:3])
    bar = np.array([[-1.0, 0.0], [0.0, 0.0], [1.0, 0.0]])
    assert same_corners(member_outline(bar, 0.1),
                        [[-1, -0.1], [1, -0.1], [1, 0.1], [-1, 0.1]])
    assert same_corners(member_outline(np.array([[0.5, 0.5]]), 0.2),
                        [[0.3, 0.3], [0.7, 0.3], [0.7, 0.7], [0.3, 0.7]])


@pytest.fixture(scope="module")
def slider_crank():
    return depsim.load(ROOT / "examples" / "slider_crank.dep").compile("c")


def test_members_are_drawn_through_all_their_points(slider_crank):
    """The crank and the rod as boxes from end a to end b (the rod was drawn from its centre
    to one hinge), the piston as a square of half-side sqrt(I / m) = sqrt(0.01 / 2) m."""
    sim = slider_crank
    p = sim.defaults
    q, _ = initial_state(sim.module, p)
    geometry = Geometry(sim.module, p, sim.outlines(p))
    drawn = dict(zip(geometry.member_names, geometry.outlines(q)))
    names = list(sim.module.COORDINATES)
    for bar, length in (("crank", 0.1), ("rod", 0.3)):
        x, y, phi = (q[names.index(f"{bar}.{c}")] for c in ("x", "y", "phi"))
        ends = rotate([[-length / 2, 0.0], [length / 2, 0.0]], phi, (x, y))
        box = drawn[bar]  # the ends are the middles of the box's short sides
        middles = np.array([(box[0] + box[3]) / 2, (box[1] + box[2]) / 2])
        assert np.allclose(middles, ends, atol=1e-12), bar
    radius = math.sqrt(0.01 / 2.0)
    x, y, phi = (q[names.index(f"piston.{c}")] for c in ("x", "y", "phi"))
    square = rotate([[-radius, -radius], [radius, -radius], [radius, radius],
                     [-radius, radius]], phi, (x, y))
    assert same_corners(drawn["piston"], square)


def test_stacked_members_show_as_nested_boxes(slider_crank):
    """Two bars lying on one another, as stowed panels do: the later one's box lies inside
    the earlier one's, with its own size, so both stay visible."""
    sim = slider_crank
    p = sim.defaults
    q = np.zeros(sim.module.NQ)  # every member at the origin, along +x
    outlines = {"crank": [[-0.15, 0.0], [0.15, 0.0]], "rod": [[-0.15, 0.0], [0.15, 0.0]],
                "piston": [[-0.15, 0.0], [0.15, 0.0]]}
    boxes = Geometry(sim.module, p, outlines).outlines(q)
    widths = [np.ptp(box[:, 1]) for box in boxes]
    assert widths[0] > widths[1] > widths[2] > 0
    assert all(np.allclose(np.ptp(box[:, 0]), 0.3) for box in boxes)


def test_the_command_line_animation_draws_the_outlines(slider_crank, tmp_path):
    """depsim run --animate passes the model's points: the frame shows the piston's square
    (its colour fills a block, not a line)."""
    from PIL import Image

    result = slider_crank.run(t_end=0.2)
    frames = animate(result, slider_crank.module, tmp_path / "a.gif", max_frames=3,
                     outlines=slider_crank.outlines(result.parameters))
    image = Image.open(tmp_path / "a.gif")
    assert frames == image.n_frames == 3
    pixels = np.asarray(image.convert("RGB")).astype(int)
    green = (abs(pixels[..., 0] - 44) < 40) & (abs(pixels[..., 1] - 160) < 40) & \
        (pixels[..., 2] < 120)  # tab:green (C2, the third member: the piston), lightened
    rows, cols = np.nonzero(green)
    assert rows.size and np.ptp(rows) > 20 and np.ptp(cols) > 20
