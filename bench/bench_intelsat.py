"""INTELSAT V, 0-70 s: depsim's standalone C program against a hand-written solver, side by
side in one run, and the throughput of a Monte Carlo study.

    .venv/bin/python bench/bench_intelsat.py                        # tol 1e-8, 7 runs each
    .venv/bin/python bench/bench_intelsat.py --tol 1e-8 --tol 3e-8 --repeat 11 --runs 2000

The hand-written solver (tests/references/intelsat_hand.c, also the test suite's reference) integrates the four hinge angles with
Dormand-Prince 5(4) and the same forces, latches included: the minimal-coordinate baseline.
Both write theta1..4 every 0.05 s; the error is the largest difference from a converged
reference (the hand solver at tol 1e-13, which agrees with itself at 1e-12 to ~1e-11 rad).
Times are medians of whole processes, run interleaved; a second pair, also interleaved, writes
no rows (the hand solver without -o, depsim with --dt-out 70: its end alone), the solvers'
own cost with the process start. The study is `depsim sweep` with seven spread parameters
(frictions, preloads, cable stiffness), timed as a whole command.
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEPSIM = [sys.executable, "-m", "depsim"]
SAMPLES = ["h1.friction=normal(0.68, 0.068)", "h2.friction=normal(0.64, 0.064)",
           "h3.friction=normal(0.69, 0.069)", "h4.friction=normal(0.70, 0.070)",
           "h1.preload=normal(1.70, 0.17)", "h2.preload=normal(0.85, 0.085)",
           "cable_k=uniform(4000, 5000)"]


def build(folder: Path) -> tuple[Path, Path]:
    """The hand solver and depsim's program for examples/intelsat5.dep."""
    hand = folder / "intelsat_hand"
    subprocess.run(["cc", "-O2", "-std=c99", "-o", str(hand),
                    str(ROOT / "tests" / "references" / "intelsat_hand.c"), "-lm"], check=True)
    subprocess.run([*DEPSIM, "compile", str(ROOT / "examples" / "intelsat5.dep"), "--target",
                    "c", "-o", str(folder / "depsim")], check=True, capture_output=True)
    subprocess.run(["make", "-s", "-C", str(folder / "depsim"), "intelsat5"], check=True)
    return hand, folder / "depsim" / "intelsat5"


def hand_run(hand: Path, tol: float, out: Path | None) -> dict:
    """One run; out None: no CSV written."""
    written = ["-o", str(out)] if out is not None else []
    done = subprocess.run([str(hand), "--t-end", "70", "--tol", repr(tol), *written],
                          capture_output=True, text=True, check=True)
    steps, rejected, evaluations = re.search(r"steps (\d+) rejected (\d+) evaluations (\d+)",
                                             done.stderr).groups()
    return {"steps": int(steps), "rejected": int(rejected), "evaluations": int(evaluations)}


def depsim_run(program: Path, tol: float, out: Path, dt_out: float = 0.05) -> dict:
    done = subprocess.run([str(program), "--t-end", "70", "--tol", repr(tol), "--dt-out",
                           repr(dt_out), "-o", str(out)], capture_output=True, text=True,
                          check=True)
    found = re.search(r"steps: (\d+) accepted, (\d+) rejected, (\d+) retried; (\d+) force",
                      done.stdout).groups()
    return {"steps": int(found[0]), "rejected": int(found[1]) + int(found[2]),
            "evaluations": int(found[3])}


def error(path: Path, reference: np.ndarray) -> float:
    values = np.loadtxt(path, delimiter=",", skiprows=1)
    n = min(len(values), len(reference))
    assert np.allclose(values[:n, 0], reference[:n, 0])
    return float(np.max(np.abs(values[:n, 1:5] - reference[:n, 1:5])))


def timed(run) -> float:
    start = time.perf_counter()
    run()
    return time.perf_counter() - start


def compare(hand: Path, program: Path, tol: float, repeat: int, folder: Path,
            reference: np.ndarray) -> None:
    hand_out, depsim_out = folder / "hand.csv", folder / "depsim.csv"
    hand_info, depsim_info = hand_run(hand, tol, hand_out), depsim_run(program, tol, depsim_out)
    hand_times, depsim_times, hand_bare, depsim_bare = [], [], [], []
    bare_out = folder / "depsim_end.csv"
    for _ in range(repeat):  # interleaved, whole processes
        hand_times.append(timed(lambda: hand_run(hand, tol, hand_out)))
        depsim_times.append(timed(lambda: depsim_run(program, tol, depsim_out)))
        hand_bare.append(timed(lambda: hand_run(hand, tol, None)))
        depsim_bare.append(timed(lambda: depsim_run(program, tol, bare_out, dt_out=70)))
    rows = [("hand, 4 joint coordinates", hand_info, hand_times, error(hand_out, reference)),
            ("depsim standalone C", depsim_info, depsim_times, error(depsim_out, reference))]
    print(f"\ntol {tol:g}, 0-70 s, medians of {repeat} whole processes")
    print(f"{'solver':<28} {'error rad':>10} {'wall ms':>9} {'steps':>7} {'rej+retried':>12} "
          f"{'f evals':>8}")
    for name, info, times, err in rows:
        print(f"{name:<28} {err:>10.2e} {1000 * statistics.median(times):>9.2f} "
              f"{info['steps']:>7} {info['rejected']:>12} {info['evaluations']:>8}")
    ratio = statistics.median(depsim_times) / statistics.median(hand_times)
    print(f"depsim / hand: {ratio:.2f}x the time, "
          f"{depsim_info['steps'] / hand_info['steps']:.1f}x the steps, "
          f"{depsim_info['evaluations'] / hand_info['evaluations']:.1f}x the force evaluations")
    bare = statistics.median(depsim_bare) / statistics.median(hand_bare)
    print(f"without writing the rows (the hand solver without -o, depsim with --dt-out 70): "
          f"{1000 * statistics.median(hand_bare):.2f} ms and "
          f"{1000 * statistics.median(depsim_bare):.2f} ms, {bare:.2f}x")


def study(runs: int, folder: Path) -> None:
    command = [*DEPSIM, "sweep", str(ROOT / "examples" / "intelsat5.dep"), "--runs", str(runs),
               "--seed", "1", "--t-end", "70", "-o", str(folder / "study.nc")]
    for item in SAMPLES:
        command += ["--sample", item]
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    wall = time.perf_counter() - start
    print(f"\ndepsim sweep, {runs} runs of 0-70 s, whole command on this machine: {wall:.1f} s "
          f"= {runs / wall:.1f} runs/s")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tol", type=float, action="append", help="tolerances (1e-8)")
    parser.add_argument("--repeat", type=int, default=7, help="runs per solver (median)")
    parser.add_argument("--runs", type=int, default=1000, help="study runs (0: no study)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        hand, program = build(folder)
        subprocess.run([str(hand), "--t-end", "70", "--tol", "1e-13", "-o",
                        str(folder / "reference.csv")], check=True, capture_output=True)
        reference = np.loadtxt(folder / "reference.csv", delimiter=",", skiprows=1)
        for tol in args.tol or [1e-8]:
            compare(hand, program, tol, args.repeat, folder, reference)
        if args.runs:
            study(args.runs, folder)
    return 0


if __name__ == "__main__":
    sys.exit(main())
