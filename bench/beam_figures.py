"""The seed's Figures 4 and 5 for examples/two_link_flex.dep: link 2's chord angle and its tip
deflection over the 5 s, at 2 and 16 elements per link, with each run's time and steps.

    .venv/bin/python bench/beam_figures.py [--elements 2,16] [--out docs/figures/two_link_flex.png]

Each mesh goes through the real pipeline (Model.with_elements -> the C target -> the default
stepping at the model's tol 1e-8); the wall time is the run's alone (compilation apart).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

import depsim
from depsim.runtime.output import atomic_path

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "examples" / "two_link_flex.dep"


def run(elements: int, folder: Path):
    model = depsim.load(MODEL).with_elements({"link1": elements, "link2": elements})
    sim = model.compile(target="c", out_dir=folder / f"e{elements}")
    start = time.perf_counter()
    result = sim.run(t_end=5.0, dt_out=5e-4)
    return result, time.perf_counter() - start


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", default="2,16", help="element counts per link")
    parser.add_argument("--out", default=str(ROOT / "docs" / "figures" / "two_link_flex.png"))
    args = parser.parse_args(argv)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(8, 5.6), layout="constrained")
    FigureCanvasAgg(figure)
    chord, tip = figure.subplots(2, 1, sharex=True)
    with tempfile.TemporaryDirectory() as tmp:
        for elements in (int(n) for n in args.elements.split(",")):
            result, wall = run(elements, Path(tmp))
            label = (f"{elements} elements/link: {wall:.1f} s, "
                     f"{result.stats.accepted_steps:,} steps")
            print(label)
            chord.plot(result.times, np.degrees(result.output("chord2")), lw=0.9, label=label)
            tip.plot(result.times, 1e3 * result.output("tip2"), lw=0.7, label=label)
    chord.set_ylabel("chord2 [deg]  (Figure 4)")
    tip.set_ylabel("tip2 [mm]  (Figure 5)")
    tip.set_xlabel("t [s]")
    for ax in (chord, tip):
        ax.grid(True, alpha=0.3)
    chord.legend(fontsize=8, loc="upper right")
    figure.suptitle("two_link_flex, 0-5 s, tol 1e-8, C target (bench/beam_figures.py)")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out) as path:
        figure.savefig(path, format="png", dpi=100)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
