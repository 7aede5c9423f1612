"""The cost of forward sensitivities: a run with k of them against the run without, and
against finite differences (k + 1 runs forward, 2k + 1 central), with their accuracy.

    .venv/bin/python bench/bench_sensitivities.py               # INTELSAT V, k = 1, 2, 4, 7
    .venv/bin/python bench/bench_sensitivities.py --repeat 21 --tol 1e-8

Every round times, in one process and in an order that turns from round to round (the
machine's changing speed falls on all alike), a run without sensitivities and a run with k
of them (the C target through the Python API, dt_out = 0.5 s, the model's 70 s). The figures
are medians over the rounds; "ratio" is the run with k sensitivities over the run without
(the issue's goal: below 1 + k/2), "central" the cost of the central differences that would
give the same derivatives (2k + 1 runs) over the run with sensitivities.

Accuracy: the latch times' sensitivities against central differences at tol 1e-10 (relative
step 1e-4), the largest relative difference over the four latches and k parameters.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import depsim

ROOT = Path(__file__).resolve().parents[1]
PARAMETERS = ["h1.friction", "h2.friction", "h3.friction", "h4.friction", "h1.preload",
              "h2.preload", "cable_k"]


def timed(sim, **run) -> float:
    start = time.perf_counter()
    sim.run(**run)
    return time.perf_counter() - start


def accuracy(sim, names, tol=1e-10, step=1e-4) -> float:
    """The largest relative difference of the latch times' sensitivities from central
    differences."""
    result = sim.run(tol=tol, dt_out=0.5, sensitivities=names)
    worst = 0.0
    for k, name in enumerate(names):
        p0 = sim.parameters()[sim.parameter_names.index(name)]
        h = step * abs(p0)
        plus, minus = (sim.run(set={name: p0 + s * h}, tol=tol, dt_out=0.5) for s in (1, -1))
        fd = np.array([a.t - b.t for a, b in zip(plus.events, minus.events)]) / (2 * h)
        worst = max(worst, float(np.max(np.abs(result.sensitivities.event_times[:, k] - fd)
                                        / np.abs(fd))))
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=11)
    parser.add_argument("--tol", type=float, default=1e-8)
    args = parser.parse_args()
    sim = depsim.load(ROOT / "examples" / "intelsat5.dep").compile("c")
    sim.run(sensitivities=PARAMETERS[:1], t_end=1.0)  # the tangents' code, compiled once
    counts = (1, 2, 4, 7)
    cases = [()] + [tuple(PARAMETERS[:k]) for k in counts]
    times = {case: [] for case in cases}
    for round_ in range(args.repeat):
        order = cases[round_ % len(cases):] + cases[:round_ % len(cases)]
        for case in order:
            times[case].append(timed(sim, tol=args.tol, dt_out=0.5, sensitivities=case))
    base = statistics.median(times[()])
    print(f"INTELSAT V, 0-70 s, tol {args.tol:g}, C target, medians of {args.repeat} rounds")
    print(f"  without sensitivities: {1e3 * base:.2f} ms a run")
    print("   k   ms a run   ratio   goal 1+k/2   central differences (2k+1 runs) / it")
    for k in counts:
        with_k = statistics.median(times[tuple(PARAMETERS[:k])])
        print(f"  {k:2d}   {1e3 * with_k:8.2f}   {with_k / base:5.2f}   {1 + k / 2:10.1f}"
              f"   {(2 * k + 1) * base / with_k:8.2f}")
    print(f"latch times' sensitivities against central differences (tol 1e-10): largest "
          f"relative difference {accuracy(sim, PARAMETERS[:4]):.2e}")


if __name__ == "__main__":
    main()
