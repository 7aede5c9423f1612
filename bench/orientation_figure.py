"""The figure of docs/language.md, Spatial models: how `orientation = rz(30 deg) * ry(-40
deg)` turns a body frame, one turn after the other about the axes of the frame reached so far.

    .venv/bin/python bench/orientation_figure.py   # writes docs/figures/spatial-orientation.png
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "docs" / "figures" / "spatial-orientation.png"


def turn(axis: str, angle: float) -> np.ndarray:
    """The right-handed rotation by `angle` about the named axis."""
    c, s = math.cos(angle), math.sin(angle)
    k = "xyz".index(axis)
    i, j = (k + 1) % 3, (k + 2) % 3
    matrix = np.eye(3)
    matrix[i, i], matrix[i, j], matrix[j, i], matrix[j, j] = c, -s, s, c
    return matrix


def draw_frame(ax, R: np.ndarray, label: str, style: dict) -> None:
    for k, name in enumerate("xyz"):
        end = R[:, k]
        ax.quiver(0, 0, 0, *end, arrow_length_ratio=0.12, **style)
        ax.text(*(1.12 * end), f"{name}{label}", fontsize=10, color=style["color"])


def main() -> None:
    fig = plt.figure(figsize=(10, 4.2))
    steps = [("world frame", np.eye(3), "", "0.35"),
             ("after rz(30 deg)", turn("z", math.radians(30)), "'", "tab:blue"),
             ("after rz(30 deg) * ry(-40 deg)",
              turn("z", math.radians(30)) @ turn("y", math.radians(-40)), "''", "tab:red")]
    for n, (title, R, label, color) in enumerate(steps):
        ax = fig.add_subplot(1, 3, n + 1, projection="3d")
        if n:
            draw_frame(ax, steps[n - 1][1], steps[n - 1][2], dict(color="0.75", linewidth=1))
        draw_frame(ax, R, label, dict(color=color, linewidth=2))
        ax.set_title(title, fontsize=10)
        ax.set_xlim(-1, 1), ax.set_ylim(-1, 1), ax.set_zlim(-1, 1)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=22, azim=35)
        ax.set_xticks([]), ax.set_yticks([]), ax.set_zticks([])
    fig.suptitle("orientation = rz(30 deg) * ry(-40 deg): each turn about an axis of the frame "
                 "the turns before it reached (R = Rz Ry)", fontsize=10)
    fig.tight_layout()
    OUT.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT, dpi=110)
    print(OUT)


if __name__ == "__main__":
    main()
