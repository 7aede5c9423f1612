"""Spatial formulation: depsim's rotation-matrix coordinates against Euler parameters and joint
coordinates, on the same mechanisms, side by side.

    .venv/bin/python bench/bench_formulation.py                  # 5 to 7 minutes
    .venv/bin/python bench/bench_formulation.py --instructions   # and callgrind's counts
    .venv/bin/python bench/bench_formulation.py --quick          # under a minute
    .venv/bin/python bench/bench_formulation.py --parts chain --sizes 3,10,30 --rounds 5

The built programs are kept in --work (depsim's C folders are generated again only when a
model's text changes): the first run spends about 1.5 minutes building the chain of 30, 40 s
the quick run's folders; after that --quick takes seconds.

The formulations (every one a C program, timed inside its own process: Python only starts
the processes and reads what they print, so no Python runs in a timed loop):

depsim       the model written in depsim's language, `depsim compile --target c`, the
             folder's objects linked with the small driver below (DRIVER): dep_simulate, r
             and R read from q. 12 coordinates and 6 rows per body; M constant, factorised
             once; the iterative multipliers (docs/method.md, 2 and 11).
EP           Euler parameters, tests/references/formulations.c with the kernels
             tests/references/formulations.py derives with sympy and emits with sympy's C
             code generator: 7 coordinates and the norm row per body, M(p) formed and
             factorised at every evaluation, the multipliers solved with the accelerations
             (the index-1 system, S = Phi_q M^-1 Phi_q^T in envelope form), Baumgarte
             stabilisation (a = 10 1/s); Dormand-Prince 5(4) with Hairer's step control.
EP+proj      the same without Baumgarte, the state projected onto the rows after every
             accepted step (Newton on Phi to 0.01 tol, M-orthogonal, then the velocities).
joint        joint coordinates (the hinge angles) by the articulated-body algorithm, O(n);
             the same Dormand-Prince 5(4). For the free body: z-y-x Euler angles (singular
             at pitch +-90 deg) and, separately, a quaternion with Euler's equations (7
             states, no rows: "quat").

The mechanisms: the double pendulum with skewed hinge axes of tests/runtime/test_spatial.py
(0-3 s); the torque-free asymmetric body spun about its middle axis (J = 2, 3, 4 kg m^2,
0-6 s, six turns and a flip; a free joint in depsim); the hanging chain of N bars of
bench/bench_spatial.py (each 1/N m and 1/N kg, skewed hinge axes, h1 released at 45 deg,
0-2 s), its body frames turned to the world's (the same motion).

Printed, per mechanism and tol: steps (and rejected), right-side evaluations, the cost of an
evaluation alone (ns, the median of timed loops: every 97th evaluation of a run is repeated
20 times between two clock readings; depsim's right side is `dep_stepper_rhs`: forces,
Phi_q^T lambda(t), M^-1), the run's CPU time (median of the in-process repeats of all
rounds) and that time per evaluation and per step, the largest error of the bodies' r (m)
and R entries at the output times (every 0.01 s) against a converged reference (joint
coordinates at tol 1e-13; the free body: the quaternion at 1e-13; each checked against a
second formulation and tests/references/spatial.py), the energy drift max |E - E0| / max KE
in tol, the largest constraint residual over the accepted steps (depsim: the passes'
position residual; EP: max |Phi|, the norm rows included), and for the free body how close
the Euler angles came to gimbal lock and whether a quaternion changed sign. Then the
evaluations, steps and CPU time each needs for the same error, interpolated log-log between
the tols, and for the chains the growth with N. With --instructions, callgrind's instruction
counts (the same on any load) per evaluation alone, per evaluation of the whole process and
per step, at tol 1e-8.

The machine's 2 cores are shared: every round runs each (formulation, tol) process once in
a turning order; times are medians. The load average is printed before and after.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from references.formulations import (Mechanism, build, derivative,  # noqa: E402
                                     potential, run)
from references.spatial import (_Chain, rot, skewed_double_pendulum,  # noqa: E402
                                torque_free)

PYTHON = sys.executable
DEPSIM = [PYTHON, "-m", "depsim"]
REFERENCE_TOL = 1e-13


# --- the mechanisms ---------------------------------------------------------------------------

def pendulum() -> Mechanism:
    """tests/runtime/test_spatial.py's double pendulum with skewed hinge axes."""
    bodies = [dict(name="l1", m=1.0, J=np.diag([0.01, 0.09, 0.09])),
              dict(name="l2", m=0.5, J=np.diag([0.005, 0.04, 0.04]))]
    hinges = [dict(parent=-1, axis=[0, 1, 0.2], point_a=[0, 0, 0], point_b=[-0.5, 0, 0]),
              dict(parent=0, axis=[0.3, 1, 0], point_a=[0.5, 0, 0], point_b=[-0.4, 0, 0])]
    return Mechanism("pendulum", bodies, hinges, gravity=(0.0, 0.0, -9.81),
                     theta0=tuple(np.radians([30.0, -20.0])), rate0=(0.0, 1.0))


def tumbling() -> Mechanism:
    """tests/runtime/test_spatial.py's torque-free body spun about its middle axis."""
    R0 = rot([0.2, -0.4, 1.0], 0.7)
    return Mechanism("tumbling", [dict(name="top", m=5.0, J=np.diag([2.0, 3.0, 4.0]))],
                     free=True, R0=R0, omega0=R0 @ np.array([1e-3, 2 * math.pi, 1e-3]))


def chain(n: int) -> Mechanism:
    """bench/bench_spatial.py's chain, each bar's frame the world's at theta = 0: its length
    along z, root (a) at +L/2, tip (b) at -L/2; hinge axes (0, 1, 0.2) from the ground, then
    alternately (0.2, 1, 0) and (0.2, 0, 1) of bench_spatial's bar frames, here (0, 1, -0.2)
    and (1, 0, -0.2)."""
    L, m = 1.0 / n, 1.0 / n
    J = np.diag([m * L * L * 1.01 / 12, m * L * L * 1.01 / 12, m * L * L / 600])
    bodies = [dict(name=f"b{i + 1}", m=m, J=J) for i in range(n)]
    hinges = [dict(parent=-1, axis=[0, 1, 0.2], point_a=[0, 0, 0], point_b=[0, 0, L / 2])]
    for i in range(1, n):
        axis = [0, 1, -0.2] if (i + 1) % 2 == 0 else [1, 0, -0.2]
        hinges.append(dict(parent=i - 1, axis=axis, point_a=[0, 0, -L / 2],
                           point_b=[0, 0, L / 2]))
    return Mechanism(f"chain{n}", bodies, hinges, gravity=(0.0, 0.0, -9.81),
                     theta0=(math.radians(45.0),) + (0.0,) * (n - 1), rate0=(0.0,) * n)


CASES = {  # t_end, dt_out
    "pendulum": (3.0, 0.01),
    "tumbling": (6.0, 0.01),
    "chain": (2.0, 0.01),
}


def vector(values) -> str:
    return "(" + ", ".join(repr(float(v)) for v in values) + ")"


def turns(R) -> str:
    """R as rz(a) * ry(b) * rx(c) (R = Rz Ry Rx, |b| < 90 deg)."""
    b = -math.asin(max(-1.0, min(1.0, R[2, 0])))
    a, c = math.atan2(R[1, 0], R[0, 0]), math.atan2(R[2, 1], R[2, 2])
    return f"rz({float(a)!r} rad) * ry({float(b)!r} rad) * rx({float(c)!r} rad)"


def dep_text(mech: Mechanism, t_end: float, dt_out: float) -> str:
    """The mechanism in depsim's language (principal axes = the body frame: J diagonal)."""
    lines = [f'model {mech.name} spatial "{mech.name}, bench/bench_formulation.py"']
    if any(mech.gravity):
        lines.append(f"gravity = {vector(mech.gravity)} m/s^2")
    points = {i: [] for i in range(len(mech.bodies))}
    for i, h in enumerate(mech.hinges):
        if h["parent"] >= 0:
            points[h["parent"]].append((f"c{i + 1}", h["point_a"]))
        points[i].append(("root", h["point_b"]))
    for i, body in enumerate(mech.bodies):
        J = np.asarray(body["J"], float)
        if np.any(J != np.diag(np.diag(J))):
            raise ValueError("principal axes only")
        lines.append(f"body {body['name']} {{")
        lines.append(f"    mass = {body['m']!r} kg")
        lines.append(f"    inertia = {vector(np.diag(J))} kg*m^2")
        if mech.free:
            lines.append(f"    orientation = {turns(np.asarray(mech.R0, float))}")
        for name, point in points[i]:
            lines.append(f"    point {name} = {vector(point)} m")
        lines.append("}")
    initial = []
    for i, h in enumerate(mech.hinges):
        a = mech.bodies[h["parent"]]["name"] + f".c{i + 1}" if h["parent"] >= 0 else \
            "ground.origin"
        if h["parent"] < 0 and np.any(h["point_a"]):
            raise ValueError("ground hinges at the origin only")
        lines.append(f"hinge h{i + 1} joins {a} to {mech.bodies[i]['name']}.root "
                     f"{{ axis = {vector(h['axis'])} }}")
        if mech.theta0[i]:
            initial.append(f"h{i + 1} = {float(mech.theta0[i])!r} rad")
        if mech.rate0[i]:
            initial.append(f"h{i + 1}.rate = {float(mech.rate0[i])!r} rad/s")
    if mech.free:
        name = mech.bodies[0]["name"]
        lines.append(f"free fly joins ground.origin to {name}.cm {{ }}")
        initial += [f"fly.w{k} = {float(w)!r} rad/s" for k, w in zip("xyz", mech.omega0)]
    if initial:
        lines.append("initial { " + "; ".join(initial) + " }")
    lines.append(f"simulate {{ t_end = {t_end!r} s; tol = 1e-8; dt_out = {dt_out!r} s }}")
    return "\n".join(lines) + "\n"


# --- depsim: the C target's objects and a driver ---------------------------------------------

# dep_simulate once with the outputs (every dt_out: q, the energy, max |Phi| by the model's own
# phi), then --repeat times with the end alone (DEP_ROWS_OUTPUTS), each run timed; with
# RHS_TIMER (linked with -Wl,--wrap=dep_stepper_rhs) one more run in which every 97th
# right-side evaluation is repeated 20 times between two clock readings.
DRIVER = r"""
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "core/include/depsim.h"
#include "model.h"

static double seconds(clockid_t clock)
{
    struct timespec now;
    clock_gettime(clock, &now);
    return now.tv_sec + 1e-9 * now.tv_nsec;
}

#define MAX_SAMPLES 20000
static double samples[MAX_SAMPLES];
static long n_samples;
#ifdef RHS_TIMER
void __real_dep_stepper_rhs(void *context, double t, const double *y, double *dy);
static int sampling;
static long calls;
void __wrap_dep_stepper_rhs(void *context, double t, const double *y, double *dy)
{
    if (sampling && ++calls % 97 == 0 && n_samples < MAX_SAMPLES) {
        double start = seconds(CLOCK_MONOTONIC);
        for (int k = 0; k < 20; ++k) __real_dep_stepper_rhs(context, t, y, dy);
        samples[n_samples++] = (seconds(CLOCK_MONOTONIC) - start) / 20;
        return;
    }
    __real_dep_stepper_rhs(context, t, y, dy);
}
#endif

static int compare(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

int main(int argc, char **argv)
{
    dep_settings settings = dep_default_settings(&depsim_model);
    const char *out = NULL;
    int repeat = 0, timing = 0;
    for (int i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--time-rhs") == 0) timing = 1;
        else if (i + 1 < argc && strcmp(argv[i], "--t-end") == 0) settings.t_end = atof(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--tol") == 0) settings.tol = atof(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--dt-out") == 0)
            settings.dt_out = atof(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--repeat") == 0) repeat = atoi(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "-o") == 0) out = argv[++i];
        else { fprintf(stderr, "bad option %s\n", argv[i]); return 2; }
    }
    dep_result r;
    dep_error e;
    settings.rows = DEP_ROWS_ALL;
    if (dep_simulate(&depsim_model, NULL, &settings, NULL, 0, &r, &e) != DEP_OK) {
        fprintf(stderr, "%s\n", e.message);
        return 3;
    }
    FILE *csv = fopen(out, "w");
    if (!csv) return 1;
    fprintf(csv, "t");
    for (int j = 0; j < r.nq; ++j) fprintf(csv, ",%s", depsim_model.coordinate_names[j]);
    fprintf(csv, ",energy,residual\n");
    double phi[MODEL_NC > 0 ? MODEL_NC : 1];
    for (int i = 0; i < r.n; ++i) {
        const double *q = r.q + (size_t)i * r.nq;
        double energy = 0, worst = 0;
        for (int k = 0; k < r.ne; ++k) energy += r.energy[(size_t)i * r.ne + k];
        model_phi(q, r.times[i], r.params, phi);
        for (int k = 0; k < MODEL_NC; ++k) worst = fmax(worst, fabs(phi[k]));
        fprintf(csv, "%.17g", r.times[i]);
        for (int j = 0; j < r.nq; ++j) fprintf(csv, ",%.17g", q[j]);
        fprintf(csv, ",%.17g,%.17g\n", energy, worst);
    }
    fclose(csv);
    dep_stats st = r.stats;
    dep_result_free(&r);
    double *walls = malloc((repeat + 1) * sizeof *walls);
    double *cpus = malloc((repeat + 1) * sizeof *cpus);
    long long steps_again = -1;
    settings.rows = DEP_ROWS_OUTPUTS;
    settings.dt_out = settings.t_end;
    for (int k = 0; k < repeat; ++k) {
        double w = seconds(CLOCK_MONOTONIC), c = seconds(CLOCK_PROCESS_CPUTIME_ID);
        if (dep_simulate(&depsim_model, NULL, &settings, NULL, 0, &r, &e) != DEP_OK) return 3;
        cpus[k] = seconds(CLOCK_PROCESS_CPUTIME_ID) - c;
        walls[k] = seconds(CLOCK_MONOTONIC) - w;
        steps_again = r.stats.accepted_steps;
        dep_result_free(&r);
    }
#ifdef RHS_TIMER
    if (timing) {
        sampling = 1;
        if (dep_simulate(&depsim_model, NULL, &settings, NULL, 0, &r, &e) != DEP_OK) return 3;
        sampling = 0;
        dep_result_free(&r);
        qsort(samples, n_samples, sizeof *samples, compare);
    }
#else
    (void)timing;
#endif
    fprintf(stderr, "{\"steps\": %lld, \"rejected\": %lld, \"evaluations\": %lld, "
            "\"integrations\": %lld, \"factorizations\": %lld, \"worst_residual\": %.6g, "
            "\"steps_again\": %lld, \"rows\": %d, \"walls\": [", st.accepted_steps,
            st.rejected_steps + st.failed_steps, st.rhs_evaluations, st.integrations,
            st.factorizations, st.max_v_pos, steps_again, MODEL_NC);
    for (int k = 0; k < repeat; ++k) fprintf(stderr, "%s%.6g", k ? ", " : "", walls[k]);
    fprintf(stderr, "], \"cpus\": [");
    for (int k = 0; k < repeat; ++k) fprintf(stderr, "%s%.6g", k ? ", " : "", cpus[k]);
    fprintf(stderr, "], \"rhs_ns\": %.6g, \"rhs_samples\": %ld}\n",
            n_samples ? 1e9 * samples[n_samples / 2] : -1.0, n_samples);
    return 0;
}
"""


def build_depsim(mech: Mechanism, folder: Path, t_end: float, dt_out: float) -> Path:
    """depsim's C target folder of the mechanism and the driver linked with its objects
    (depsim's flags); generated again only when the model text changed."""
    out = folder / f"{mech.name}_depsim"
    text = dep_text(mech, t_end, dt_out)
    source = folder / f"{mech.name}.dep"
    program = out / "driver"
    if not (source.exists() and source.read_text() == text and program.exists()):
        source.write_text(text)
        subprocess.run([*DEPSIM, "compile", str(source), "--target", "c", "-o", str(out)],
                       check=True, capture_output=True)
        name = re.search(r"^all: (\S+) ", (out / "Makefile").read_text(), re.M)[1]
        subprocess.run(["make", "-s", "-j2", "-C", str(out), f"lib{name}.so"], check=True)
        sources = re.search(r"^SOURCES = (.*)$", (out / "Makefile").read_text(), re.M)[1]
        objects = [str(out / s.replace(".c", ".o")) for s in sources.split()]
        (out / "driver.c").write_text(DRIVER)
        flags = ["-O2", "-fno-math-errno", "-std=c99", "-I", str(out)]
        subprocess.run(["cc", *flags, "-o", str(out / "driver_timed"), str(out / "driver.c"),
                        *objects, "-DRHS_TIMER", "-Wl,--wrap=dep_stepper_rhs", "-lm"],
                       check=True)
        subprocess.run(["cc", *flags, "-o", str(program), str(out / "driver.c"), *objects,
                        "-lm"], check=True)
    return program


def run_depsim(program: Path, mech: Mechanism, folder: Path, *, tol: float, t_end: float,
               dt_out: float, repeat: int = 0, time_rhs: bool = False) -> dict:
    """formulations.run's dict for depsim: its statistics and the outputs of its first run."""
    out = folder / f"{mech.name}_depsim_{tol:g}.csv"
    binary = program.with_name("driver_timed") if time_rhs else program
    command = [str(binary), "--tol", repr(tol), "--t-end", repr(t_end), "--dt-out",
               repr(dt_out), "-o", str(out), "--repeat", str(repeat)]
    if time_rhs:
        command.append("--time-rhs")
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        return {"failed": (done.stderr or done.stdout).strip()}
    stats = json.loads(done.stderr.strip().splitlines()[-1])
    with open(out) as f:
        names = f.readline().strip().split(",")
    data = np.loadtxt(out, delimiter=",", skiprows=1, ndmin=2)
    column = {name: k for k, name in enumerate(names)}
    r = np.stack([np.stack([data[:, column[f"{b['name']}.{c}"]] for c in "xyz"], axis=1)
                  for b in mech.bodies], axis=1)
    R = np.stack([np.stack([data[:, column[f"{b['name']}.R{i}{j}"]] for i in "123"
                            for j in "123"], axis=1) for b in mech.bodies], axis=1)
    stats.update(t=data[:, 0], r=r, R=R.reshape(len(data), len(mech.bodies), 3, 3),
                 energy=data[:, column["energy"]], residual=data[:, column["residual"]])
    return stats


# --- runs ---------------------------------------------------------------------------------------

LABELS = {"depsim": "depsim (R, 12/body)", "ep": "EP + Baumgarte", "ep-project": "EP + projection",
          "joint": "joint (ABA)", "angles": "Euler angles zyx", "quat": "quaternion+Euler eq"}


def error(run_: dict, reference: dict, free: bool) -> float:
    """The largest difference of r (m) and R's entries at the output times."""
    n = min(len(run_["t"]), len(reference["t"]))
    if np.max(np.abs(run_["t"][:n] - reference["t"][:n])) > 1e-9:
        raise RuntimeError("output times differ")
    worst = np.max(np.abs(run_["R"][:n] - reference["R"][:n]))
    if not free:
        worst = max(worst, np.max(np.abs(run_["r"][:n] - reference["r"][:n])))
    return float(worst)


def drift(run_: dict, mech: Mechanism) -> float:
    """max |E - E0| / max KE."""
    kinetic = run_["energy"] - potential(mech, run_["r"])
    return float(np.max(np.abs(run_["energy"] - run_["energy"][0])) / np.max(kinetic))


def one(kind: str, mech: Mechanism, programs: dict, folder: Path, tol: float, t_end: float,
        dt_out: float, repeat: int, time_rhs: bool) -> dict:
    if kind == "depsim":
        return run_depsim(programs["depsim"], mech, folder, tol=tol, t_end=t_end,
                          dt_out=dt_out, repeat=repeat, time_rhs=time_rhs)
    return run(programs["baselines"], mech, kind, folder, tol=tol, t_end=t_end, dt_out=dt_out,
               repeat=repeat, time_rhs=time_rhs)


def measure(mech: Mechanism, kinds: list[str], programs: dict, folder: Path, args,
            t_end: float, dt_out: float) -> dict:
    """Every (kind, tol) once a round, in a turning order; the first round keeps the outputs
    (every round's are the same: the runs are deterministic)."""
    jobs = [(kind, tol) for kind in kinds for tol in args.tols]
    results: dict = {}
    for round_ in range(args.rounds):
        shift = round_ % len(jobs)
        for kind, tol in jobs[shift:] + jobs[:shift]:
            got = one(kind, mech, programs, folder, tol, t_end, dt_out, args.repeat, True)
            entry = results.setdefault((kind, tol), {"cpus": [], "walls": [], "rhs": []})
            if "failed" in got:
                entry["failed"] = got["failed"]
                continue
            entry["cpus"] += got["cpus"]
            entry["walls"] += got["walls"]
            if got["rhs_ns"] > 0:
                entry["rhs"].append(got["rhs_ns"])
            if "run" not in entry:
                entry["run"] = got
    return results


def table(title: str, mech: Mechanism, results: dict, reference: dict, kinds: list[str],
          tols: list[float]) -> list[dict]:
    print(f"\n{title}")
    print(f"{'formulation':<21} {'tol':>6} {'steps':>6} {'rej':>4} {'evals':>7} {'ns/eval':>8} "
          f"{'CPU ms':>8} {'ns/eval':>8} {'us/step':>8} {'error':>8} {'/tol':>6} "
          f"{'dE/KE/tol':>9} {'residual':>9}  notes")
    print(f"{'':<21} {'':>6} {'':>6} {'':>4} {'':>7} {'(alone)':>8} {'(run)':>8} {'(run)':>8} "
          f"{'(run)':>8}")
    rows = []
    for kind in kinds:
        for tol in tols:
            entry = results[(kind, tol)]
            label = LABELS[kind]
            if "run" not in entry:
                print(f"{label:<21} {tol:>6.0e} FAILED: {entry.get('failed', '')[:80]}")
                continue
            r = entry["run"]
            cpu = statistics.median(entry["cpus"])
            rhs = statistics.median(entry["rhs"]) if entry["rhs"] else float("nan")
            err = error(r, reference, mech.free)
            energy = drift(r, mech) / tol
            notes = []
            if kind == "angles":
                notes.append(f"min |cos pitch| {r['best_residual']:.1e}")
            if kind in ("ep", "ep-project") and r.get("e0_sign_changes"):
                notes.append(f"e0 changed sign {r['e0_sign_changes']}x")
            if kind == "ep-project":
                notes.append(f"{r['projection_iterations'] / max(r['steps'], 1):.2f} Newton/step")
            if r.get("stopped"):
                notes.append("STOPPED (step size underflow)")
            residual = r.get("worst_residual", 0.0) if kind not in ("angles",) else float("nan")
            row = dict(kind=kind, tol=tol, steps=r["steps"], rejected=r["rejected"],
                       evaluations=r["evaluations"], rhs_ns=rhs, cpu=cpu, error=err,
                       energy=energy, residual=residual)
            rows.append(row)
            print(f"{label:<21} {tol:>6.0e} {r['steps']:>6} {r['rejected']:>4} "
                  f"{r['evaluations']:>7} {rhs:>8.0f} {1e3 * cpu:>8.2f} "
                  f"{1e9 * cpu / r['evaluations']:>8.0f} {1e6 * cpu / r['steps']:>8.2f} "
                  f"{err:>8.1e} {err / tol:>6.2f} {energy:>9.2g} {residual:>9.1e}  "
                  + "; ".join(notes), flush=True)
    return rows


def equal_accuracy(rows: list[dict], kinds: list[str]) -> None:
    """Evaluations, steps and CPU ms at the same error: log-log interpolation between the
    tols measured (none outside their range), at each power of ten that at least two
    formulations reach within their range."""
    def interpolated(kind, target):
        points = sorted(((r["error"], r) for r in rows if r["kind"] == kind),
                        key=lambda x: -x[0])
        for (e1, r1), (e2, r2) in zip(points, points[1:]):
            if e1 >= target >= e2 and e1 > e2 > 0:
                s = (math.log(target) - math.log(e1)) / (math.log(e2) - math.log(e1))
                return {key: math.exp(math.log(r1[key]) + s * (math.log(r2[key])
                                                               - math.log(r1[key])))
                        for key in ("evaluations", "steps", "cpu")}
        return None

    errors = [r["error"] for r in rows if r["error"] > 0]
    if not errors:
        return
    targets = [10.0 ** k for k in range(math.floor(math.log10(max(errors))),
                                        math.ceil(math.log10(min(errors))) - 1, -1)]
    targets = [e for e in targets if sum(interpolated(k, e) is not None for k in kinds) >= 2]
    if not targets:
        print("at the same error: no error level within the range of two formulations")
        return
    print("at the same error (log-log between the measured tols; - outside their range): "
          "evaluations / steps / CPU ms")
    print(f"{'formulation':<21} " + " ".join(f"{'error ' + format(e, '.0e'):>22}"
                                             for e in targets))
    for kind in kinds:
        cells = []
        for target in targets:
            at = interpolated(kind, target)
            cells.append(f"{at['evaluations']:.0f} / {at['steps']:.0f} / {1e3 * at['cpu']:.2f}"
                         if at else "-")
        print(f"{LABELS[kind]:<21} " + " ".join(f"{c:>22}" for c in cells))


def reference_run(mech: Mechanism, programs: dict, folder: Path, t_end: float,
                  dt_out: float) -> dict:
    """The converged reference, checked against a second formulation (and, for the pendulum
    and the free body, against tests/references/spatial.py)."""
    kind = "quat" if mech.free else "joint"
    ref = run(programs["baselines"], mech, kind, folder, tol=REFERENCE_TOL, t_end=t_end,
              dt_out=dt_out)
    second = run(programs["baselines"], mech, "ep-project", folder, tol=1e-12, t_end=t_end,
                 dt_out=dt_out)
    checks = [f"EP + projection at 1e-12 within {error(second, ref, mech.free):.1e}"]
    t = ref["t"]
    if mech.name == "pendulum":
        numpy = skewed_double_pendulum(t, g=np.array(mech.gravity), bodies=[
            dict(m=b["m"], J=b["J"]) for b in mech.bodies], hinges=mech.hinges,
            theta0=mech.theta0, rate0=mech.rate0)
        checks.append(f"tests/references/spatial.py (DOP853 1e-12) within "
                      f"{error(dict(numpy, t=t), ref, False):.1e}")
    elif mech.free:
        numpy = torque_free(t, J=mech.bodies[0]["J"], R0=mech.R0, omega0=mech.omega0)
        numpy = dict(R=numpy["R"][:, None], r=np.zeros((len(t), 1, 3)))
        checks.append(f"tests/references/spatial.py (DOP853 1e-12) within "
                      f"{error(dict(numpy, t=t), ref, True):.1e}")
    elif len(mech.bodies) <= 3:
        chain_ = _Chain(mech.gravity, [dict(m=b["m"], J=b["J"]) for b in mech.bodies],
                        mech.hinges)
        rng = np.random.default_rng(3)
        n, worst = len(mech.bodies), 0.0
        for k in range(20):  # the articulated-body algorithm against _Chain's Kane equations
            y = np.concatenate([rng.uniform(-3, 3, n), rng.uniform(-5, 5, n)])
            probe = Mechanism(f"{mech.name}_probe", mech.bodies, mech.hinges,
                              gravity=mech.gravity, theta0=tuple(y[:n]), rate0=tuple(y[n:]))
            ours = derivative(programs["baselines"], probe, "joint", folder)[n:]
            expected = chain_.rhs(0.0, y)[n:]
            worst = max(worst, float(np.max(np.abs(ours - expected))
                                     / np.max(np.abs(expected))))
        checks.append(f"joint accelerations within {worst:.1e} (relative) of "
                      f"tests/references/spatial.py's _Chain at 20 random states")
    print(f"reference: {LABELS[kind]} at tol {REFERENCE_TOL:g}, {ref['steps']} steps; "
          + "; ".join(checks))
    return ref


def instructions(mech: Mechanism, kinds: list[str], programs: dict, folder: Path, tol: float,
                 t_end: float) -> None:
    """Instructions per evaluation (callgrind, deterministic whatever the load): the right
    side alone (dep_stepper_rhs; the baselines' raw_rhs, inclusive) and the whole process
    over its evaluations; one run, no output rows."""
    print(f"instructions (callgrind, tol {tol:g}, one run, no rows): per evaluation alone / "
          f"per evaluation of the whole process / per step of the whole process")
    for kind in kinds:
        out = folder / f"{mech.name}_{kind}.callgrind"
        if kind == "depsim":
            command = [str(programs["depsim"]), "--tol", repr(tol), "--t-end", repr(t_end),
                       "--dt-out", repr(t_end), "-o", str(folder / "callgrind.csv")]
            function = "dep_stepper_rhs"
        else:
            spec = folder / f"{mech.name}.spec"
            spec.write_text(mech.spec())
            command = [str(programs["baselines"]), kind, str(spec), "--tol", repr(tol),
                       "--t-end", repr(t_end), "--dt-out", repr(t_end), "-o",
                       str(folder / "callgrind.csv")]
            function = "raw_rhs"
        done = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                               *command], capture_output=True, text=True)
        if done.returncode != 0:
            print(f"{LABELS[kind]:<21} callgrind failed")
            continue
        stats = json.loads([line for line in done.stderr.splitlines()
                            if line.startswith("{")][-1])
        report = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100",
                                 str(out)],
                                capture_output=True, text=True).stdout
        total = int(re.search(r"([\d,]+) \(100.0%\)\s+PROGRAM TOTALS", report)[1]
                    .replace(",", ""))
        found = re.search(r"^\s*([\d,]+) \(\s*[\d.]+%\)\s+\S*:" + function + r"\b", report,
                          re.M)
        alone = int(found[1].replace(",", "")) if found else 0
        calls = stats["evaluations"]
        print(f"{LABELS[kind]:<21} {alone / calls:>9.0f} {total / calls:>9.0f} "
              f"{total / stats['steps']:>10.0f}")


# --- the command --------------------------------------------------------------------------------

def numbers(text: str, kind=float) -> list:
    return [kind(item) for item in text.split(",") if item]


def load() -> str:
    return "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="chains of 3 and 6, tols 1e-6 and 1e-8, one round")
    parser.add_argument("--sizes", type=lambda s: numbers(s, int), default=None,
                        help="chain sizes (3,10,30; --quick 3,6)")
    parser.add_argument("--tols", type=numbers, default=None, help="1e-6,1e-8,1e-10")
    parser.add_argument("--rounds", type=int, default=None, help="interleaved rounds (3)")
    parser.add_argument("--repeat", type=int, default=None,
                        help="timed runs inside each process (3)")
    parser.add_argument("--parts", default="pendulum,tumbling,chain")
    parser.add_argument("--instructions", action="store_true",
                        help="and the instructions per evaluation (callgrind; slow)")
    parser.add_argument("--work", type=Path,
                        default=Path(tempfile.gettempdir()) / "depsim-bench-formulation",
                        help="build folder, kept between runs (default: %(default)s)")
    args = parser.parse_args(argv)
    quick = args.quick
    args.sizes = args.sizes or ([3, 6] if quick else [3, 10, 30])
    args.tols = args.tols or ([1e-6, 1e-8] if quick else [1e-6, 1e-8, 1e-10])
    args.rounds = args.rounds or (1 if quick else 3)
    args.repeat = args.repeat or (2 if quick else 3)
    folder = args.work
    folder.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    print(f"bench_formulation: {load()} on {os.cpu_count()} cores; tols "
          f"{', '.join(f'{t:g}' for t in args.tols)}; {args.rounds} rounds x {args.repeat} "
          f"timed runs a process; every time is taken inside a C process (clock_gettime "
          f"around the runs and the timed loops), Python only starts them")
    baselines = build(folder / "baselines")
    parts = args.parts.split(",")
    mechanisms = []
    if "pendulum" in parts:
        mechanisms.append((pendulum(), "double pendulum, skewed hinge axes, 0-3 s"))
    if "tumbling" in parts:
        mechanisms.append((tumbling(), "torque-free asymmetric body (J = 2, 3, 4), spun about "
                                       "its middle axis, 0-6 s"))
    if "chain" in parts:
        mechanisms += [(chain(n), f"chain of {n} spatial bars, 0-2 s") for n in args.sizes]
    summary = []
    for mech, title in mechanisms:
        t_end, dt_out = CASES["chain" if mech.name.startswith("chain") else mech.name]
        compile_start = time.perf_counter()
        programs = {"baselines": baselines,
                    "depsim": build_depsim(mech, folder, t_end, dt_out)}
        print(f"\n== {title} ({len(mech.bodies)} bodies: depsim {12 * len(mech.bodies)} "
              f"coordinates, EP {7 * len(mech.bodies)}; depsim built in "
              f"{time.perf_counter() - compile_start:.0f} s)")
        reference = reference_run(mech, programs, folder, t_end, dt_out)
        kinds = ["depsim", "ep", "ep-project"] + (["angles", "quat"] if mech.free else ["joint"])
        results = measure(mech, kinds, programs, folder, args, t_end, dt_out)
        rows = table(title, mech, results, reference, kinds, args.tols)
        equal_accuracy(rows, kinds)
        if args.instructions:
            instructions(mech, kinds, programs, folder,
                         1e-8 if 1e-8 in args.tols else args.tols[0], t_end)
        summary.append((mech, rows))
    chains = [(m, rows) for m, rows in summary if m.name.startswith("chain")]
    if len(chains) > 1:
        tol = 1e-8 if 1e-8 in args.tols else args.tols[0]
        kinds = ["depsim", "ep", "ep-project", "joint"]
        short = {"depsim": "depsim", "ep": "EP+Baumgarte", "ep-project": "EP+projection",
                 "joint": "joint (ABA)"}
        print(f"\nchains at tol {tol:g}: ns per evaluation alone | us per step of the run, and "
              f"the growth exponent from N = {len(chains[0][0].bodies)} to "
              f"{len(chains[-1][0].bodies)}")
        print(f"{'N':>5} " + " ".join(f"{short[k]:>23}" for k in kinds))
        found = {}
        for mech, rows in chains:
            cells = []
            for kind in kinds:
                row = next((r for r in rows if r["kind"] == kind and r["tol"] == tol), None)
                if row:
                    found.setdefault(kind, []).append(
                        (len(mech.bodies), row["rhs_ns"], 1e6 * row["cpu"] / row["steps"]))
                    cells.append(f"{row['rhs_ns']:>9.0f} | {1e6 * row['cpu'] / row['steps']:>8.1f}")
                else:
                    cells.append("-")
            print(f"{len(mech.bodies):>5} " + " ".join(f"{c:>23}" for c in cells))
        cells = []
        for kind in kinds:
            points = found.get(kind, [])
            if len(points) > 1:
                (n1, e1, s1), (n2, e2, s2) = points[0], points[-1]
                cells.append(f"n^{math.log(e2 / e1) / math.log(n2 / n1):.2f} | "
                             f"n^{math.log(s2 / s1) / math.log(n2 / n1):.2f}")
            else:
                cells.append("-")
        print(f"{'exp.':>5} " + " ".join(f"{c:>23}" for c in cells))
    print(f"\nbench_formulation: {time.perf_counter() - started:.0f} s; {load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
