"""INTELSAT V, 0-70 s: depsim's standalone C program against the tight hand-written baseline,
side by side in one run, and the throughput of a Monte Carlo study.

    .venv/bin/python bench/bench_intelsat.py                        # tol 1e-8, 21 rounds
    .venv/bin/python bench/bench_intelsat.py --tol 1e-8 --tol 3e-8 --repeat 41 --runs 2000
    .venv/bin/python bench/bench_intelsat.py --runs 0 --profile     # and where depsim's goes

The baseline (tests/references/intelsat_hand.c, also the test suite's reference) integrates
the four hinge angles with Dormand-Prince 5(4), Hairer's step control and the same forces,
latches included: about 170 flops, three sincos, four exp and one 4 x 4 LDL^T an evaluation.

Every round runs each of these whole processes once, in an order that turns from round to
round (the machine's 2 cores are shared: its speed changes from minute to minute); the times
are medians over the rounds:

* no rows (the headline): `--dt-out 70`, the end alone written, as a study asks;
* rows: t, theta1..4 every 0.05 s (1,401 rows; depsim samples its record at the rows too);
* the fixed cost: a run to t = 1 ms (the process, its start and end, the model's setup).

Then, at equal accuracy against the converged reference: depsim at the loosest
tolerance on a ladder of multiples of the baseline's whose error is no larger than the
baseline's, both without rows, timed the same way.

"ns per evaluation" is the run without rows, less the fixed cost, over the right-side
evaluations: the whole method's time per evaluation, by wall time and by CPU time (user +
system: what the process itself used, steadier while other processes share the cores). The
right side alone is timed inside a run, each call between two clock readings, one reading's
cost taken off: depsim's program linked with a wrapper of the core's `dep_stepper_rhs`
(forces, Phi_q^T lambda, the profiles, M^-1; RHS_TIMER below), the baseline with --time-rhs
(which also times a loop over its run's states). With valgrind on the machine the
instructions per evaluation follow (callgrind, deterministic): the whole process's and the
right side's. --profile adds depsim's run by the method's parts.

The error is the largest difference of theta1..4 (every 0.05 s) from a converged reference:
the baseline at tol 1e-13, which agrees with itself at 1e-12 to ~1e-11 rad. The study is
`depsim sweep` with seven spread parameters (frictions, preloads, cable stiffness), timed as a
whole command.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEPSIM = [sys.executable, "-m", "depsim"]
HAND = ROOT / "tests" / "references" / "intelsat_hand.c"
SAMPLES = ["h1.friction=normal(0.68, 0.068)", "h2.friction=normal(0.64, 0.064)",
           "h3.friction=normal(0.69, 0.069)", "h4.friction=normal(0.70, 0.070)",
           "h1.preload=normal(1.70, 0.17)", "h2.preload=normal(0.85, 0.085)",
           "cable_k=uniform(4000, 5000)"]
T_END = 70.0


def build(folder: Path) -> tuple[Path, Path, Path | None]:
    """The baseline, depsim's program for examples/intelsat5.dep, and that program linked with
    RHS_TIMER (None where the linker has no --wrap). All -O2 -fno-math-errno, depsim's own
    flags."""
    hand = folder / "intelsat_hand"
    subprocess.run(["cc", "-O2", "-fno-math-errno", "-std=c99", "-o", str(hand), str(HAND),
                    "-lm"], check=True)
    subprocess.run([*DEPSIM, "compile", str(ROOT / "examples" / "intelsat5.dep"), "--target",
                    "c", "-o", str(folder / "depsim")], check=True, capture_output=True)
    subprocess.run(["make", "-s", "-C", str(folder / "depsim"), "intelsat5"], check=True)
    timed_folder = folder / "depsim_timed"
    shutil.copytree(folder / "depsim", timed_folder)
    (timed_folder / "intelsat5").unlink()
    (timed_folder / "rhs_timer.c").write_text(RHS_TIMER)
    linked = subprocess.run(["make", "-s", "-C", str(timed_folder), "intelsat5",
                             "LDLIBS=rhs_timer.c -Wl,--wrap=dep_stepper_rhs -lm"],
                            capture_output=True)
    timed_program = timed_folder / "intelsat5" if linked.returncode == 0 else None
    return hand, folder / "depsim" / "intelsat5", timed_program


# depsim's right side timed inside its run: the program linked with this wrapper of the core's
# dep_stepper_rhs (ld --wrap), two clock readings around each call, less one reading's cost.
RHS_TIMER = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <time.h>
void __real_dep_stepper_rhs(void *context, double t, const double *y, double *dy);
static double spent;
static long calls;
static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}
void __wrap_dep_stepper_rhs(void *context, double t, const double *y, double *dy)
{
    double start = now();
    __real_dep_stepper_rhs(context, t, y, dy);
    spent += now() - start;
    calls++;
}
__attribute__((destructor)) static void report(void)
{
    volatile double sink;
    double start = now();
    for (int i = 0; i < 100000; ++i) sink = now();
    double reading = (now() - start) / 100000;
    (void)sink;
    if (calls > 0)
        fprintf(stderr, "rhs_timer %ld calls %.1f ns each (%.1f ns a clock reading less)\n",
                calls, 1e9 * (spent / calls - reading), 1e9 * reading);
}
"""


def command(program: Path, tol: float, out: Path, t_end: float = T_END,
            dt_out: float = 0.05) -> list[str]:
    """Both programs take the same options."""
    return [str(program), "--t-end", repr(t_end), "--tol", repr(tol), "--dt-out", repr(dt_out),
            "-o", str(out)]


def counts(done: subprocess.CompletedProcess) -> dict:
    """Steps, rejected (and retried) steps and right-side evaluations from either program."""
    found = re.search(r"steps (\d+) rejected (\d+) evaluations (\d+)", done.stderr)
    if found:  # the baseline, and its own time: "time T ms, X ns per evaluation"
        own = re.search(r"time ([\d.]+) ms", done.stderr)
        return {"steps": int(found[1]), "rejected": int(found[2]),
                "evaluations": int(found[3]), "own": float(own[1]) / 1e3}
    found = re.search(r"steps: (\d+) accepted, (\d+) rejected, (\d+) retried; (\d+) force",
                      done.stdout)
    return {"steps": int(found[1]), "rejected": int(found[2]) + int(found[3]),
            "evaluations": int(found[4])}


def timed(cmd: list[str]) -> tuple[float, float, subprocess.CompletedProcess]:
    """A whole process: wall time, CPU time (user + system) and what it printed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, check=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), done


def error(path: Path, reference: np.ndarray) -> float:
    values = np.loadtxt(path, delimiter=",", skiprows=1)
    n = min(len(values), len(reference))
    assert np.allclose(values[:n, 0], reference[:n, 0])
    return float(np.max(np.abs(values[:n, 1:5] - reference[:n, 1:5])))


def load() -> str:
    return "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


# ---- instructions (callgrind) ----------------------------------------------------------------

def callgrind(cmd: list[str], folder: Path, name: str) -> tuple[dict, dict] | None:
    """Inclusive instructions and calls per function of one run under callgrind; None without
    valgrind."""
    if shutil.which("valgrind") is None or shutil.which("callgrind_annotate") is None:
        return None
    out = folder / f"callgrind.{name}"
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", *cmd],
                   check=True, capture_output=True)
    text = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--tree=calling",
                           "--threshold=100", str(out)], check=True, capture_output=True,
                          text=True).stdout
    inclusive, calls = {}, {}
    for line in text.splitlines():
        found = re.match(r"\s*([\d,]+) \([\s\d.]+%\)\s+([*>])\s+(\S+)(?: \(([\d,]+)x\))?", line)
        if not found:
            continue
        value, kind, where, called = found.groups()
        function = where.rsplit(":", 1)[-1]
        value = int(value.replace(",", ""))
        if kind == "*":
            inclusive[function] = max(inclusive.get(function, 0), value)
        elif called:
            calls[function] = calls.get(function, 0) + int(called.replace(",", ""))
    total = max(inclusive.values())
    inclusive["TOTAL"] = total
    return inclusive, calls


# The method's parts in depsim's run (docs/method.md, 2-4), by the core's functions. A part
# not found (the core renamed it) prints as such.
PARTS = [
    ("the step (dep_run_step: every trial step)", "dep_run_step"),
    ("  multiplier passes (dep_iterate_multipliers)", "dep_iterate_multipliers"),
    ("    position pass (measure_position)", "measure_position"),
    ("      DOPRI integrations (dep_dopri_step)", "dep_dopri_step"),
    ("        right sides (dep_stepper_rhs)", "dep_stepper_rhs"),
    ("        stage sums (combine)", "combine"),
    ("    velocity pass (measure_velocity)", "measure_velocity"),
    ("    acceleration pass (measure_acceleration)", "measure_acceleration"),
    ("    Schur solves and forms (step_for)", "step_for"),
    ("  friction end values (dep_stepper_friction_settled)", "dep_stepper_friction_settled"),
    ("  acceleration at the end (dep_acceleration)", "dep_acceleration"),
    ("tangential error projections (dep_stepper_tangential)", "dep_stepper_tangential"),
    ("step factor (dep_step_factor)", "dep_step_factor"),
    ("after each step: events, loads (dep_run_after_step)", "dep_run_after_step"),
]


def profile(depsim_cg: tuple[dict, dict], evaluations: int, trials: int) -> None:
    inclusive, calls = depsim_cg
    total = inclusive["TOTAL"]
    print(f"\ndepsim's run by the method's parts (callgrind, no rows; inclusive instructions; "
          f"{trials} trial steps, {evaluations} evaluations)")
    print(f"{'part':<58} {'share':>6} {'calls':>7} {'per call':>9} {'per trial':>10}")
    for label, function in PARTS:
        if function not in inclusive:
            print(f"{label:<58} {'not found':>6}")
            continue
        value, n = inclusive[function], calls.get(function, 0)
        per_call = f"{value / n:9.0f}" if n else f"{'':>9}"
        print(f"{label:<58} {100 * value / total:5.1f}% {n:>7} {per_call} "
              f"{value / trials:10.0f}")
    print(f"{'the whole process':<58} {100.0:5.1f}% {'':>7} {'':>9} {total / trials:10.0f}")


# ---- the comparison ------------------------------------------------------------------------

def compare(hand: Path, program: Path, timed_program: Path | None, tol: float, repeat: int,
            folder: Path, reference: np.ndarray, with_profile: bool) -> None:
    solvers = {"depsim": program, "baseline": hand}
    kinds = {"bare": {"dt_out": T_END}, "rows": {"dt_out": 0.05},
             "fixed": {"t_end": 1e-3, "dt_out": 1e-3}}
    jobs = [(s, k) for s in solvers for k in kinds]
    if timed_program is not None:
        solvers["depsim, right side timed"] = timed_program
        jobs.append(("depsim, right side timed", "bare"))
    walls = {job: [] for job in jobs}
    cpus = {job: [] for job in jobs}
    info, own, rhs_timed = {}, [], []
    print(f"\nINTELSAT V, 0-70 s, tol {tol:g}: {repeat} rounds of whole processes, interleaved "
          f"(before: {load()})")
    for name in ("depsim", "baseline"):  # once untimed: the counts, the rows' error
        done = subprocess.run(command(solvers[name], tol, folder / f"{name}.csv"),
                              capture_output=True, text=True, check=True)
        info[name] = counts(done)
        info[name]["error"] = error(folder / f"{name}.csv", reference)
    for r in range(repeat):
        for name, kind in jobs[r % len(jobs):] + jobs[:r % len(jobs)]:
            settings = kinds[kind]
            cmd = command(solvers[name], tol, folder / "timed.csv",
                          t_end=settings.get("t_end", T_END), dt_out=settings["dt_out"])
            wall, used, done = timed(cmd)
            walls[(name, kind)].append(wall)
            cpus[(name, kind)].append(used)
            if name == "baseline" and kind == "bare":
                own.append(counts(done)["own"])
            elif name == "depsim, right side timed":
                rhs_timed.append(float(re.search(r"rhs_timer \d+ calls ([\d.]+) ns",
                                                 done.stderr)[1]))
    after = load()
    in_run, in_loop = [], []
    for _ in range(5):  # the baseline's right side alone, each of these ~0.3 s
        done = subprocess.run([*command(hand, tol, folder / "loop.csv", dt_out=T_END),
                               "--time-rhs"], capture_output=True, text=True, check=True)
        in_run.append(float(re.search(r"rhs in the run ([\d.]+) ns", done.stderr)[1]))
        in_loop.append(float(re.search(r"rhs in a loop ([\d.]+) ns", done.stderr)[1]))
    in_run_ns, loop_ns = statistics.median(in_run), statistics.median(in_loop)
    med = {job: statistics.median(v) for job, v in walls.items()}
    cpu = {job: statistics.median(v) for job, v in cpus.items()}
    d, b = info["depsim"], info["baseline"]

    def ms(name: str, kind: str, of: dict = med) -> float:
        return 1e3 * of[(name, kind)]

    def ns(name: str, of: dict = med) -> float:
        return 1e6 * (ms(name, "bare", of) - ms(name, "fixed", of)) / info[name]["evaluations"]

    rows = []
    for label, kind in (("no rows (--dt-out 70)", "bare"), ("rows every 0.05 s", "rows"),
                        ("fixed cost (a run to t = 1 ms)", "fixed")):
        rows += [(f"wall, {label}", "ms", ms("depsim", kind), ms("baseline", kind), ".2f"),
                 (f"CPU, {label}", "ms", ms("depsim", kind, cpu), ms("baseline", kind, cpu),
                  ".2f")]
    rows += [
        ("CPU, no rows less the fixed cost", "ms",
         ms("depsim", "bare", cpu) - ms("depsim", "fixed", cpu),
         ms("baseline", "bare", cpu) - ms("baseline", "fixed", cpu), ".2f"),
        ("steps accepted", "", d["steps"], b["steps"], "d"),
        ("steps rejected (+ retried)", "", d["rejected"], b["rejected"], "d"),
        ("right-side evaluations", "", d["evaluations"], b["evaluations"], "d"),
        ("evaluations per trial step", "", d["evaluations"] / (d["steps"] + d["rejected"]),
         b["evaluations"] / (b["steps"] + b["rejected"]), ".2f"),
        ("ns per evaluation (wall, less fixed)", "ns", ns("depsim"), ns("baseline"), ".0f"),
        ("ns per evaluation (CPU, less fixed)", "ns", ns("depsim", cpu), ns("baseline", cpu),
         ".0f"),
    ]
    if rhs_timed:
        rows.append(("ns per right side alone (in the run)", "ns", statistics.median(rhs_timed),
                     in_run_ns, ".0f"))
    rows.append(("error against the reference", "rad", d["error"], b["error"], ".2e"))
    print(f"{'':<40} {'':>4} {'depsim':>10} {'baseline':>10} {'depsim/base':>12}")
    for label, unit, x, y, spec in rows:
        ratio = f"{x / y:11.2f}x" if y else ""
        print(f"{label:<40} {unit:>4} {x:>10{spec}} {y:>10{spec}} {ratio}")
    print(f"right side alone: each call between two clock readings in a run, one reading's "
          f"cost taken off (depsim: its program linked with a wrapper of dep_stepper_rhs; the "
          f"baseline: --time-rhs, whose loop over its run's states gives {loop_ns:.0f} ns)"
          if rhs_timed else "right side alone: depsim's not timed (no ld --wrap here)")
    print(f"the baseline's run timed inside its process: {1e3 * statistics.median(own):.2f} ms "
          f"= {1e9 * statistics.median(own) / b['evaluations']:.0f} ns per evaluation, step "
          f"control included")
    print(f"headline, no rows: depsim/baseline {ms('depsim', 'bare') / ms('baseline', 'bare'):.2f}x"
          f" the wall time ({ms('depsim', 'bare', cpu) / ms('baseline', 'bare', cpu):.2f}x the "
          f"CPU time) = {d['steps'] / b['steps']:.2f}x the steps, "
          f"{d['evaluations'] / b['evaluations']:.2f}x the evaluations, "
          f"{ns('depsim', cpu) / ns('baseline', cpu):.2f}x the CPU time per evaluation "
          f"(after: {after})")
    bare = {name: command(solvers[name], tol, folder / f"cg_{name}.csv", dt_out=T_END)
            for name in ("depsim", "baseline")}
    depsim_cg = callgrind(bare["depsim"], folder, "depsim")
    hand_cg = callgrind(bare["baseline"], folder, "baseline")
    if depsim_cg is None or hand_cg is None:
        print("instructions per evaluation: valgrind not found, skipped")
        return
    rhs = {"depsim": depsim_cg[0].get("dep_stepper_rhs"), "baseline": hand_cg[0].get("rhs")}
    total = {"depsim": depsim_cg[0]["TOTAL"], "baseline": hand_cg[0]["TOTAL"]}
    print(f"instructions per evaluation (callgrind, no rows): whole process "
          f"{total['depsim'] / d['evaluations']:.0f} depsim, "
          f"{total['baseline'] / b['evaluations']:.0f} baseline "
          f"({total['depsim'] / total['baseline']:.1f}x the instructions); right side "
          + ", ".join(f"{rhs[n] / info[n]['evaluations']:.0f} {n}" if rhs[n] else f"n/a {n}"
                      for n in ("depsim", "baseline")))
    if rhs["depsim"]:
        share = rhs["depsim"] / total["depsim"]
        rest = (1 - share) * total["depsim"] / d["steps"]
        print(f"depsim's right sides are {100 * share:.1f} % of its instructions; the rest, "
              f"the method's passes and bookkeeping, {rest:.0f} instructions per accepted step "
              f"(the baseline's whole run: {total['baseline'] / b['steps']:.0f})")
    if with_profile:
        profile(depsim_cg, d["evaluations"], d["steps"] + d["rejected"])


# depsim's tolerances tried for the comparison at equal accuracy, as multiples of the
# baseline's tol.
LADDER = (1.0, 1.5, 2.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 30.0)


def equal_accuracy(hand: Path, program: Path, tol: float, repeat: int, folder: Path,
                   reference: np.ndarray) -> None:
    """depsim at the loosest tol on LADDER x tol whose error is within the baseline's at tol,
    against the baseline at tol: the comparison at equal or better accuracy. The
    errors (rows every 0.05 s) are deterministic; the times are medians of interleaved whole
    processes without rows."""
    done = subprocess.run(command(hand, tol, folder / "eq_base.csv"), capture_output=True,
                          text=True, check=True)
    base = counts(done)
    base["error"] = error(folder / "eq_base.csv", reference)
    print(f"\nAt equal accuracy: the baseline at tol {tol:g} (error {base['error']:.2e} rad) "
          f"against depsim at the loosest tol whose error is no larger")
    print(f"{'depsim tol':>11} {'error rad':>10} {'steps':>6} {'evaluations':>12}")
    chosen = None
    for factor in LADDER:
        t = tol * factor
        done = subprocess.run(command(program, t, folder / "eq_depsim.csv"),
                              capture_output=True, text=True, check=True)
        found = counts(done)
        found["error"] = error(folder / "eq_depsim.csv", reference)
        meets = found["error"] <= base["error"]
        print(f"{t:>11.3g} {found['error']:>10.2e} {found['steps']:>6} "
              f"{found['evaluations']:>12} {'within' if meets else 'larger'}")
        if meets:
            chosen = (t, found)
    if chosen is None:
        print("no tol on the ladder is as accurate as the baseline: no comparison")
        return
    t, found = chosen
    jobs = [("depsim", command(program, t, folder / "timed.csv", dt_out=T_END)),
            ("baseline", command(hand, tol, folder / "timed.csv", dt_out=T_END))]
    walls, cpus = {n: [] for n, _ in jobs}, {n: [] for n, _ in jobs}
    for r in range(repeat):
        for name, cmd in jobs[r % 2:] + jobs[:r % 2]:
            wall, used, _ = timed(cmd)
            walls[name].append(wall)
            cpus[name].append(used)
    w = {n: 1e3 * statistics.median(v) for n, v in walls.items()}
    c = {n: 1e3 * statistics.median(v) for n, v in cpus.items()}
    print(f"depsim at tol {t:g} ({found['steps']} steps, {found['evaluations']} evaluations, "
          f"{found['error']:.2e} rad) against the baseline at {tol:g} ({base['steps']} steps, "
          f"{base['evaluations']} evaluations, {base['error']:.2e} rad), no rows, {repeat} "
          f"rounds: wall {w['depsim']:.2f} / {w['baseline']:.2f} ms = "
          f"{w['depsim'] / w['baseline']:.2f}x, CPU {c['depsim']:.2f} / {c['baseline']:.2f} ms "
          f"= {c['depsim'] / c['baseline']:.2f}x ({load()})")


def study(runs: int, folder: Path) -> None:
    cmd = [*DEPSIM, "sweep", str(ROOT / "examples" / "intelsat5.dep"), "--runs", str(runs),
           "--seed", "1", "--t-end", "70", "-o", str(folder / "study.nc")]
    for item in SAMPLES:
        cmd += ["--sample", item]
    start = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    wall = time.perf_counter() - start
    print(f"\ndepsim sweep, {runs} runs of 0-70 s, whole command on this machine: {wall:.1f} s "
          f"= {runs / wall:.1f} runs/s")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tol", type=float, action="append", help="tolerances (1e-8)")
    parser.add_argument("--repeat", type=int, default=21, help="rounds (medians)")
    parser.add_argument("--runs", type=int, default=1000, help="study runs (0: no study)")
    parser.add_argument("--profile", action="store_true",
                        help="depsim's run by the method's parts (callgrind)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        hand, program, timed_program = build(folder)
        subprocess.run(command(hand, 1e-13, folder / "reference.csv"), check=True,
                       capture_output=True)
        reference = np.loadtxt(folder / "reference.csv", delimiter=",", skiprows=1)
        for tol in args.tol or [1e-8]:
            compare(hand, program, timed_program, tol, args.repeat, folder, reference,
                    args.profile)
            equal_accuracy(hand, program, tol, args.repeat, folder, reference)
        if args.runs:
            study(args.runs, folder)
    return 0


if __name__ == "__main__":
    sys.exit(main())
