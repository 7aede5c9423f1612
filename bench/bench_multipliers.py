"""Iterative multipliers (the core) against a direct solver, on hanging chains of N bars.

    .venv/bin/python bench/bench_multipliers.py [--links 2,4,8,16,32] [--repeat 3] [--t-end 1]

Each chain is a .dep model written here: N unit bars (1 m, 1 kg) hinged end to end, the first
to the ground, released horizontal in gravity (NQ = 3N, NC = 2N). For each N, side by side:

    core      depsim.runtime.simulate on the C target (iterative multipliers, no factorisation)
    direct    the test suite's reference solver on the NumPy module: LU of the augmented
              matrix [[M, Phi_q^T], [Phi_q, 0]] at every evaluation, Baumgarte, DOP853

Printed: medians of --repeat runs, the steps and force evaluations of each, the ratio of the
times, and the largest difference of the hinge angles (rad) between the two at the output
times: both at the same tolerance, so it shows they solve the same problem.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the reference solver


def chain_model(n: int, t_end: float, tol: float) -> str:
    """The .dep text of an n-bar chain."""
    lines = [f'model chain{n} "A chain of {n} bars hanging from the ground"',
             "gravity = (0, -9.81) m/s^2"]
    for k in range(n):
        lines.append(f"bar b{k} {{ length = 1 m; mass = 1 kg; inertia = 1 kg*m^2 / 12 }}")
    for k in range(n):
        parent = "ground.origin" if k == 0 else f"b{k - 1}.b"
        lines.append(f"hinge h{k} joins {parent} to b{k}.a {{ angle = b{k} - "
                     f"{'ground' if k == 0 else f'b{k - 1}'} }}")
    lines.append("initial { " + "; ".join(f"h{k} = 0 deg" for k in range(n)) + " }")
    lines.append(f"simulate {{ t_end = {t_end} s; tol = {tol}; dt_out = 0.01 s }}")
    lines += [f"output a{k} = h{k}" for k in range(n)]
    return "\n".join(lines) + "\n"


def median_time(run, repeat: int):
    times, value = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        value = run()
        times.append(time.perf_counter() - start)
    return statistics.median(times), value


def bench(n: int, t_end: float, tol: float, repeat: int, folder: Path) -> dict:
    from depsim.codegen import compile_c, compile_numpy, derive, load_generated
    from depsim.dsl import load_model
    from depsim.runtime import simulate
    from depsim.runtime.binding import load_folder
    from references.direct import solve_direct

    source = folder / f"chain{n}.dep"
    source.write_text(chain_model(n, t_end, tol))
    model = load_model(source)
    system = derive(model)
    c_module = load_folder(compile_c(model, folder / f"c{n}", system))
    numpy_module = load_generated(compile_numpy(model, folder / f"numpy{n}", system))
    core_s, core = median_time(lambda: simulate(c_module), repeat)

    def direct():
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            return solve_direct(numpy_module)

    direct_s, reference = median_time(direct, repeat)
    return {"n": n, "core_s": core_s, "core_steps": core.stats.accepted_steps,
            "core_evaluations": core.stats.rhs_evaluations, "direct_s": direct_s,
            "direct_steps": reference.steps, "direct_evaluations": reference.evaluations,
            "difference": float(np.max(np.abs(core.outputs - reference.outputs)))}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--links", default="2,4,8,16,32", help="chain lengths N")
    parser.add_argument("--repeat", type=int, default=3, help="runs per solver (median)")
    parser.add_argument("--t-end", type=float, default=1.0, help="simulated time, s")
    parser.add_argument("--tol", type=float, default=1e-8)
    args = parser.parse_args(argv)
    print(f"{'N':>4} {'core s':>9} {'steps':>6} {'f evals':>8} {'direct s':>9} {'steps':>6} "
          f"{'f evals':>8} {'direct/core':>11} {'max |diff| rad':>15}")
    with tempfile.TemporaryDirectory() as tmp:
        for n in (int(v) for v in args.links.split(",") if v):
            r = bench(n, args.t_end, args.tol, args.repeat, Path(tmp))
            print(f"{n:>4} {r['core_s']:>9.4f} {r['core_steps']:>6} {r['core_evaluations']:>8} "
                  f"{r['direct_s']:>9.4f} {r['direct_steps']:>6} {r['direct_evaluations']:>8} "
                  f"{r['direct_s'] / r['core_s']:>11.1f} {r['difference']:>15.2e}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
