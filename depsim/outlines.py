"""Each rigid member's points in its own frame, from the model text: what the animation
(`depsim.runtime.animate`) and the mode figures draw a member's outline through
(`Simulator.outlines`). Planar points are (x, y), spatial ones (x, y, z)."""

from __future__ import annotations

import math

import numpy as np

from depsim.dsl import ir
from depsim.dsl.evaluate import EvaluationError, evaluate


def member_points(model: ir.Model, p: np.ndarray) -> dict[str, np.ndarray]:
    """{member: (k, 2) or, in a spatial model, (k, 3) points (m, from its centre of mass, in
    its frame)} at the parameter vector `p`: its centre of mass, a bar's ends and every
    declared point. A body of fewer than three points (its centre counted) also gets
    corners: in a planar model those of a square of half-side its radius of gyration,
    sqrt(inertia / mass); in a spatial one those of the uniform box of its mass and principal
    moments along its principal axes (half-sides sqrt(3 (I_j + I_k - I_i) / (2 m))). A
    spatial model's entry "ground" holds the ground's declared points (world frame; not
    its origin). A member whose points cannot be evaluated is left out (the animation then
    reconstructs it from the generated module)."""
    size = 3 if model.spatial else 2
    out = {}
    for body in model.bodies:
        try:
            points = [_point(point, p, size) for point in body.points]
            if len({*points, (0.0,) * size}) < 3 and body.kind != "bar":
                points += _box(body, p) if model.spatial else _square(body, p)
        except (EvaluationError, ValueError, ZeroDivisionError):
            continue
        out[body.name] = np.array([(0.0,) * size] + points)
    if model.spatial:
        try:
            out["ground"] = np.array([_point(point, p, 3) for point in model.ground.points
                                      if point.name != "origin"]).reshape(-1, 3)
        except (EvaluationError, ValueError, ZeroDivisionError):
            pass
    return out


def _point(point: ir.Point, p, size: int) -> tuple[float, ...]:
    return tuple(evaluate(c, p) for c in (point.x, point.y, point.z)[:size])


def _square(body: ir.Body, p) -> list[tuple[float, ...]]:
    """The corners of a square of half-side the body's radius of gyration."""
    radius = math.sqrt(evaluate(body.inertia, p) / evaluate(body.mass, p))
    return [(sx * radius, sy * radius) for sx in (-1, 1) for sy in (-1, 1)]


def _box(body: ir.Body, p) -> list[tuple[float, ...]]:
    """The corners of the uniform box of the body's mass and principal moments (the strict
    triangle inequality of the moments and, with products of inertia, the positive definite
    second moments, range checks, make every half-side positive), along its principal
    axes."""
    mass = evaluate(body.mass, p)
    moments = [evaluate(moment, p) for moment in body.principal]
    if body.products is not None:  # the principal moments and axes of the tensor (ir.Body)
        pxy, pyz, pzx = (evaluate(value, p) for value in body.products)
        tensor = np.array([[moments[0], -pxy, -pzx], [-pxy, moments[1], -pyz],
                           [-pzx, -pyz, moments[2]]])
        moments, axes = np.linalg.eigh(tensor)
    else:
        axes = rotation(body.principal_axes, p)
    half = [math.sqrt(max(1.5 * (sum(moments) - 2 * moments[i]) / mass, 0.0))
            for i in range(3)]
    corners = [axes @ (np.array((sx, sy, sz)) * half)
               for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    return [tuple(float(c) for c in corner) for corner in corners]


def rotation(turns: tuple[ir.Turn, ...], p) -> np.ndarray:
    """The rotation matrix of an orientation, R = R_1 R_2 ... (ir.Turn)."""
    matrix = np.eye(3)
    for turn in turns:
        angle = evaluate(turn.angle, p)
        k = "xyz".index(turn.axis)
        i, j = (k + 1) % 3, (k + 2) % 3
        step = np.eye(3)
        step[i, i], step[i, j] = math.cos(angle), -math.sin(angle)
        step[j, i], step[j, j] = math.sin(angle), math.cos(angle)
        matrix = matrix @ step
    return matrix
