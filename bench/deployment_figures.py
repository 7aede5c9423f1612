"""The figures of docs/deployment.md (a free-flying spacecraft deploying its array) and
docs/modes.md (the deployed boom's and INTELSAT V wing's mode shapes), made by the pipeline a
user runs: load, compile to C, run or `modes`, draw.

    .venv/bin/python bench/deployment_figures.py [--out docs/figures]

The INTELSAT V wing of docs/modes.md is examples/intelsat5.dep with compliant latches (every
hinge's latch_stiffness and latch_damping given, WING_LATCHES), run to 80 s, where it has
deployed.
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np

import depsim
from depsim.runtime.mode_figures import plot_modes
from depsim.runtime.output import atomic_path

ROOT = Path(__file__).resolve().parents[1]
WING_LATCHES = {"h1": (2000.0, 2.0), "h2": (1500.0, 1.5), "h3": (1500.0, 1.5),
                "h4": (1500.0, 1.5)}  # latch_stiffness N*m/rad, latch_damping N*m*s/rad


def compliant_wing(folder: Path) -> Path:
    """examples/intelsat5.dep with WING_LATCHES' compliant latches, as a file in `folder`."""
    lines = (ROOT / "examples" / "intelsat5.dep").read_text().splitlines()
    out, hinge = [], None
    for line in lines:
        words = line.split()
        if words[:1] == ["hinge"]:
            hinge = words[1]
        out.append(line)
        if hinge in WING_LATCHES and words[:1] == ["latch"]:
            k, c = WING_LATCHES[hinge]
            out += [f"    latch_stiffness = {k} N*m/rad", f"    latch_damping = {c} N*m*s/rad"]
    path = folder / "intelsat5_compliant.dep"
    path.write_text("\n".join(out) + "\n")
    return path


def flight_figure(path: Path, folder: Path) -> None:
    """The free flyer's bus attitude disturbance and rate, the hinge angles, the root hinge's
    loads and the kick-off spring's push against time."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    sim = depsim.load(ROOT / "examples" / "free_flyer.dep").compile("c", out_dir=folder / "ff")
    result = sim.run(dt_out=0.01, t_end=20.0)
    t = result.times
    spin = math.radians(0.5)
    figure = Figure(figsize=(8, 9), layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.subplots(4, 1, sharex=True)
    attitude = np.degrees(result.output("attitude") - spin * t)
    axes[0].plot(t, attitude, color="C0")
    axes[0].set_ylabel("bus attitude\nless its initial spin [deg]")
    rate = axes[0].twinx()
    rate.plot(t, np.degrees(result.output("bus_rate")), color="C1", lw=0.9)
    rate.set_ylabel("bus rate [deg/s]", color="C1")
    axes[1].plot(t, np.degrees(result.output("h1_angle")), label="h1")
    axes[1].plot(t, np.degrees(result.output("h2_angle")), label="h2")
    axes[1].set_ylabel("hinge angle [deg]")
    axes[1].legend(loc="lower right")
    axes[2].plot(t, result.output("h1_force"), label="h1 force [N]")
    axes[2].plot(t, result.output("h1_torque"), label="h1 lock torque [N*m]")
    axes[2].set_ylabel("root hinge loads")
    axes[2].legend(loc="lower right")
    axes[3].plot(t, result.output("kick_force"), color="C2")
    axes[3].set_ylabel("kick-off spring\npush [N]")
    axes[3].set_xlabel("t [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        for event in result.events:
            if event.kind in ("latch", "release"):
                ax.axvline(event.t, color="tab:red" if event.kind == "latch" else "0.5",
                           ls="--", lw=0.8)
    figure.suptitle("free_flyer: release at 2 s, h1 latched at "
                    f"{result.events[4].t:.2f} s, h2 at {result.events[5].t:.2f} s")
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format="png", dpi=90)


def modes_figure(model: Path, path: Path, folder: Path, count: int) -> None:
    sim = depsim.load(model).compile("c", out_dir=folder / model.stem)
    found = sim.modes(at="deployed", count=count)
    print(found.table())
    p = sim.parameters()
    plot_modes(found, sim.module, path, p, outlines=sim.outlines(p), count=count)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "figures"))
    args = parser.parse_args(argv)
    out = Path(args.out)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        flight_figure(out / "free_flyer.png", folder)
        modes_figure(ROOT / "examples" / "boom.dep", out / "boom_modes.png", folder, 3)
        modes_figure(compliant_wing(folder), out / "intelsat5_modes.png", folder, 6)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
