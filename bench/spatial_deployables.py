"""The figures and numbers of docs/examples.md for the two spatial deployables,
examples/canted_wing.dep and examples/reflector_arm.dep, made by the pipeline a user runs:
load, compile to C, run, draw.

    .venv/bin/python bench/spatial_deployables.py [--out docs/figures]

For each model it prints the latches (time, rate), the peak hinge loads (force, lock torque
and the largest bending moment of the `*_moment` outputs), the energy balance (kinetic plus
potential plus dissipated: its largest drift against the work the springs did) and, for the
wing, how far the cable loops let the hinges part; then it runs the model again with each
hinge's friction 20 % lower and higher (every combination) and prints the latch times. It
writes, per model, the time histories (<model>.png) and the mechanism in 3-D at a few
moments of its deployment (<model>_3d.png).
"""

from __future__ import annotations

import argparse
import itertools
import math
import tempfile
from pathlib import Path

import numpy as np

import depsim
from depsim.runtime.output import atomic_path

ROOT = Path(__file__).resolve().parents[1]
MODELS = {"canted_wing": ("root", "inner", "outer"), "reflector_arm": ("shoulder", "elbow")}
# The bus face (x = 0) drawn in the 3-D pictures: its corners (m), y and z.
BUS_FACE = {"canted_wing": ((-1.1, 1.1), (-1.0, 1.0)),
            "reflector_arm": ((-1.0, 1.0), (-1.2, 1.0))}
SNAPSHOTS = {"canted_wing": (0.0, 8.0, 16.0, 32.0), "reflector_arm": (0.0, 10.0, 20.5, 45.0)}
VIEWS = {"canted_wing": (22.0, -62.0), "reflector_arm": (20.0, -50.0)}


def run(name: str, folder: Path):
    """The compiled model and its run, output every 0.02 s for the figures (the model's
    0.1 s would clip the latches' ringing; the latches and peak loads do not depend on it)."""
    sim = depsim.load(ROOT / "examples" / f"{name}.dep").compile(
        "c", out_dir=folder / name)
    return sim, sim.run(dt_out=0.02)


def energy_drift(result) -> tuple[float, float]:
    """(largest change of kinetic + potential + dissipated energy, J; the energy the springs
    and cable loops released, J: kinetic + potential at the start less at the end)."""
    balance, energy = result.output("energy_balance"), result.output("energy")
    return float(np.max(np.abs(balance - balance[0]))), float(energy[0] - energy[-1])


def print_run(name: str, result) -> None:
    print(f"{name}: deployed {result.deployment.deployed} at {result.deployment.time:.3f} s")
    for latch in result.deployment.latches:
        print(f"  latch {latch.hinge:9s} t = {latch.t:8.3f} s, rate "
              f"{math.degrees(latch.rate):6.3f} deg/s")
    for hinge, peak in result.peak_loads.items():
        print(f"  peak {hinge:9s} force {peak.force:7.3f} N at {peak.t_force:7.3f} s, "
              f"lock torque {peak.torque:7.3f} N*m at {peak.t_torque:7.3f} s")
    for output in result.output_names:
        if output.endswith("_moment"):
            values = result.output(output)
            k = int(np.argmax(np.abs(values)))
            print(f"  largest {output}: {values[k]:.3f} N*m at {result.times[k]:.2f} s")
    drift, work = energy_drift(result)
    d = result.deployment
    print(f"  springs' work {work:.4f} J, dissipated {result.output('dissipated')[-1]:.4f} J "
          f"(friction {d.friction_energy:.4f} J, latch impacts {d.impact_energy:.4f} J, the "
          f"rest damping); energy balance drift {drift:.2e} J")
    for output in result.output_names:
        if output.endswith("_stretch"):
            print(f"  largest {output}: "
                  f"{math.degrees(np.max(np.abs(result.output(output)))):.2f} deg")
    print(f"  steps {result.stats.accepted_steps}, force evaluations "
          f"{result.stats.rhs_evaluations}")


def friction_corners(name: str, sim) -> None:
    """Every hinge's friction 20 % lower and higher, all combinations: the latch times."""
    hinges = MODELS[name]
    nominal = sim.parameters()
    index = {p: i for i, p in enumerate(sim.module.PARAMETERS)}
    print(f"  friction -20 % / +20 % ({', '.join(hinges)}): latch times")
    for signs in itertools.product((0.8, 1.2), repeat=len(hinges)):
        settings = {f"{h}.friction": s * nominal[index[f'{h}.friction']]
                    for h, s in zip(hinges, signs)}
        result = sim.run(set=settings)
        times = ", ".join(f"{x.hinge} {x.t:.2f} s" for x in result.deployment.latches)
        print(f"    {signs}: deployed {result.deployment.deployed}: {times}")


def history_figure(name: str, result, path: Path) -> None:
    """The hinge angles, the cable loops' stretch (if any), the lock torques (if any), the
    hinge forces and bending moments, and the energies against time."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    t, names = result.times, result.output_names
    groups = [[o for o in names if o.endswith(ends)]
              for ends in ("_stretch", "_torque", ("_force", "_moment"))]
    groups = [g for g in groups if g]
    figure = Figure(figsize=(8, 2.3 * (len(groups) + 2)), layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.subplots(len(groups) + 2, 1, sharex=True)
    for hinge in MODELS[name]:
        axes[0].plot(t, np.degrees(result.output(f"theta_{hinge}")), label=hinge)
    axes[0].set_ylabel("hinge angle [deg]")
    for ax, group in zip(axes[1:], groups):
        for output in group:
            if output.endswith("_stretch"):
                ax.plot(t, np.degrees(result.output(output)), label=output, lw=1.0)
                ax.set_ylabel("cable loop\nstretch [deg]")
            else:
                unit = "N" if output.endswith("_force") else "N*m"
                ax.plot(t, result.output(output), label=f"{output} [{unit}]", lw=1.0)
                ax.set_ylabel("lock torque [N*m]" if output.endswith("_torque")
                              else "force [N], moment [N*m]")
    energy, dissipated = result.output("energy"), result.output("dissipated")
    axes[-1].plot(t, energy, label="kinetic + potential")
    axes[-1].plot(t, dissipated, label="dissipated (friction, dampers, latches)")
    axes[-1].plot(t, energy + dissipated, "k--", lw=0.9, label="their sum")
    axes[-1].set_ylabel("energy [J]")
    axes[-1].set_xlabel("t [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper left" if ax is not axes[-1] else "center left", fontsize=8)
        for latch in result.deployment.latches:
            ax.axvline(latch.t, color="tab:red", ls="--", lw=0.8)
    times = ", ".join(f"{x.hinge} {x.t:.1f} s" for x in result.deployment.latches)
    figure.suptitle(f"{name}: latched {times} (red lines)")
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format="png", dpi=90)


def picture_3d(name: str, sim, result, path: Path) -> None:
    """The mechanism at SNAPSHOTS' times in one 3-D view, earlier ones fainter, with the bus
    face it deploys from."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from depsim.runtime.animation3d import Drawing, SpatialGeometry, new_axes, set_limits

    p = result.parameters
    frames = [int(np.argmin(np.abs(result.times - t))) for t in SNAPSHOTS[name]]
    geometry = SpatialGeometry(sim.module, p, result.q[0], sim.outlines(p))
    placements = [geometry.place(result.q[k]) for k in frames]
    figure = Figure(figsize=(7, 6))
    FigureCanvasAgg(figure)
    figure.subplots_adjust(left=0.0, right=1.0, bottom=0.02, top=0.94)
    ax = new_axes(figure, geometry, VIEWS[name])
    (y0, y1), (z0, z1) = BUS_FACE[name]
    face = np.array([(0, y0, z0), (0, y1, z0), (0, y1, z1), (0, y0, z1)])
    ax.add_collection3d(Poly3DCollection([face], facecolor=(0.6, 0.6, 0.6, 0.35),
                                         edgecolor="0.4"), autolim=False)
    set_limits(ax, np.concatenate([placement.points() for placement in placements] + [face]))
    for k, placement in enumerate(placements):
        last = k == len(placements) - 1
        drawing = Drawing(ax, geometry, colour=None if last else "0.45",
                          alpha=0.35 if last else 0.08, width=1.6 if last else 0.7)
        drawing.update(placement)
        x, y, z = placement.joints.T
        ax.plot(x, y, z, ls="none", marker="o", ms=4 if last else 2,
                color="black" if last else "0.45")
    moments = ", ".join(f"{result.times[k]:.0f}" for k in frames)
    ax.set_title(f"{name} at t = {moments} s (the last in colour); bus face grey",
                 fontsize=10)
    with atomic_path(path) as tmp:
        figure.savefig(tmp, format="png", dpi=90)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "figures"))
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for name in MODELS:
            sim, result = run(name, Path(tmp))
            print_run(name, result)
            friction_corners(name, sim)
            history_figure(name, result, out / f"{name}.png")
            picture_3d(name, sim, result, out / f"{name}_3d.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
