"""Scale: hanging chains of n rigid bars (2 s of motion, tol 1e-8, damped hinges), the cost of
compiling them and of a step, and how both grow with n (issue: a thousand bodies).

    .venv/bin/python bench/bench_scaling.py                      # n = 10, 20, 40, 80
    .venv/bin/python bench/bench_scaling.py --sizes 10,30,100 --repeat 5
    .venv/bin/python bench/bench_scaling.py --shape loop         # a closed loop

Shapes: `chain`, an open chain from a pivot released 60 deg off the vertical (a tree); `loop`,
the same bars hanging as a V from the pivot to a block that slides on a horizontal rail at the
pivot's height, pinned to the last bar (one closed loop through every bar).

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


def loop_model(n: int) -> str:
    """n bars (n even) hanging as a V from the ground to a block on a rail at y = 0."""
    lines = chain_model(n).replace(f"model chain{n} \"hanging chain of {n} bars\"",
                                   f"model loop{n} \"V of {n} bars on a rail\"").splitlines()
    lines = [line for line in lines if not line.startswith("initial")]
    lines += ["body block { mass = 0.1 kg; inertia = 1e-4 kg*m^2; point pin = (0, 0) m }",
              "slider rail joins ground.origin to block.pin { axis = (1, 0) }",
              f"hinge close joins b{n}.b to block.pin {{ damping = 0.001 N*m*s/rad }}",
              f"initial {{ h1 = -60 deg; h{n // 2 + 1} = 120 deg }}"]
    return "\n".join(lines) + "\n"


SHAPES = {"chain": chain_model, "loop": loop_model}


def measure(n: int, folder: Path, repeat: int, shape: str
            ) -> tuple[float, float, float, int]:
    """(compile, start, per step, steps): the start is a run to the first output time (the
    setup, the assembly of closed loops, a few steps); per step, the rest of a whole run over
    its remaining steps. Times are medians over `repeat` runs."""
    import depsim

    path = folder / f"{shape}{n}.dep"
    path.write_text(SHAPES[shape](n))
    start = time.perf_counter()
    sim = depsim.load(path).compile(target="c")
    compiled = time.perf_counter() - start

    def timed(**settings):
        times, steps = [], 0
        for _ in range(repeat):
            begin = time.perf_counter()
            result = sim.run(**settings)
            times.append(time.perf_counter() - begin)
            steps = result.stats.accepted_steps
        return statistics.median(times), steps

    sim.run(t_end=0.01)  # warm
    first, first_steps = timed(t_end=0.01)
    whole, steps = timed()
    return compiled, first, (whole - first) / (steps - first_steps), steps


def slope(sizes, values) -> float:
    return float(np.polyfit(np.log(sizes), np.log(values), 1)[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="10,20,40,80")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--shape", choices=sorted(SHAPES), default="chain")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    with tempfile.TemporaryDirectory() as scratch:
        os.environ["DEPSIM_CACHE"] = str(Path(scratch) / "cache")  # nothing reused
        from depsim.runtime.core import core

        core()  # the integrator core, built once before any timing
        print(f"{'n':>6} {'compile (s)':>12} {'start (s)':>10} {'per step (us)':>14} "
              f"{'steps':>7}")
        rows = []
        for n in sizes:
            compiled, first, per_step, steps = measure(n, Path(scratch), args.repeat, args.shape)
            rows.append((n, compiled, per_step, steps, first))
            print(f"{n:>6} {compiled:>12.2f} {first:>10.3f} {per_step * 1e6:>14.1f} {steps:>7}",
                  flush=True)
    if len(rows) > 1:
        ns = [r[0] for r in rows]
        print(f"exponents: compile n^{slope(ns, [r[1] for r in rows]):.2f}, "
              f"per step n^{slope(ns, [r[2] for r in rows]):.2f}, "
              f"steps n^{slope(ns, [r[3] for r in rows]):.2f}")
        large = [r for r in rows if r[0] >= 100]
        if len(large) > 1:
            print(f"per step from n = 100: n^{slope([r[0] for r in large], [r[2] for r in large]):.2f}")


if __name__ == "__main__":
    main()
