"""The calibration figure of docs/calibration.md: a synthetic ground test of INTELSAT V
(examples/intelsat5.dep) and `depsim fit` of the four hinges' frictions to it.

    .venv/bin/python bench/fit_figure.py [--data-dir DIR] [--out docs/figures/intelsat5-fit.png]

The test: the model run with the frictions of TRUTH, theta1..theta4 sampled at 20 Hz with
Gaussian noise of 0.06 deg, and the four latch times with 10 ms of noise (seed 1), written
as DIR/ground-test.csv and DIR/latch-times.csv (default: a temporary folder). The fit starts
at the model's frictions. Prints the report (the one docs/calibration.md shows) and writes the
figure; the same depsim, numpy and matplotlib give the same numbers and image.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

import depsim

ROOT = Path(__file__).resolve().parents[1]
TRUTH = {"h1.friction": 0.62, "h2.friction": 0.70, "h3.friction": 0.64, "h4.friction": 0.75}
NOISE_DEG = 0.06
LATCH_NOISE = 0.010  # s
T_END = 75.0


def write_ground_test(sim, folder: Path) -> tuple[Path, Path]:
    """The synthetic test's two files in `folder`."""
    run = sim.run(set=TRUTH, tol=1e-10, t_end=T_END, dt_out=0.05)
    rng = np.random.default_rng(1)
    angles = np.degrees(run.outputs) + rng.normal(0, NOISE_DEG, run.outputs.shape)
    data = folder / "ground-test.csv"
    header = "t [s], " + ", ".join(f"{name} [deg]" for name in run.output_names)
    data.write_text("# INTELSAT V deployment, synthetic ground test (bench/fit_figure.py)\n"
                    + header + "\n" + "".join(
                        f"{t:.2f}, " + ", ".join(f"{v:.4f}" for v in row) + "\n"
                        for t, row in zip(run.times, angles)))
    latches = folder / "latch-times.csv"
    latches.write_text("event, t [s]\n" + "".join(
        f"{e.name}, {e.t + rng.normal(0, LATCH_NOISE):.3f}\n"
        for e in run.events if e.kind == "latch"))
    return data, latches


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir", type=Path, help="where to write the test's files")
    parser.add_argument("--out", type=Path, default=ROOT / "docs/figures/intelsat5-fit.png")
    args = parser.parse_args(argv)
    sim = depsim.load(ROOT / "examples/intelsat5.dep").compile("c")
    with tempfile.TemporaryDirectory() as scratch:
        folder = args.data_dir or Path(scratch)
        data, latches = write_ground_test(sim, folder)
        fit = depsim.fit(sim, data=data, latch_times=latches, free=list(TRUTH),
                         sigma={"latch-times": f"{LATCH_NOISE} s"}, t_end=T_END)
    print(fit.report())
    fit.plot(args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
