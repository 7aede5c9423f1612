"""two_link_flex, 0-5 s, against Exudyn side by side at issue 36's accuracy bar.

Each solver's settings, their wall and CPU times and their errors against the converged
64-element reference, which meet the bar, and each solver's fastest that does.

    .venv/bin/python bench/bench_exudyn.py             # the full sweep, 3 rounds
    .venv/bin/python bench/bench_exudyn.py --quick     # the finalists (a couple of minutes)
    .venv/bin/python bench/bench_exudyn.py --profile   # and where depsim's time goes

The accuracy bar (issue 36): chord2 within 2e-5 rad, tip2 within 1e-4 m raw and within 1e-5 m
low-passed at 60 Hz (bench_beams.low_passed), largest differences over the 5 s on the
reference's 0.5 ms grid. The reference is depsim's 64-element run, linearly implicit at tol
1e-9 (bench/beam_reference.py; docs/beams.md says how far it is converged), computed once
(about 2-4 minutes) and kept in the bench's folder, $TMPDIR/depsim_bench_exudyn.

* Exudyn (only when installed: `pip install exudyn`, 1.13.x; not a dependency of depsim):
  bench/exudyn_two_link_flex.py, ANCFCable2D elements, generalized-alpha at fixed steps,
  modified Newton, Eigen's sparse LU, in a process of its own per run. "solve" is
  mbs.SolveDynamic alone; "process" the whole Python process (start, import, build, solve,
  writing link 2's recorded nodes). Link 2's end nodes are recorded every 0.5 ms (at the
  first step at or after each multiple) and interpolated (cubic Hermite in coordinates and
  velocities) onto the reference's grid.
* depsim: its standalone program (`depsim compile --target c`, `make`), outputs every 0.5
  ms to a CSV. "process" is the whole process; "solve" is dep_simulate (setup and
  integration, no writing), timed by a wrapper linked in (ld --wrap: two clock readings).
* --profile: depsim's fastest setting that meets the bar under callgrind, by the method's
  parts (bench/beam_callgrind.py).

Every round runs each setting once, in an order that turns from round to round (the
machine's cores are shared). The times are medians over the rounds: a setting that misses
the bar runs in the first round only. Wall and CPU (user + system) times are both printed;
with other work on the machine the CPU times are the steadier.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from beam_callgrind import profile
from bench_beams import LOW_PASS, low_passed

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "examples" / "two_link_flex.dep"
EXUDYN = ROOT / "bench" / "exudyn_two_link_flex.py"
CACHE = Path(tempfile.gettempdir()) / "depsim_bench_exudyn"
T_END, DT_OUT = 5.0, 5e-4
TIMEOUT = 300.0  # s of wall time: a run that takes longer is reported as failed
BAR = (2e-5, 1e-4, 1e-5)  # chord2 rad, tip2 m, tip2 low-passed m
REFERENCE = {"elements": 64, "tol": 1e-9}

# The sweep: Exudyn at 4, 8 and 16 elements per link over the step sizes (rho 0.9, Newton to
# 1e-6, the fast module), and at 8 elements, where it is fastest for the bar, over Newton's
# tolerance (its default 1e-8 among them), rho, and the standard module at the issue's
# setting. (At 16 elements Newton's default 1e-8 is below what round-off lets the residual
# reach: the steps fail and shrink, and a run at h = 5e-5 had not ended after 8 CPU minutes.)
# depsim at 4, 8, 12 and 16 elements over tolerances around the model's (1e-8).
STEPS = (5e-5, 1e-4, 1.25e-4, 1.6e-4, 2e-4, 2.5e-4, 5e-4)
NEAR = (1e-4, 1.25e-4, 1.6e-4, 2e-4)  # the step sizes about where 8 elements meet the bar
EXUDYN_SWEEP = (  # (elements, h, rho, Newton relative tolerance, fast module)
    [(n, h, 0.9, 1e-6, True) for n in (4, 8, 16) for h in STEPS]
    + [(8, h, 0.9, rtol, True) for rtol in (1e-8, 1e-5, 1e-4) for h in NEAR]
    + [(8, h, rho, 1e-6, True) for rho in (0.6, 0.99) for h in NEAR]
    + [(16, h, 0.9, 1e-5, True) for h in (5e-5, 1e-4)]
    + [(8, h, 0.9, 1e-8, False) for h in NEAR])
DEPSIM_SWEEP = ([(n, tol) for n in (4, 8, 16) for tol in (1e-7, 5e-8, 3e-8, 2e-8, 1e-8, 3e-9)]
                + [(12, tol) for tol in (3e-8, 1e-8)])
# --quick: the setting, the fastest that met the bar in the full sweep and the next
# step size up (which missed it), for each solver
QUICK_EXUDYN = [(8, 1e-4, 0.9, 1e-8, False), (8, 1e-4, 0.9, 1e-4, True),
                (8, 1.25e-4, 0.9, 1e-5, True), (8, 1.6e-4, 0.9, 1e-5, True)]
QUICK_DEPSIM = [(8, 1e-8), (16, 1e-8), (8, 3e-8), (8, 1e-7)]

# dep_simulate timed inside the program: ld --wrap, two clock readings of each kind
SIM_TIMER = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <time.h>
#include "core/include/depsim.h"
int __real_dep_simulate(const dep_model *, const double *, const dep_settings *,
                        const dep_event *, int, dep_result *, dep_error *);
static double seconds(clockid_t clock)
{
    struct timespec ts;
    clock_gettime(clock, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}
int __wrap_dep_simulate(const dep_model *m, const double *p, const dep_settings *s,
                        const dep_event *e, int n, dep_result *r, dep_error *err)
{
    double wall = seconds(CLOCK_MONOTONIC), cpu = seconds(CLOCK_PROCESS_CPUTIME_ID);
    int status = __real_dep_simulate(m, p, s, e, n, r, err);
    fprintf(stderr, "dep_simulate wall %.6f cpu %.6f\n", seconds(CLOCK_MONOTONIC) - wall,
            seconds(CLOCK_PROCESS_CPUTIME_ID) - cpu);
    return status;
}
"""


@dataclass
class Setting:
    """One solver setting, its runs' times and its errors."""

    solver: str  # "Exudyn" or "depsim"
    elements: int
    options: dict
    walls: list = field(default_factory=list)  # whole process
    cpus: list = field(default_factory=list)
    solves: list = field(default_factory=list)  # the solve alone (wall)
    solve_cpus: list = field(default_factory=list)
    counts: str = ""
    errors: tuple | None = None  # chord2, tip2, tip2 low-passed; None: the run failed

    @property
    def label(self) -> str:
        if self.solver == "Exudyn":
            o = self.options
            return (f"h = {o['h']:g}, rho {o['rho']:g}, Newton rtol {o['newton_rtol']:g}"
                    + (", fast module" if o["fast"] else ""))
        return f"tol {self.options['tol']:g}"

    @property
    def meets(self) -> bool:
        return self.errors is not None and all(e <= b for e, b in zip(self.errors, BAR))


# ---- the reference and the errors ------------------------------------------------------------

def reference() -> dict:
    """The 64-element reference (times, chord2, tip2), computed once into CACHE."""
    path = CACHE / "two_link_flex_ref{elements}_tol{tol:g}.npz".format(**REFERENCE)
    if not path.exists():
        print(f"computing the reference ({REFERENCE['elements']} elements, linearly implicit, "
              f"tol {REFERENCE['tol']:g}; a few minutes, once) -> {path}", flush=True)
        subprocess.run([sys.executable, str(ROOT / "bench" / "beam_reference.py"),
                        "--elements", str(REFERENCE["elements"]), "--solver", "implicit",
                        "--tol", repr(REFERENCE["tol"]), "--t-end", repr(T_END),
                        "--dt-out", repr(DT_OUT), "--out", str(path)], check=True)
    with np.load(path) as data:
        return {key: data[key] for key in ("times", "chord2", "tip2")}


def errors(chord2: np.ndarray, tip2: np.ndarray, ref: dict) -> tuple[float, float, float]:
    """Largest differences from the reference on its grid: chord2, tip2, tip2 low-passed."""
    return (float(np.max(np.abs(chord2 - ref["chord2"]))),
            float(np.max(np.abs(tip2 - ref["tip2"]))),
            float(np.max(np.abs(low_passed(tip2, DT_OUT) - low_passed(ref["tip2"], DT_OUT)))))


def exudyn_outputs(path: Path, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """chord2 and tip2 at `times` from an Exudyn run's recorded nodes (link 2's base and tip:
    displacements from the reference coordinates, and velocities, at every step)."""
    with np.load(path) as data:
        nodes = []
        for k in (0, 1):
            coordinates, velocities = data[f"s{2 * k}"], data[f"s{2 * k + 1}"]
            t, first = np.unique(coordinates[:, 0], return_index=True)
            q = coordinates[first, 1:5] + data[f"r{k}"]
            nodes.append(CubicHermiteSpline(t, q, velocities[first, 1:5], axis=0)(times))
    base, tip = nodes
    chord = tip[:, :2] - base[:, :2]
    tangent = base[:, 2:4] / np.linalg.norm(base[:, 2:4], axis=1)[:, None]
    return (np.arctan2(chord[:, 0], -chord[:, 1]),  # from -y, counter-clockwise
            tangent[:, 0] * chord[:, 1] - tangent[:, 1] * chord[:, 0])


def depsim_outputs(path: Path, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    values = np.loadtxt(path, delimiter=",", skiprows=1)
    assert len(values) == len(times) and np.allclose(values[:, 0], times)
    return values[:, 1], values[:, 2]


# ---- the runs --------------------------------------------------------------------------------

def build_depsim(elements: int, folder: Path) -> Path:
    """The standalone program for `elements` per link, with SIM_TIMER linked in."""
    out = folder / f"depsim{elements}"
    subprocess.run([sys.executable, "-m", "depsim", "compile", str(MODEL), "--target", "c",
                    "-o", str(out), "--elements", f"link1={elements},link2={elements}"],
                   check=True, capture_output=True)
    (out / "sim_timer.c").write_text(SIM_TIMER)
    subprocess.run(["make", "-s", "-j2", "-C", str(out), "two_link_flex",
                    "LDLIBS=sim_timer.c -Wl,--wrap=dep_simulate -lm"], check=True)
    return out / "two_link_flex"


def timed(cmd: list[str]) -> tuple[float, float, subprocess.CompletedProcess]:
    """A whole process: wall time, CPU time (user + system) and what it printed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        done = subprocess.CompletedProcess(cmd, -1, "", f"no end after {TIMEOUT:g} s")
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), done


def run_once(setting: Setting, programs: dict, folder: Path, ref: dict, first: bool) -> None:
    """Run `setting` once; record its times and, in the first round, its errors."""
    o = setting.options
    if setting.solver == "Exudyn":
        out = folder / "exudyn.npz"
        cmd = [sys.executable, str(EXUDYN), "--elements", str(setting.elements), "--h",
               repr(o["h"]), "--rho", repr(o["rho"]), "--newton-rtol", repr(o["newton_rtol"]),
               "--t-end", repr(T_END), "--out", str(out)] + (["--fast"] if o["fast"] else [])
    else:
        out = folder / "depsim.csv"
        cmd = [str(programs[setting.elements]), "--tol", repr(o["tol"]), "--dt-out",
               repr(DT_OUT), "--max-steps", "1e8", "-o", str(out)]
    wall, cpu, done = timed(cmd)
    if setting.solver == "Exudyn":
        found = dict(re.findall(r"(\w+)=(\S+)", done.stdout))
        ok = done.returncode == 0 and found.get("ok") == "True"
        solve, solve_cpu = float(found.get("solve", "nan")), float(found.get("solve_cpu", "nan"))
        setting.counts = (f"{found.get('steps')} steps, {found.get('newton')} Newton, "
                          f"{found.get('jacobians')} Jacobians")
    else:
        found = re.search(r"dep_simulate wall (\S+) cpu (\S+)", done.stderr)
        ok = done.returncode == 0 and found is not None
        solve, solve_cpu = (float(found[1]), float(found[2])) if found else (np.nan, np.nan)
        steps = re.search(r"steps: (\d+) accepted, (\d+) rejected, (\d+) retried; (\d+) force",
                          done.stdout)
        if steps:
            setting.counts = f"{steps[1]} steps, {steps[4]} force evaluations"
    if not ok:
        setting.errors = None
        setting.counts = "failed: " + (done.stderr.strip().splitlines() or ["?"])[-1][:60]
        return
    setting.walls.append(wall)
    setting.cpus.append(cpu)
    setting.solves.append(solve)
    setting.solve_cpus.append(solve_cpu)
    if first:
        outputs = (exudyn_outputs if setting.solver == "Exudyn" else depsim_outputs)(
            out, ref["times"])
        setting.errors = errors(*outputs, ref)


def interleave(settings: list[Setting]) -> list[Setting]:
    """The settings with the two solvers' runs spread evenly through each other."""
    groups = [[s for s in settings if s.solver == solver] for solver in ("depsim", "Exudyn")]
    keyed = [((k + 0.5) / len(group), s) for group in groups for k, s in enumerate(group)]
    return [s for _, s in sorted(keyed, key=lambda pair: pair[0])]


def sweep(settings: list[Setting], programs: dict, folder: Path, ref: dict,
          rounds: int) -> None:
    """`rounds` rounds over the settings, each in an order turned by the round; after the
    first, only the settings that meet the bar."""
    for r in range(rounds):
        todo = interleave(settings if r == 0 else [s for s in settings if s.meets])
        shift = (r * len(todo)) // max(rounds, 1)
        for k, setting in enumerate(todo[shift:] + todo[:shift]):
            run_once(setting, programs, folder, ref, first=(r == 0))
            if r == 0:
                e = setting.errors
                shown = "failed" if e is None else (
                    f"{e[0]:.1e} rad, {e[1]:.1e} m, {e[2]:.1e} m"
                    f"{', meets the bar' if setting.meets else ''}")
                print(f"  {setting.solver} {setting.elements} elements, {setting.label}: "
                      f"{setting.walls[-1] if setting.walls else float('nan'):.2f} s; {shown}",
                      flush=True)
        print(f"round {r + 1} of {rounds} done ({load()})", flush=True)


# ---- printing --------------------------------------------------------------------------------

def load() -> str:
    return "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


def median(values: list) -> float:
    return statistics.median(values) if values else float("nan")


def table(settings: list[Setting]) -> str:
    lines = ["| solver | elements/link | setting | solve s (CPU) | process s (CPU) | runs "
             "| chord2 rad | tip2 m | tip2 low-passed m | bar | counts |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in settings:
        e = s.errors or (np.nan,) * 3
        lines.append(
            f"| {s.solver} | {s.elements} | {s.label} | {median(s.solves):.3f} "
            f"({median(s.solve_cpus):.3f}) | {median(s.walls):.3f} ({median(s.cpus):.3f}) "
            f"| {len(s.walls)} | {e[0]:.1e} | {e[1]:.1e} | {e[2]:.1e} "
            f"| {'yes' if s.meets else 'no'} | {s.counts} |")
    return "\n".join(lines)


def fastest(settings: list[Setting], solver: str, key: str) -> Setting | None:
    meeting = [s for s in settings if s.solver == solver and s.meets]
    return min(meeting, key=lambda s: median(getattr(s, key))) if meeting else None


MEASURES = {"solves": "solve alone, wall", "walls": "whole process, wall",
            "solve_cpus": "solve alone, CPU", "cpus": "whole process, CPU"}


def summary(settings: list[Setting]) -> None:
    """Each solver's fastest setting that meets the bar by each measure, and the ratios."""
    for solver in ("Exudyn", "depsim"):
        if not any(s.solver == solver for s in settings):
            print(f"{solver}: not run")
            continue
        for key, what in MEASURES.items():
            best = fastest(settings, solver, key)
            print(f"{solver}'s fastest setting that meets the bar by {what}: " + (
                "none" if best is None else
                f"{best.elements} elements, {best.label}: {median(getattr(best, key)):.3f} s"))
    pairs = [("depsim's whole process / Exudyn's solve alone, wall (the issue's comparison)",
              "walls", "solves"),
             ("the same in CPU time", "cpus", "solve_cpus"),
             ("depsim's solve / Exudyn's solve, wall", "solves", "solves"),
             ("the same in CPU time", "solve_cpus", "solve_cpus"),
             ("whole process / whole process, wall", "walls", "walls"),
             ("the same in CPU time", "cpus", "cpus")]
    for what, ours, theirs in pairs:
        d, x = fastest(settings, "depsim", ours), fastest(settings, "Exudyn", theirs)
        if d is None or x is None:
            continue
        ratio = median(getattr(d, ours)) / median(getattr(x, theirs))
        print(f"{what}: depsim / Exudyn = {ratio:.2f} ({1 / ratio:.1f}x faster; the goal is "
              f"5x)")


# ---- the bench -------------------------------------------------------------------------------

def exudyn_installed() -> bool:
    return importlib.util.find_spec("exudyn") is not None


def plan(quick: bool, with_exudyn: bool) -> list[Setting]:
    exudyn, depsim = (QUICK_EXUDYN, QUICK_DEPSIM) if quick else (EXUDYN_SWEEP, DEPSIM_SWEEP)
    settings = [Setting("depsim", n, {"tol": tol}) for n, tol in depsim]
    if with_exudyn:
        settings += [Setting("Exudyn", n, {"h": h, "rho": rho, "newton_rtol": rtol,
                                           "fast": fast})
                     for n, h, rho, rtol, fast in exudyn]
    return settings


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="the finalists of the full sweep only (QUICK_*)")
    parser.add_argument("--rounds", type=int, default=3,
                        help="rounds: the first runs every setting, the later ones those that "
                             "meet the bar")
    parser.add_argument("--profile", action="store_true",
                        help="callgrind on depsim's fastest setting that meets the bar (by "
                             "CPU time; a few minutes)")
    parser.add_argument("--no-exudyn", action="store_true", help="depsim alone")
    args = parser.parse_args(argv)
    print(f"two_link_flex, 0-{T_END:g} s, against Exudyn; {os.cpu_count()} cores, {load()}")
    with_exudyn = exudyn_installed() and not args.no_exudyn
    if not with_exudyn:
        print("Exudyn is not installed (pip install exudyn, 1.13.x): depsim alone" if
              not exudyn_installed() else "Exudyn left out (--no-exudyn): depsim alone")
    else:
        import exudyn
        print(f"Exudyn {exudyn.__version__}: the element against beam theory")
        done = subprocess.run([sys.executable, str(EXUDYN), "--check"], capture_output=True,
                              text=True, check=True)
        print(done.stdout.rstrip())
    CACHE.mkdir(parents=True, exist_ok=True)
    ref = reference()
    settings = plan(args.quick, with_exudyn)
    with tempfile.TemporaryDirectory(dir=CACHE) as tmp:
        folder = Path(tmp)
        programs = {n: build_depsim(n, folder) for n in sorted({s.elements for s in settings
                                                               if s.solver == "depsim"})}
        sweep(settings, programs, folder, ref, args.rounds)
        print(f"\ntwo_link_flex, 0-{T_END:g} s, outputs every {DT_OUT * 1e3:g} ms, errors "
              f"against the {REFERENCE['elements']}-element reference; the bar: chord2 "
              f"{BAR[0]:g} rad, tip2 {BAR[1]:g} m, tip2 low-passed ({LOW_PASS:g} Hz) "
              f"{BAR[2]:g} m; medians over the runs ({load()})\n")
        print(table(settings))
        print()
        summary(settings)
        best = fastest(settings, "depsim", "cpus")  # the steadier measure on a shared machine
        if args.profile and best is not None:
            steps = int(re.search(r"(\d+) steps", best.counts)[1])
            profile([str(programs[best.elements]), "--tol", repr(best.options["tol"]),
                     "--dt-out", repr(DT_OUT), "--max-steps", "1e8", "-o",
                     str(folder / "profile.csv")], folder, steps)
    return 0


if __name__ == "__main__":
    sys.exit(main())
