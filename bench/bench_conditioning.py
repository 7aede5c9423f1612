"""Conditioning and rank: hanging chains of many short bars, and chains of parallelograms
that pass through a singular position, on depsim's standalone C program.

    .venv/bin/python bench/bench_conditioning.py --quick          # a few minutes
    .venv/bin/python bench/bench_conditioning.py                  # both full tables
    .venv/bin/python bench/bench_conditioning.py --part chains --sizes 100,300 --tols 1e-6,1e-8
    .venv/bin/python bench/bench_conditioning.py --part parallelograms --counts 1,2 --t-end 5
    .venv/bin/python bench/bench_conditioning.py --part parallelograms --releases 5,10,20,30
    .venv/bin/python bench/bench_conditioning.py --build /tmp/cond   # keep the built programs

Chains: N bars hinged end to end, the first pinned to the ground origin, undamped, in gravity
(0, -9.81), released straight at 45 deg from the vertical (h1 = 45 deg, the other hinges 0),
0-2 s. Every bar has length L and mass m = 1/N kg (the chain's total mass is 1 kg whatever L),
inertia m L^2 / 12; L and m are parameters, so one program per N serves every length
(`--set L=... --set m=...`). The lengths are 1/N m (the uniform chain of total length 1 m)
and the bars of 1 mm, 1 cm and 0.1 m (`--lengths`; 1/N is left out where it repeats one).
Short bars make the mass matrix's entries small against the constraints' and the chain's
fastest modes fast: the conditioning the chain tests. Printed per case: completed, or the first
line of the failure, or a timeout; the steps accepted, rejected and retried; the wall time of
the whole process (median of --repeat; a run longer than --repeat-below seconds is timed once);
that time per accepted step divided by N (a per-step cost of O(N) shows as a constant column);
and the energy check, max |E(t) - E(0)| / max KE / tol over the output times, E = kinetic +
gravity. The standalone program has no JSON summary and depsim's summary holds no energies,
so the models output their kinetic and gravity energies (`output kinetic`, `output potential`,
sums over the bars) and the check reads them from the CSV. There is no reference solution for
the chains: the energy is the check.

Parallelograms: N four-bar parallelograms sharing their cranks: cranks c0..cN pinned to the
ground at x = 0, 1, ..., N, couplers k1..kN joining the tips of cranks i-1 and i; all links
1 m, 1 kg (inertia 1/12 kg m^2), gravity, one degree of freedom; released at rest with the
crank 10 deg above the horizontal (--releases: other angles, `--set g0.initial_angle`), 0-20 s. The cranks swing through the horizontal, the
singular position: there every crank and coupler lies on the line of the ground pivots, Phi_q
loses rank (the constraints no longer fix the motion along that line to first order, and the
parallelogram branch crosses the folded, anti-parallelogram one), so the reactions along the
line are not determined by the constraints alone. The reference is the one-angle ODE
I_eff theta'' = -dV/dtheta, I_eff = (N+1) m L^2/3 + N m L^2, V = ((N+1) m g L/2 + N m g L)
sin(theta), theta the crank angle from the horizontal, integrated with scipy's DOP853 at rtol
1e-13, atol 1e-14. Printed per case: completed or the failure; steps; the largest error of the
first crank's tip position and velocity (m, m/s) against the reference over the output times,
absolute and divided by tol; the energy drift (all bars' kinetic + gravity, from the CSV) over
the largest kinetic energy, divided by tol; the wall time (median as for the chains). With
several release angles, each N and tol also gets the errors' median and largest over them and
how many runs kept both within 10 tol: the errors are phase errors, and one release is one
draw of how they scatter with the crossings' step sequence.

Beside each chain, two runs of the same motion without a singular position, which tell what
the singular positions cost from what any integration at that tol leaves over 20 s:
- "pendulum": one body on one hinge whose angle obeys the chain's one-angle ODE (mass
  (3N+1)^2/(4N+1) kg, its centre (3N+1)/(2 mass) m from the hinge, its inertia about the
  hinge I_eff; the weight's moment (N+1)/2 + N kg m times g), written in depsim's language
  and run by the same program at the same tol and release. Its `tip` is the point 1 m from
  the hinge along the body, so its errors are the crank tip's.
- "DOPRI5": the one-angle ODE itself by scipy's RK45 (Dormand-Prince 5(4)) at
  rtol = atol = tol, on the same output times; "DOPRI5=" the same at the tolerance where it
  takes as many steps as the pendulum (its errors still in units of the run's tol).
The chain against the pendulum is what the singular positions cost; the pendulum against
DOPRI5= what depsim's method costs a step on a motion with no singular position at all (the
multipliers prescribed over each step: docs/method.md, 9).
Each prints its steps, the same errors against the reference and the energy drift.

Every run has a timeout (--timeout, 900 s), reported as such. Programs are built with
`depsim compile --target c` and `make` into --build (default a temporary folder); set
DEPSIM_CACHE to keep the generated code of big chains between invocations.
"""

from __future__ import annotations

import argparse
import math
import re
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

DEPSIM = [sys.executable, "-m", "depsim"]
G = 9.81  # m/s^2, as the models' gravity


# --- models ----------------------------------------------------------------------------------

def chain_model(n: int) -> str:
    """n bars of length L and mass m (parameters), h1 at the ground origin, released at 45 deg
    from the vertical; outputs the tip and the kinetic and gravity energies."""
    lines = [f'model chain{n} "hanging chain of {n} bars"', "gravity = (0, -9.81) m/s^2",
             "param L = 0.01 m", "param m = 0.01 kg"]
    for i in range(1, n + 1):
        lines.append(f"bar b{i} {{ length = L; mass = m; inertia = m * L^2 / 12 }}")
    lines.append("hinge h1 joins ground.origin to b1.a { angle = b1 - ground + 90 deg }")
    for i in range(2, n + 1):
        lines.append(f"hinge h{i} joins b{i - 1}.b to b{i}.a")
    bars = [f"b{i}" for i in range(1, n + 1)]
    lines += ["initial { h1 = 45 deg }",
              "simulate { t_end = 2 s; tol = 1e-8; dt_out = 0.01 s }",
              f"output tip_x = b{n}.b.x", f"output tip_y = b{n}.b.y",
              f"output kinetic = {kinetic(bars, 'm', 'm * L^2 / 12')}",
              f"output potential = {potential(bars, 'm')}"]
    return "\n".join(lines) + "\n"


def parallelogram_model(n: int) -> str:
    """n parallelograms sharing their cranks (c0..cn, couplers k1..kn), all links 1 m, 1 kg;
    outputs the first crank's angle, rate, tip position and velocity, and the energies."""
    lines = [f'model para{n} "chain of {n} parallelograms"', "gravity = (0, -9.81) m/s^2"]
    bars = [f"c{i}" for i in range(n + 1)] + [f"k{i}" for i in range(1, n + 1)]
    for bar in bars:
        lines.append(f"bar {bar} {{ length = 1 m; mass = 1 kg; inertia = 1 kg * (1 m)^2 / 12 }}")
    lines.append("ground { " + "; ".join(f"point p{i} = ({i}, 0) m" for i in range(n + 1)) + " }")
    for i in range(n + 1):
        lines.append(f"hinge g{i} joins ground.p{i} to c{i}.a")
    for i in range(1, n + 1):
        lines.append(f"hinge a{i} joins c{i - 1}.b to k{i}.a")
        lines.append(f"hinge b{i} joins k{i}.b to c{i}.b")
    lines += ["initial { g0 = 10 deg; g0.rate = 0 rad/s }",
              "simulate { t_end = 20 s; tol = 1e-8; dt_out = 0.01 s }",
              "output crank = g0", "output rate = g0.rate", "output tip_x = c0.b.x",
              "output tip_y = c0.b.y", "output tip_vx = c0.b.vx", "output tip_vy = c0.b.vy",
              f"output kinetic = {kinetic(bars, '1 kg', '1 kg * (1 m)^2 / 12')}",
              f"output potential = {potential(bars, '1 kg')}"]
    return "\n".join(lines) + "\n"


def pendulum_model(n: int) -> str:
    """One body on one hinge whose angle obeys the n-parallelogram chain's one-angle ODE (see
    the module's text); `tip` 1 m from the hinge, outputs named as parallelogram_model's."""
    mass = (3 * n + 1) ** 2 / (4 * n + 1)  # kg: any mass above (3n+1)^2/(4 I_eff) would do
    centre = (3 * n + 1) / (2 * mass)  # m from the hinge: mass * centre = (n+1)/2 + n kg m
    inertia = (4 * n + 1) / 3 - mass * centre ** 2  # kg m^2 about the centre: I_eff about the hinge
    lines = [f'model pend{n} "the one-angle motion of {n} parallelograms, one body"',
             "gravity = (0, -9.81) m/s^2",
             f"body c0 {{ mass = {mass!r} kg; inertia = {inertia!r} kg*m^2; "
             f"point a = ({-centre!r}, 0) m; point tip = ({1 - centre!r}, 0) m }}",
             "hinge g0 joins ground.origin to c0.a",
             "initial { g0 = 10 deg; g0.rate = 0 rad/s }",
             "simulate { t_end = 20 s; tol = 1e-8; dt_out = 0.01 s }",
             "output crank = g0", "output rate = g0.rate", "output tip_x = c0.tip.x",
             "output tip_y = c0.tip.y", "output tip_vx = c0.tip.vx", "output tip_vy = c0.tip.vy",
             f"output kinetic = {mass!r} kg / 2 * (c0.vx^2 + c0.vy^2) + {inertia!r} kg*m^2 / 2 "
             "* c0.omega^2 / rad^2",
             f"output potential = {mass!r} kg * {G} m/s^2 * c0.y"]
    return "\n".join(lines) + "\n"


def kinetic(bars: list[str], mass: str, inertia: str) -> str:
    """The bars' kinetic energy as an output expression (equal bars)."""
    translation = balanced_sum([f"{b}.vx^2 + {b}.vy^2" for b in bars])
    rotation = balanced_sum([f"{b}.omega^2" for b in bars])
    return f"{mass} / 2 * {translation} + {inertia} / 2 * {rotation} / rad^2"


def potential(bars: list[str], mass: str) -> str:
    """The bars' gravity energy (zero at y = 0) as an output expression (equal bars)."""
    return f"{mass} * {G} m/s^2 * " + balanced_sum([f"{b}.y" for b in bars])


def balanced_sum(terms: list[str]) -> str:
    """(t1 + t2 + ...) as a tree of halves: the language nests expressions at most 100 deep,
    and a flat sum of n terms nests n deep."""
    if len(terms) <= 8:
        return "(" + " + ".join(terms) + ")"
    half = len(terms) // 2
    return f"({balanced_sum(terms[:half])} + {balanced_sum(terms[half:])})"


# --- building and running --------------------------------------------------------------------

def build(text: str, name: str, folder: Path) -> tuple[Path, float]:
    """The standalone program of a model text, and the seconds compile + make took."""
    source = folder / f"{name}.dep"
    if not source.exists() or source.read_text() != text:
        source.write_text(text)
    start = time.perf_counter()
    subprocess.run([*DEPSIM, "compile", str(source), "--target", "c", "-o",
                    str(folder / name)], check=True, capture_output=True)
    subprocess.run(["make", "-s", "-j2", "-C", str(folder / name), name], check=True,
                   capture_output=True)
    return folder / name / name, time.perf_counter() - start


@dataclass
class Run:
    status: str  # "ok", "failed", "timeout"
    message: str = ""  # the failure's first line
    accepted: int = 0
    rejected: int = 0
    retried: int = 0
    wall: float = 0.0  # s, median over the timed processes
    table: dict | None = None  # output name -> column, with "t"


def run_once(program: Path, tol: float, t_end: float, settings: dict, out: Path,
             timeout: float) -> Run:
    """One whole process; its CSV read back when it completes."""
    command = [str(program), "--tol", repr(tol), "--t-end", repr(t_end), "-o", str(out)]
    for name, value in settings.items():
        command += ["--set", f"{name}={value!r}"]
    out.unlink(missing_ok=True)
    start = time.perf_counter()
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return Run("timeout", f"no result within {timeout:g} s", wall=timeout)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        lines = (done.stderr or done.stdout).strip().splitlines() or [f"exit {done.returncode}"]
        return Run("failed", lines[0], wall=wall)
    found = re.search(r"steps: (\d+) accepted, (\d+) rejected, (\d+) retried", done.stdout)
    data = np.genfromtxt(out, delimiter=",", names=True)
    return Run("ok", "", *map(int, found.groups()), wall=wall,
               table={name: data[name] for name in data.dtype.names})


def run_timed(program: Path, tol: float, t_end: float, settings: dict, out: Path,
              args) -> Run:
    """run_once, repeated --repeat times for the median wall time unless the first run failed
    or took longer than --repeat-below seconds."""
    first = run_once(program, tol, t_end, settings, out, args.timeout)
    if first.status != "ok" or first.wall > args.repeat_below:
        return first
    walls = [first.wall] + [run_once(program, tol, t_end, settings, out, args.timeout).wall
                            for _ in range(args.repeat - 1)]
    first.wall = statistics.median(walls)
    return first


def energy_drift(table: dict) -> float:
    """max |E(t) - E(0)| / max KE over the output times, E = kinetic + gravity."""
    energy = table["kinetic"] + table["potential"]
    return float(np.max(np.abs(energy - energy[0])) / np.max(table["kinetic"]))


def outcome(run: Run) -> str:
    return {"ok": "completed", "timeout": "TIMEOUT"}.get(run.status, "FAILED")


def failure_lines(failures: list[tuple[str, Run]]) -> None:
    for case, run in failures:
        print(f"  {case}: {run.message}")


# --- chains ----------------------------------------------------------------------------------

def chain_lengths(n: int, lengths: list[float]) -> list[float]:
    """1/N (the 1 m chain) first, then the given bar lengths, without repeats."""
    chosen = [1.0 / n]
    for length in lengths:
        if all(abs(length - c) > 1e-12 * c for c in chosen):
            chosen.append(length)
    return chosen


def chain_table(args, folder: Path) -> None:
    print(f"\nHanging chains, 0-2 s, undamped, released at 45 deg; m = 1/N kg per bar; "
          f"timeout {args.timeout:g} s")
    header = (f"{'N':>5} {'L (m)':>8} {'tol':>6} {'result':<10} {'accepted':>9} "
              f"{'rejected':>9} {'retried':>8} {'wall (s)':>9} {'us/step/N':>10} "
              f"{'dE/KEmax/tol':>13}")
    failures = []
    for n in args.sizes:
        program, seconds = build(chain_model(n), f"chain{n}", folder)
        print(f"chain{n}: built in {seconds:.1f} s")
        print(header)
        for length in chain_lengths(n, args.lengths):
            for tol in args.tols:
                run = run_timed(program, tol, 2.0, {"L": length, "m": 1.0 / n},
                                folder / "chain.csv", args)
                print(chain_row(n, length, tol, run), flush=True)
                if run.status != "ok":
                    failures.append((f"N={n} L={length:.3g} tol={tol:g}", run))
    failure_lines(failures)


def chain_row(n: int, length: float, tol: float, run: Run) -> str:
    row = f"{n:>5} {length:>8.3g} {tol:>6.0e} {outcome(run):<10}"
    if run.status != "ok":
        return row + f" {'':>9} {'':>9} {'':>8} {run.wall:>9.3f}"
    per_step = run.wall / max(run.accepted, 1) / n * 1e6
    drift = energy_drift(run.table) / tol
    return (row + f" {run.accepted:>9} {run.rejected:>9} {run.retried:>8} {run.wall:>9.3f} "
            f"{per_step:>10.3f} {drift:>13.3g}")


# --- parallelograms --------------------------------------------------------------------------

def parallelogram_constants(n: int) -> tuple[float, float]:
    """I_eff (kg m^2) and the weight's moment W (N m, V = W sin(theta)) of the one-angle ODE
    I_eff theta'' = -W cos(theta) (m = L = 1)."""
    return (n + 1) / 3 + n, ((n + 1) / 2 + n) * G


def parallelogram_reference(n: int, times: np.ndarray, release: float = 10.0, tol: float = 0.0
                            ) -> tuple[np.ndarray, np.ndarray, int]:
    """The crank angle and rate of the one-angle ODE at the given times, released at rest
    `release` deg above the horizontal, and the accepted steps: the converged reference
    (DOP853, rtol 1e-13) without tol, scipy's RK45 at rtol = atol = tol with it."""
    from scipy.integrate import solve_ivp

    inertia, weight = parallelogram_constants(n)

    def rhs(t, y):
        return [y[1], -weight * np.cos(y[0]) / inertia]

    settings = dict(method="RK45", rtol=tol, atol=tol) if tol else \
        dict(method="DOP853", rtol=1e-13, atol=1e-14)
    sol = solve_ivp(rhs, (0.0, times[-1]), [np.radians(release), 0.0], t_eval=times,
                    **settings)
    stages = 6 if tol else 12  # right-side evaluations a step (FSAL for RK45)
    return sol.y[0], sol.y[1], (sol.nfev - 2) // stages


def tip_errors(n: int, table: dict, release: float = 10.0) -> tuple[float, float]:
    """The first crank's tip: largest position and velocity errors against the reference."""
    theta, omega, _ = parallelogram_reference(n, table["t"], release)
    position = np.hypot(table["tip_x"] - np.cos(theta), table["tip_y"] - np.sin(theta))
    velocity = np.hypot(table["tip_vx"] + omega * np.sin(theta),
                        table["tip_vy"] - omega * np.cos(theta))
    return float(position.max()), float(velocity.max())


def dopri_table(n: int, tol: float, release: float, t_end: float) -> tuple[dict, int]:
    """The one-angle ODE by RK45 at tol as an output table (the crank tip, the energies), and
    its steps."""
    times = np.arange(0.0, t_end + 1e-9, 0.01)
    theta, omega, steps = parallelogram_reference(n, times, release, tol)
    inertia, weight = parallelogram_constants(n)
    return {"t": times, "tip_x": np.cos(theta), "tip_y": np.sin(theta),
            "tip_vx": -omega * np.sin(theta), "tip_vy": omega * np.cos(theta),
            "kinetic": 0.5 * inertia * omega ** 2, "potential": weight * np.sin(theta)}, steps


def equal_steps(n: int, steps: int, release: float, t_end: float) -> float | None:
    """The RK45 tolerance at which the one-angle ODE takes `steps` accepted steps, within 2 %
    (secants in log steps against log tol, where the steps follow a power of tol); None
    without steps."""
    if steps <= 0:
        return None
    times = np.array([0.0, t_end])
    points = []
    tol = 1e-10
    for _ in range(12):
        taken = parallelogram_reference(n, times, release, tol)[2]
        if abs(taken - steps) <= 0.02 * steps:
            break
        points.append((math.log(tol), math.log(taken)))
        slope = -0.2  # DOPRI5's steps go as tol^(-1/5)
        if len(points) > 1 and points[-1][0] != points[-2][0]:
            slope = (points[-1][1] - points[-2][1]) / (points[-1][0] - points[-2][0])
            slope = min(-0.05, max(-1.0, slope))
        tol = math.exp(points[-1][0] + (math.log(steps) - points[-1][1]) / slope)
        tol = min(1e-3, max(1e-15, tol))
    return tol


def parallelogram_table(args, folder: Path) -> None:
    releases = ", ".join(f"{a:g}" for a in args.releases)
    print(f"\nParallelogram chains, 0-{args.t_end:g} s, released at rest {releases} deg above "
          f"the singular position; timeout {args.timeout:g} s; beside each chain the same "
          "motion without a singular position: a pendulum (one body on a hinge, depsim) and "
          "the one-angle ODE by DOPRI5 (scipy's RK45, rtol = atol = tol; DOPRI5=: at the tol where "
          "it takes the pendulum's steps)")
    print(f"{'N':>4} {'tol':>6} {'deg':>4} {'run':<8} {'result':<10} {'accepted':>9} "
          f"{'rej+retried':>11} {'pos err m':>10} {'/tol':>9} {'vel err m/s':>11} {'/tol':>9} "
          f"{'dE/KEmax/tol':>13} {'wall (s)':>9}")
    failures = []
    for n in args.counts:
        programs = {"chain": build(parallelogram_model(n), f"para{n}", folder)[0],
                    "pendulum": build(pendulum_model(n), f"pend{n}", folder)[0]}
        for tol in args.tols:
            errors = {"chain": [], "pendulum": [], "DOPRI5": [], "DOPRI5=": []}
            for release in args.releases:
                runs = {}
                for kind, program in programs.items():
                    run = run_timed(program, tol, args.t_end,
                                    {"g0.initial_angle": math.radians(release)},
                                    folder / f"{kind}.csv", args)
                    row, error = parallelogram_row(n, tol, release, kind, run)
                    print(row, flush=True)
                    errors[kind].append(error)
                    runs[kind] = run
                    if run.status != "ok":
                        failures.append((f"{kind} N={n} tol={tol:g} release={release:g} deg",
                                         run))
                pendulum = runs["pendulum"]
                same = pendulum.accepted if pendulum.status == "ok" else 0
                for kind, at in (("DOPRI5", tol), ("DOPRI5=", equal_steps(n, same, release,
                                                                         args.t_end))):
                    if at is None:
                        continue
                    table, steps = dopri_table(n, at, release, args.t_end)
                    row, error = parallelogram_row(n, tol, release, kind,
                                                   Run("ok", accepted=steps, table=table))
                    print(row, flush=True)
                    errors[kind].append(error)
            if len(args.releases) > 1:
                for kind, found in errors.items():
                    print(f"      {kind:<8} " + spread_row(found))
    failure_lines(failures)


def parallelogram_row(n: int, tol: float, release: float, kind: str, run: Run
                      ) -> tuple[str, tuple[float, float] | None]:
    """The table's row, and the position and velocity errors in tol (None: no result)."""
    row = f"{n:>4} {tol:>6.0e} {release:>4g} {kind:<8} {outcome(run):<10}"
    if run.status != "ok":
        return row + f" {'':>9} {'':>11} {'':>10} {'':>9} {'':>11} {'':>9} {'':>13} " \
                     f"{run.wall:>9.3f}", None
    position, velocity = tip_errors(n, run.table, release)
    drift = energy_drift(run.table) / tol
    wall = f"{run.wall:>9.3f}" if run.wall else f"{'':>9}"
    return (row + f" {run.accepted:>9} {run.rejected + run.retried:>11} {position:>10.2e} "
            f"{position / tol:>9.3g} {velocity:>11.2e} {velocity / tol:>9.3g} "
            f"{drift:>13.3g} {wall}"), (position / tol, velocity / tol)


def spread_row(errors: list[tuple[float, float] | None]) -> str:
    """Over the release angles: the medians and largest errors, and how many runs kept both
    within 10 tol."""
    done = [e for e in errors if e is not None]
    if not done:
        return "no run completed"
    position, velocity = np.array(done).T
    within = sum(p <= 10 and v <= 10 for p, v in done)
    return (f"over {len(errors)} releases: position median {np.median(position):.3g}, "
            f"largest {position.max():.3g} tol; velocity median {np.median(velocity):.3g}, "
            f"largest {velocity.max():.3g} tol; within 10 tol: {within} of {len(errors)}")


# --- command line ----------------------------------------------------------------------------

def numbers(text: str, kind=float) -> list:
    return [kind(item) for item in text.split(",") if item]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=["chains", "parallelograms", "both"], default="both")
    parser.add_argument("--quick", action="store_true",
                        help="chains N=100 and parallelograms N=1,10, tol 1e-6 and 1e-8")
    parser.add_argument("--sizes", type=lambda s: numbers(s, int), default=[100, 300, 1000],
                        help="chain bar counts (100,300,1000)")
    parser.add_argument("--lengths", type=numbers, default=[1e-3, 1e-2, 0.1],
                        help="chain bar lengths besides 1/N, m (0.001,0.01,0.1)")
    parser.add_argument("--counts", type=lambda s: numbers(s, int), default=[1, 2, 10, 40],
                        help="parallelogram counts (1,2,10,40)")
    parser.add_argument("--tols", type=numbers, default=[1e-6, 1e-8, 1e-10],
                        help="tolerances (1e-6,1e-8,1e-10)")
    parser.add_argument("--t-end", type=float, default=20.0, help="parallelograms' end, s")
    parser.add_argument("--releases", type=numbers, default=[10.0],
                        help="parallelograms' release angles above the horizontal, deg (10); "
                             "several show how the errors scatter with the crossings' steps")
    parser.add_argument("--repeat", type=int, default=3, help="processes per case (median)")
    parser.add_argument("--repeat-below", type=float, default=10.0,
                        help="repeat only runs shorter than this, s")
    parser.add_argument("--timeout", type=float, default=900.0, help="per run, s")
    parser.add_argument("--build", type=Path, help="folder for the programs (kept)")
    args = parser.parse_args(argv)
    if args.quick:
        args.sizes, args.counts, args.tols = [100], [1, 10], [1e-6, 1e-8]
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.build or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        if args.part in ("chains", "both"):
            chain_table(args, folder)
        if args.part in ("parallelograms", "both"):
            parallelogram_table(args, folder)
    return 0


if __name__ == "__main__":
    sys.exit(main())
