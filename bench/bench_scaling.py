"""Scale: hanging chains of n rigid bars (2 s of motion, tol 1e-8, damped hinges), the cost of
compiling them and of a step, and how both grow with n (issue: a thousand bodies).

    .venv/bin/python bench/bench_scaling.py                      # n = 10, 20, 40, 80
    .venv/bin/python bench/bench_scaling.py --sizes 10,30,100 --repeat 5

Per size: compile = derive + emit + C build of the model (a fresh cache, so nothing is
reused), time per step = the median over `--repeat` runs of the whole integration divided by
its accepted steps (C target, through the library), and the steps taken. The exponents are
least-squares slopes of log(cost) against log(n) over the sizes given.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np


def chain_model(n: int) -> str:
    """n bars of 0.1 m hanging from the ground, released 60 deg off the vertical."""
    lines = [f'model chain{n} "hanging chain of {n} bars"', "gravity = (0, -9.81) m/s^2"]
    for i in range(1, n + 1):
        lines.append(f"bar b{i} {{ length = 0.1 m; mass = 0.1 kg; "
                     "inertia = 0.1 kg * (0.1 m)^2 / 12 }")
    lines.append("hinge h1 joins ground.origin to b1.a { damping = 0.001 N*m*s/rad }")
    for i in range(2, n + 1):
        lines.append(f"hinge h{i} joins b{i - 1}.b to b{i}.a {{ damping = 0.001 N*m*s/rad }}")
    lines += ["initial { h1 = -60 deg }", "simulate { t_end = 2 s; tol = 1e-8; dt_out = 0.01 s }",
              f"output tip_y = b{n}.b.y"]
    return "\n".join(lines) + "\n"


def measure(n: int, folder: Path, repeat: int) -> tuple[float, float, int]:
    import depsim

    path = folder / f"chain{n}.dep"
    path.write_text(chain_model(n))
    start = time.perf_counter()
    sim = depsim.load(path).compile(target="c")
    compiled = time.perf_counter() - start
    sim.run(t_end=0.01)  # warm
    times, steps = [], 0
    for _ in range(repeat):
        start = time.perf_counter()
        result = sim.run()
        times.append(time.perf_counter() - start)
        steps = result.stats.accepted_steps
    return compiled, statistics.median(times) / steps, steps


def slope(sizes, values) -> float:
    return float(np.polyfit(np.log(sizes), np.log(values), 1)[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="10,20,40,80")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    with tempfile.TemporaryDirectory() as scratch:
        os.environ["DEPSIM_CACHE"] = str(Path(scratch) / "cache")  # nothing reused
        from depsim.runtime.core import core

        core()  # the integrator core, built once before any timing
        print(f"{'n':>6} {'compile (s)':>12} {'per step (us)':>14} {'steps':>7}")
        rows = []
        for n in sizes:
            compiled, per_step, steps = measure(n, Path(scratch), args.repeat)
            rows.append((n, compiled, per_step, steps))
            print(f"{n:>6} {compiled:>12.2f} {per_step * 1e6:>14.1f} {steps:>7}", flush=True)
    if len(rows) > 1:
        ns = [r[0] for r in rows]
        print(f"exponents: compile n^{slope(ns, [r[1] for r in rows]):.2f}, "
              f"per step n^{slope(ns, [r[2] for r in rows]):.2f}, "
              f"steps n^{slope(ns, [r[3] for r in rows]):.2f}")


if __name__ == "__main__":
    main()
