"""Iterative vs direct multipliers: the cost of finding lambda, and of whole runs.

    .venv/bin/python bench/bench_multipliers.py [--repeats 7] [--quick]

1. One multiplier solve at a state (q, qd, t) -> (lambda, qdd):
   iterative = the acceleration pass, (6) with A = S^-1 by Jacobi-preconditioned CG
               (runtime.stepper.Stepper.acceleration), no factorisation;
   direct    = LU of the augmented matrix [[M, Phi_q^T], [Phi_q, 0]] (runtime.direct).
   Both include the module evaluations (Phi_q, f, gamma). Models: the hand-made pendulum and
   slider-crank of tests/runtime/models and an N-link pendulum chain (NC = 2N) built here.
2. Whole runs: simulate vs simulate_direct at the same tolerance.

Times are medians over the repeats; the ratios (iterative / direct) are what to compare across
machines.
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import time
import types
from pathlib import Path

import numpy as np

from depsim.runtime import simulate, simulate_direct
from depsim.runtime.constraints import ConstraintSet
from depsim.runtime.direct import DirectRun
from depsim.runtime.stepper import Stepper
from depsim.runtime.system import System, resolve_settings

ROOT = Path(__file__).resolve().parents[1]


def handmade(name: str):
    path = ROOT / "tests" / "runtime" / "models" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"bench_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class Chain:
    """An n-link chain of unit bars (1 kg, hinged end to end, the first to the ground) hanging
    in gravity, released horizontal: NQ = 3n, NC = 2n. Row 2k + axis is end a of bar k minus
    end b of bar k - 1 (the ground origin for k = 0)."""

    def __init__(self, n: int):
        self.n = n
        self.masses = np.tile([1.0, 1.0, 1 / 12], n)
        rows, cols = [], []
        for k in range(n):
            for axis in (0, 1):
                rows += [2 * k + axis] * (4 if k else 2)
                cols += [3 * k + axis, 3 * k + 2] + ([3 * k - 3 + axis, 3 * k - 1] if k else [])
        self.rows, self.cols = tuple(rows), tuple(cols)

    def _half(self, q):
        phi = q[2::3]
        return 0.5 * np.cos(phi), 0.5 * np.sin(phi)

    @staticmethod
    def _pairs(a, b):
        """Interleave rows: (a_k - b_{k-1}) for x and y, b_{-1} = 0."""
        out = np.empty(2 * len(a[0]))
        for axis in (0, 1):
            out[axis::2] = a[axis] - np.concatenate(([0.0], b[axis][:-1]))
        return out

    def phi(self, q, t, p):
        c, s = self._half(q)
        x, y = q[0::3], q[1::3]
        return self._pairs((x - c, y - s), (x + c, y + s))

    def phi_q(self, q, t, p):
        c, s = self._half(q)
        values = []
        for k in range(self.n):
            for axis, lever in ((0, s), (1, -c)):
                values += [1.0, lever[k]] + ([-1.0, lever[k - 1]] if k else [])
        return np.array(values)

    def gamma(self, q, qd, t, p):
        c, s = self._half(q)
        w2 = qd[2::3] ** 2
        return self._pairs((-c * w2, -s * w2), (c * w2, s * w2))

    def initial_state(self, p):
        q = np.zeros(3 * self.n)
        q[0::3] = np.arange(self.n) + 0.5
        return q, np.zeros(3 * self.n)

    def force(self, q, qd, t, p):
        f = np.zeros(3 * self.n)
        f[1::3] = -9.81
        return f

    def energy(self, q, qd, t, p):
        return np.array([0.5 * np.sum(self.masses * qd * qd), 9.81 * np.sum(q[1::3])])

    def hinge_angles(self, q, p):
        return np.diff(np.concatenate(([0.0], q[2::3])))

    def module(self):
        """The chain as a generated-module-like namespace."""
        n = self.n
        return types.SimpleNamespace(
            MODEL_NAME=f"chain{n}", NQ=3 * n, NC=2 * n, NP=0,
            COORDINATES=tuple(f"bar{k}.{c}" for k in range(n) for c in ("x", "y", "phi")),
            PARAMETERS=(), PARAMETER_DEFAULTS=(),
            CONSTRAINTS=tuple(f"h{k}.{a}" for k in range(n) for a in ("x", "y")),
            CONSTRAINT_JOINTS=tuple(f"h{k}" for k in range(n) for _ in (0, 1)),
            PHI_Q_ROWS=self.rows, PHI_Q_COLS=self.cols, HINGES=tuple(f"h{k}" for k in range(n)),
            SLIDERS=(), OUTPUTS=("tip_y",), OUTPUT_UNITS=("m",),
            ENERGIES=("kinetic", "gravity"), DISSIPATORS=(), T_END=1.0, TOL=1e-8, DT_OUT=0.01,
            mass_matrix=lambda p: np.diag(self.masses), initial_state=self.initial_state,
            phi=self.phi, phi_q=self.phi_q, phi_t=lambda q, t, p: np.zeros(2 * n),
            gamma=self.gamma, force=self.force, hinge_angles=self.hinge_angles,
            hinge_rates=lambda q, qd, p: self.hinge_angles(qd, p),
            hinge_jacobian=lambda q, p: np.eye(n, 3 * n, 2) - np.eye(n, 3 * n, -1),
            outputs=lambda q, qd, t, p: np.array([q[-2] + 0.5 * np.sin(q[-1])]),
            energy=self.energy, dissipation=lambda q, qd, t, p: np.zeros(0))


def chain(n: int):
    return Chain(n).module()


def median_time(call, calls: int, repeats: int) -> float:
    """Median over `repeats` of the mean wall time of one call (s)."""
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(calls):
            call()
        samples.append((time.perf_counter() - start) / calls)
    return statistics.median(samples)


def multiplier_solves(models, repeats: int, calls: int) -> None:
    print("1. one multiplier solve (lambda and qdd at a state)")
    print(f"{'model':>14} {'NC':>4} {'iterative us':>13} {'direct us':>10} {'ratio':>7}"
          f" {'CG it':>6} {'|d lambda|':>10}")
    for module in models:
        p = np.array(module.PARAMETER_DEFAULTS, dtype=float)
        system = System(module, p)
        stepper = Stepper(system, ConstraintSet(system), 1e-10)
        direct = DirectRun(module, resolve_settings(module, p))
        q, qd = (np.array(v, dtype=float) for v in module.initial_state(p))
        guess = np.zeros(module.NC)
        lam_iterative, _, report = stepper.acceleration(q, qd, 0.0, guess)
        _, lam_direct = direct.solve(q, qd, 0.0)
        t_iter = median_time(lambda: stepper.acceleration(q, qd, 0.0, guess), calls, repeats)
        t_direct = median_time(lambda: direct.solve(q, qd, 0.0), calls, repeats)
        difference = np.max(np.abs(lam_iterative - lam_direct))
        print(f"{module.MODEL_NAME:>14} {module.NC:>4} {1e6 * t_iter:>13.1f} "
              f"{1e6 * t_direct:>10.1f} {t_iter / t_direct:>7.2f} {report.cg_iterations:>6}"
              f" {difference:>10.1e}")


def whole_runs(cases, repeats: int) -> None:
    print("\n2. whole runs (same tol; the direct solver uses DOP853, order 8)")
    print(f"{'model':>14} {'t_end':>6} {'tol':>7} {'iterative s':>12} {'direct s':>9} "
          f"{'ratio':>7} {'f-evals it/dir':>15} {'max |out diff|':>15}")
    for module, t_end, tol in cases:
        kwargs = dict(t_end=t_end, tol=tol)
        iterative, direct = simulate(module, **kwargs), simulate_direct(module, **kwargs)
        t_iter = median_time(lambda: simulate(module, **kwargs), 1, repeats)
        t_direct = median_time(lambda: simulate_direct(module, **kwargs), 1, repeats)
        evals = iterative.stats.rhs_evaluations / direct.stats.rhs_evaluations
        difference = np.max(np.abs(iterative.outputs - direct.outputs))
        print(f"{module.MODEL_NAME:>14} {t_end:>6.2f} {tol:>7.0e} {t_iter:>12.3f} "
              f"{t_direct:>9.3f} {t_iter / t_direct:>7.2f} {evals:>15.2f} {difference:>15.1e}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--quick", action="store_true", help="fewer calls, shorter runs")
    args = parser.parse_args(argv)
    pendulum, slider_crank = handmade("pendulum"), handmade("slider_crank")
    sizes = (4, 16) if args.quick else (4, 16, 64)
    multiplier_solves([pendulum, slider_crank] + [chain(n) for n in sizes], args.repeats,
                      calls=50 if args.quick else 300)
    scale = 0.25 if args.quick else 1.0
    whole_runs([(pendulum, 2.0 * scale, 1e-9), (slider_crank, 0.5 * scale, 1e-9),
                (chain(4), 0.5 * scale, 1e-8)], max(1, args.repeats // 2))


if __name__ == "__main__":
    main()
