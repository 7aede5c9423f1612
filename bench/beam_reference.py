"""References for the two-link flexible pendulum: on the mesh of a depsim run but not by its
linearly implicit step, or on a finer mesh.

    .venv/bin/python bench/beam_reference.py --elements 16 [--solver explicit|radau|implicit]
                 [--tol 1e-8] [--t-end 5] [--out bench/results/two_link_flex_ref16.npz]

* `explicit`: depsim's own multiplier iteration with DOPRI 5(4) throughout (stepping
  "explicit"): every mode resolved by an explicit step held at its stability bound, no
  numerical damping (about 2 minutes at 16 elements for 5 s, 8 at 32).
* `radau`: no depsim core at all. The generated NumPy module supplies M, f, Phi and gamma;
  tests/references/direct.py solves the augmented index-1 system with Baumgarte
  stabilisation at every evaluation and scipy's Radau IIA (implicit, order 5, its own
  finite-difference Jacobian) integrates it (about 90 s at 2 elements; hours at 16).
* `implicit`: depsim's linearly implicit step, for a mesh finer than any run it is compared
  with: the mesh-converged reference (64 elements at tol 1e-9, about 130 s; at tol 1e-10,
  239,217 steps, about 330 s). Run it at two tolerances to see how far it is converged in
  time.

bench/bench_beams.py measures depsim against these files; the two agree at 2 elements to
1.3e-7 rad in chord2 and 6e-7 m in tip2 (tol 1e-8 and 1e-9), which is how we know each is
converged in time.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import depsim

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the reference solver
from references.direct import solve_direct  # noqa: E402


# The velocities' absolute tolerance is RATE_FACTOR tol: the error in the positions is what is
# controlled (a velocity error shows in them a step later). With tol on the velocities too,
# Radau resolves every bending and axial mode the release excites, however small its
# displacement (about 150,000 steps per second at 2 elements).
RATE_FACTOR = 1e4


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, default=16)
    parser.add_argument("--solver", choices=("explicit", "radau", "implicit"),
                        default="explicit")
    parser.add_argument("--tol", type=float, default=1e-8)
    parser.add_argument("--t-end", type=float, default=5.0)
    parser.add_argument("--dt-out", type=float, default=5e-4)  # bench_beams.py's
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    n = args.elements
    out = args.out or reference_path(n)
    model = depsim.load(ROOT / "examples" / "two_link_flex.dep").with_elements(
        {"link1": n, "link2": n})
    start = time.perf_counter()
    if args.solver in ("explicit", "implicit"):
        result = model.compile(target="c").run(t_end=args.t_end, dt_out=args.dt_out,
                                               tol=args.tol, stepping=args.solver,
                                               max_steps=1e9)
        times, chord2, tip2 = result.times, result.output("chord2"), result.output("tip2")
        steps, evaluations = result.stats.accepted_steps, result.stats.rhs_evaluations
    else:
        module = model.compile(target="numpy").module
        solution = solve_direct(module, tol=args.tol, t_end=args.t_end, dt_out=args.dt_out,
                                method="Radau", rate_tol=RATE_FACTOR * args.tol)
        names = list(module.OUTPUTS)
        times = solution.times
        chord2, tip2 = (solution.outputs[:, names.index(o)] for o in ("chord2", "tip2"))
        steps, evaluations = solution.steps, solution.evaluations
    wall = time.perf_counter() - start
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savez(out, times=times, chord2=chord2, tip2=tip2, elements=n, tol=args.tol,
             solver=args.solver, wall=wall, steps=steps, evaluations=evaluations)
    print(f"{n} elements per link, {args.solver} tol {args.tol:g}: {steps} steps, "
          f"{evaluations} evaluations, {wall:.1f} s -> {out}")


def reference_path(elements: int) -> Path:
    """Where bench/bench_beams.py looks for the reference at this many elements per link."""
    return ROOT / "bench" / "results" / f"two_link_flex_ref{elements}.npz"


if __name__ == "__main__":
    main()
