"""The study figure of README.md and docs/api.md: a Monte Carlo study of INTELSAT V
(examples/intelsat5.dep) over the hinge springs' preloads, the frictions and the cable
stiffness, with a deadline of 72 s (a run whose last latch has not engaged by then counts as
not deployed) and a limit on the root hinge's peak lock torque.

    .venv/bin/python bench/study_figure.py [--runs 200] [--out docs/figures/intelsat5-study.png]

Prints the study's summary (the table docs/api.md shows) and writes the figure. The seed is
fixed: the same depsim, numpy and matplotlib give the same numbers and the same image.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import depsim
from depsim.runtime.sweep import plot_study, summarize

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ["h1.preload=normal(1.7 N*m, 0.1 N*m)", "h2.preload=normal(0.85 N*m, 0.05 N*m)",
           "h1.friction=normal(0.68 N*m, 0.05 N*m)", "h2.friction=normal(0.64 N*m, 0.05 N*m)",
           "h3.friction=normal(0.69 N*m, 0.05 N*m)", "cable_k=uniform(4000 N/m, 5000 N/m)"]
LIMITS = {"peak.h1.torque": 8.5}  # N*m


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--out", default=str(ROOT / "docs" / "figures" / "intelsat5-study.png"))
    args = parser.parse_args(argv)
    sim = depsim.load(ROOT / "examples" / "intelsat5.dep").compile("c")
    with tempfile.TemporaryDirectory() as folder:
        study = depsim.sweep(sim, samples=SAMPLES, runs=args.runs, seed=7, t_end=72.0,
                             out=Path(folder) / "study.nc")
    print(summarize(study, limits=LIMITS))
    plot_study(study, args.out, limits=LIMITS)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
