"""The INTELSAT V Monte Carlo study (10,000 runs, seven spread parameters): its wall time as a
whole `depsim sweep` command, the solver's time a run, and the fixed costs around it.

    .venv/bin/python bench/bench_sweep.py                          # 10,000 runs, 3 rounds
    .venv/bin/python bench/bench_sweep.py --runs 1000 --repeat 1 --probe 100

Every round runs these whole processes, in an order that turns from round to round, so that
the machine's changing speed (2 shared cores) falls on all of them alike:

* the study: `depsim sweep examples/intelsat5.dep --sample ... --runs N --seed 1 -o FILE.nc`
  (SAMPLES below; the C target, one worker process per core);
* the same command for 2 runs: the command's fixed cost (start-up, the model from the code
  cache, the worker processes, the summary, a NetCDF file) with one run on each worker;
* the probe (this file, --probe P): the study's first P runs one at a time in one process,
  each first through the solver alone (`dep_simulate`, nothing read from its result), then as
  a study's worker runs it (`run_batch`: the solver, the run's end read, the metrics, the
  record); then what the parent does with the records: P checkpoint lines (JSON, written and
  synced a batch at a time), and an N-run dataset and its NetCDF file;
* the hand-written INTELSAT V solver (tests/references/intelsat_hand.c, 0-80 s, no rows),
  the machine's speed in this hour: compare other hours' figures by it.

The figures are medians over the rounds. "predicted" adds the fixed cost, the runs' work on
the workers (solver and worker's share) and the parent's (checkpoint lines) shared by the
cores, and the dataset and file written after the last run; what the study takes beyond it is
scheduling and the cores' contention.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "examples" / "intelsat5.dep"
HAND = ROOT / "tests" / "references" / "intelsat_hand.c"

# Spreads of the INTELSAT V deployment parameters (normal, about 10 % of the nominal value).
SAMPLES = [
    "h1.friction=normal(0.68, 0.068)", "h2.friction=normal(0.64, 0.064)",
    "h3.friction=normal(0.69, 0.069)", "h4.friction=normal(0.70, 0.070)",
    "h1.preload=normal(1.70, 0.17)", "h2.preload=normal(0.85, 0.085)",
    "cable_k=uniform(4000, 5000)",
]
SEED = 1
BATCH = 25  # runs a checkpoint append holds (the local pool's largest batch)


def study_command(runs: int, out: Path, workers: int | None) -> list[str]:
    """The `depsim sweep` command of the study."""
    command = [sys.executable, "-m", "depsim", "sweep", str(MODEL)]
    for item in SAMPLES:
        command += ["--sample", item]
    command += ["--runs", str(runs), "--seed", str(SEED), "-o", str(out)]
    return command + (["--workers", str(workers)] if workers else [])


def timed(command: list[str]) -> tuple[float, str]:
    """Wall time of a whole process (s) and its standard output."""
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command[:4])} ... failed:\n{done.stderr}")
    return wall, done.stdout


# ---- the probe: one process, the study's first runs one at a time ---------------------------

def probe(runs: int, count: int) -> dict:
    """Per-run times (s) of the study's first `count` runs: the solver alone and as a worker
    runs them, the metrics, the parent's checkpoint lines; the N-run dataset and file."""
    import numpy as np

    import depsim
    from depsim.runtime.core import core, ffi
    from depsim.runtime.sweep import Study, make_design
    from depsim.runtime.sweep import study as studies
    from depsim.runtime.sweep import worker
    from depsim.runtime.sweep.storage import Checkpoint, build_dataset, write_dataset

    sim = depsim.load(MODEL).compile("c")
    module = sim.module
    design = make_design(tuple(sim.parameter_names), sim.defaults, samples=SAMPLES, runs=runs,
                         seed=SEED)
    plan = studies._plan(Study(Path(module.__file__), design))
    view, library = ffi(), core()
    settings = view.new("dep_settings *", {
        "t_end": module.T_END, "dt_out": plan.config.dt_out or module.DT_OUT,
        "tol": module.TOL, "mechanics": 1, "max_steps": 0.0, "stepping": 0})
    metrics_time = [0.0]
    evaluate = worker.evaluate

    def timed_evaluate(*args, **kwargs):  # the worker's metrics, timed where it calls them
        start = time.perf_counter()
        try:
            return evaluate(*args, **kwargs)
        finally:
            metrics_time[0] += time.perf_counter() - start

    worker.evaluate = timed_evaluate
    solver, extra, metrics, records = [], [], [], []
    for index in range(min(count, runs)):
        p = np.ascontiguousarray(design.matrix[index])
        result, error = view.new("dep_result *"), view.new("dep_error *")
        start = time.perf_counter()
        status = library.dep_simulate(module.pointer, view.from_buffer("double[]", p), settings,
                                      view.NULL, 0, result, error)
        solver.append(time.perf_counter() - start)
        if status == library.DEP_OK:
            library.dep_result_free(result)
        metrics_time[0] = 0.0
        start = time.perf_counter()
        records += worker.run_batch(plan.ref, plan.config, [index], design.matrix[[index]])
        extra.append(time.perf_counter() - start - solver[-1])
        metrics.append(metrics_time[0])
    worker.evaluate = evaluate
    with tempfile.TemporaryDirectory() as folder:
        checkpoint = Checkpoint(Path(folder) / "study.nc.partial", plan.fingerprint, runs)
        checkpoint.open({})
        start = time.perf_counter()
        for first in range(0, len(records), BATCH):
            checkpoint.append(records[first:first + BATCH])
        lines = (time.perf_counter() - start) / len(records)
        checkpoint.close()
        every = {i: dict(records[i % len(records)], run=i) for i in range(runs)}
        for _ in range(2):  # the first time pays the imports (the fixed cost): timed the second
            start = time.perf_counter()
            ds = build_dataset(every, design, static_metrics=plan.static, user_metrics=[],
                               output_names=plan.outputs, time_grid=None, attrs=plan.attrs,
                               describe=plan.describe, parameter_units=plan.parameter_units)
            built = time.perf_counter()
            write_dataset(ds, Path(folder) / "study.nc")
            written = time.perf_counter()
    return {"solver_mean": statistics.fmean(solver), "solver_median": statistics.median(solver),
            "worker_extra": statistics.median(extra), "metrics": statistics.median(metrics),
            "checkpoint": lines, "dataset": (built - start) / runs,
            "netcdf": (written - built) / runs, "probed": len(solver),
            "failed": sum(1 for r in records if r["failed"])}


# ---- the hand-written solver: the machine's speed --------------------------------------------

def hand_solver(folder: Path) -> list[str] | None:
    """The hand-written solver's command (0-80 s, no rows), or None without a C compiler."""
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        return None
    program = folder / "intelsat_hand"
    subprocess.run([cc, "-O2", "-std=c99", "-o", str(program), str(HAND), "-lm"], check=True)
    return [str(program), "--t-end", "80", "--dt-out", "80", "-o", str(folder / "hand.csv")]


# ---- the rounds ----------------------------------------------------------------------------

def rounds(args, folder: Path) -> dict[str, list]:
    """Each measurement once a round, in an order that turns from round to round."""
    hand = hand_solver(folder)
    jobs = {
        "study": lambda: timed(study_command(args.runs, folder / "study.nc", args.workers)),
        "fixed": lambda: timed(study_command(2, folder / "two.nc", args.workers)),
        "probe": lambda: timed([sys.executable, __file__, "--runs", str(args.runs),
                                "--probe", str(args.probe), "--probe-only"]),
    }
    if hand is not None:
        jobs["hand"] = lambda: (statistics.median(timed(hand)[0] for _ in range(21)), "")
    seen: dict[str, list] = {name: [] for name in jobs}
    names = list(jobs)
    for k in range(args.repeat):
        for name in names[k % len(names):] + names[:k % len(names)]:
            wall, text = jobs[name]()
            seen[name].append(json.loads(text) if name == "probe" else wall)
            print(f"  round {k + 1}: {name} {wall:.3f} s", file=sys.stderr, flush=True)
            if name == "study":
                seen.setdefault("study_solver", []).append(study_solver(folder / "study.nc"))
    return seen


def study_solver(path: Path) -> float:
    """The median of the study's own `wall_time`s: a run's time inside its worker, with both
    cores busy."""
    from depsim.runtime.sweep import open_study

    return float(open_study(path)["wall_time"].median())


def report(args, seen: dict[str, list]) -> dict:
    workers = args.workers or len(os.sched_getaffinity(0))
    median = statistics.median
    probes = seen["probe"]
    part = {key: median(p[key] for p in probes) for key in probes[0] if key != "failed"}
    study, fixed = median(seen["study"]), median(seen["fixed"])
    setup = fixed - part["solver_mean"]  # the 2-run command less its runs (one a worker)
    per_worker_run = part["solver_mean"] + part["worker_extra"] + part["checkpoint"]
    written = part["dataset"] + part["netcdf"]
    predicted = setup + args.runs * per_worker_run / workers + args.runs * written
    floor = args.runs * part["solver_mean"] / workers
    out = {"runs": args.runs, "workers": workers, "rounds": args.repeat, "study_s": study,
           "runs_per_s": args.runs / study, "fixed_s": setup, "predicted_s": predicted,
           "solver_floor_s": floor, "study_solver_median_s": median(seen["study_solver"]),
           **{f"{key}_s": value for key, value in part.items() if key != "probed"},
           "probed": probes[0]["probed"]}
    if seen.get("hand"):
        out["hand_solver_s"] = median(seen["hand"])
    ms = 1e3
    print(f"INTELSAT V study: {args.runs:,} runs, {len(SAMPLES)} spread parameters, "
          f"{workers} workers on {os.cpu_count()} cores; medians of {args.repeat} round"
          f"{'s' * (args.repeat != 1)} of whole processes, interleaved")
    print(f"  whole `depsim sweep` command        {study:8.2f} s   ({args.runs / study:.0f} runs/s;"
          f" NetCDF written)")
    print(f"  solver, a run (dep_simulate alone)  {ms * part['solver_mean']:8.3f} ms mean, "
          f"{ms * part['solver_median']:.3f} ms median (the first {out['probed']} runs, one "
          f"process)")
    print(f"    {args.runs:,} runs of it on {workers} workers   {floor:8.2f} s   (the floor "
          f"without any other cost)")
    print(f"    inside the study's workers        {ms * out['study_solver_median_s']:8.3f} ms "
          f"median (wall_time: both cores busy)")
    print("  fixed cost of the command")
    print(f"    process and setup                 {setup:8.2f} s   (the 2-run command less "
          "its runs: start-up, model, workers, summary, file)")
    print("  cost a run beyond the solver")
    recording = part["worker_extra"] - part["metrics"]
    print(f"    recording (run's end, record)     {ms * recording:8.3f} ms  (in the worker)")
    print(f"    metrics                           {ms * part['metrics']:8.3f} ms  (in the worker)")
    print(f"    checkpoint line                   {ms * part['checkpoint']:8.3f} ms  (in the "
          "parent)")
    print(f"    dataset and NetCDF                {ms * written:8.3f} ms  (in the parent, after "
          f"the runs: {args.runs * written:.2f} s)")
    overhead = args.runs * (per_worker_run - part["solver_mean"]) / workers \
        + args.runs * written + setup
    print(f"  predicted {predicted:.2f} s = solver {floor:.2f} s + everything else "
          f"{overhead:.2f} s; the study took {study - predicted:+.2f} s beyond it "
          "(scheduling, contention)")
    if "hand_solver_s" in out:
        print(f"  the machine this hour: the hand-written solver, 0-80 s, no rows: "
              f"{ms * out['hand_solver_s']:.2f} ms a process")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000, help="runs of the study (10,000)")
    parser.add_argument("--repeat", type=int, default=3, help="rounds (3)")
    parser.add_argument("--workers", type=int, default=None, help="worker processes (a core "
                        "each)")
    parser.add_argument("--probe", type=int, default=400,
                        help="runs the probe times one at a time (400)")
    parser.add_argument("--json", metavar="PATH", help="also write the figures as JSON")
    parser.add_argument("--probe-only", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.probe_only:  # a round's probe process: its figures as JSON on stdout
        print(json.dumps(probe(args.runs, args.probe)))
        return 0
    with tempfile.TemporaryDirectory() as folder:
        seen = rounds(args, Path(folder))
    out = report(args, seen)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2) + "\n")
    return 0 if not math.isnan(out["study_s"]) else 1


if __name__ == "__main__":
    sys.exit(main())
