"""The INTELSAT V Monte Carlo study (10,000 runs, seven spread parameters): its wall time as a
whole `depsim sweep` command, the solver's time a run, and the costs around it.

    .venv/bin/python bench/bench_sweep.py                          # 10,000 runs, 3 rounds
    .venv/bin/python bench/bench_sweep.py --runs 1000 --repeat 1 --probe 100
    .venv/bin/python bench/bench_sweep.py --against ../other-worktree   # two revisions

Every round runs these whole processes, in an order that turns from round to round, so that
the machine's changing speed (2 shared cores) falls on all of them alike:

* the study: `depsim sweep examples/intelsat5.dep --sample ... --runs N --seed 1 -o FILE.nc`
  (SAMPLES below; the C target, one worker process per core);
* the same command for 2 runs: the command's fixed cost (start-up, the model from the code
  cache, the worker processes, the summary, a NetCDF file) with one run on each worker;
* the probe (this file, --probe P): the study's first P runs in one process, in batches as a
  study's worker runs them (`run_batch`), the CPU time of its `dep_simulate` calls (the
  solver), of its metrics and of the rest (the run's end read, the record: "recording"); then
  what the parent does with them: their checkpoint lines (JSON, written and synced a batch at
  a time), and an N-run dataset, its NetCDF file and its summary (the probe's runs over
  again), the first time (with their imports: fixed cost) and the second; and a study
  worker's start-up, a process of its own (interpreter, imports, the model's library);
* with --against TREE, the same three for the depsim installed in another git worktree (its
  .venv), and at the end whether the two studies hold the same numbers;
* the hand-written INTELSAT V solver (tests/references/intelsat_hand.c, 0-80 s, no rows),
  the machine's speed in this hour: compare other hours' figures by it.

The figures are medians over the rounds. "predicted" adds the fixed cost, the runs' work on
the workers (solver, recording, metrics) and the parent's (checkpoint lines) shared by the
cores, and the dataset, file and summary made after the last run; what the study takes
beyond it is scheduling and the cores' contention (with other processes' work too).
"""

from __future__ import annotations

import argparse
import json
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


def study_command(python: str, tree: Path, runs: int, out: Path,
                  workers: int | None) -> list[str]:
    """The `depsim sweep` command of the study, by the depsim of `python` (installed from
    the worktree `tree`)."""
    command = [python, "-m", "depsim", "sweep", str(tree / MODEL.relative_to(ROOT))]
    for item in SAMPLES:
        command += ["--sample", item]
    command += ["--runs", str(runs), "--seed", str(SEED), "-o", str(out)]
    return command + (["--workers", str(workers)] if workers else [])


def timed(command: list[str], env: dict | None = None,
          cwd: Path | None = None) -> tuple[float, str]:
    """Wall time of a whole process (s) and its standard output."""
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, cwd=cwd, env=env)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command[:4])} ... failed:\n{done.stderr}")
    return wall, done.stdout


# ---- the probe: one process, the study's first runs one at a time ---------------------------

def probe(model: Path, runs: int, count: int) -> dict:
    """Per-run times (s) of the study's first `count` runs as a study's worker runs them
    (`run_batch`, batches of BATCH): the solver (its `dep_simulate` calls), the metrics, the
    rest (the run's end read, the record); the parent's checkpoint lines; the N-run dataset
    and file."""
    import depsim
    from depsim.runtime import runner
    from depsim.runtime.sweep import Study, make_design, summarize
    from depsim.runtime.sweep import study as studies
    from depsim.runtime.sweep import worker
    from depsim.runtime.sweep.storage import Checkpoint
    try:  # the study as plain arrays, written with h5netcdf alone
        from depsim.runtime.sweep.storage import build_table as build
        from depsim.runtime.sweep.table import write_table as write
    except ImportError:  # a tree before them: the xarray Dataset and its writer
        from depsim.runtime.sweep.storage import build_dataset as build
        from depsim.runtime.sweep.storage import write_dataset as write

    sim = depsim.load(model).compile("c")
    design = make_design(tuple(sim.parameter_names), sim.defaults, samples=SAMPLES, runs=runs,
                         seed=SEED)
    plan = studies._plan(Study(Path(sim.module.__file__), design))
    clock = time.thread_time  # CPU time: what a run takes from a core, whatever else runs
    spent = {"solver": 0.0, "metrics": 0.0}
    calls: list[float] = []  # each dep_simulate call's time

    def timed(function, part):
        def call(*args, **kwargs):
            start = clock()
            try:
                return function(*args, **kwargs)
            finally:
                spent[part] += clock() - start
                if part == "solver":
                    calls.append(clock() - start)
        return call

    class TimedCore:  # the core library, its dep_simulate timed (where the runner calls it)
        def __init__(self, library):
            self.library, self.dep_simulate = library, timed(library.dep_simulate, "solver")

        def __getattr__(self, name):
            return getattr(self.library, name)

    library = TimedCore(runner.core())
    runner.core, worker.evaluate = (lambda: library), timed(worker.evaluate, "metrics")
    metrics, rest, records = [], [], []
    for first in range(0, min(count, runs), BATCH):
        batch = list(range(first, min(first + BATCH, count, runs)))
        spent.update(solver=0.0, metrics=0.0)
        start = clock()
        records += worker.run_batch(plan.ref, plan.config, batch, design.matrix[batch])
        total = clock() - start
        metrics.append(spent["metrics"] / len(batch))
        rest.append((total - spent["solver"] - spent["metrics"]) / len(batch))
    with tempfile.TemporaryDirectory() as folder:
        checkpoint = Checkpoint(Path(folder) / "study.nc.partial", plan.fingerprint, runs)
        checkpoint.open({})
        start = clock()
        for first in range(0, len(records), BATCH):
            checkpoint.append(records[first:first + BATCH])
        lines = (clock() - start) / len(records)
        checkpoint.close()
        every = {i: dict(records[i % len(records)], run=i) for i in range(runs)}
        first = {}
        for _ in range(2):  # the first time pays the imports (the fixed cost): timed the second
            start = time.perf_counter()
            ds = build(every, design, static_metrics=plan.static, user_metrics=[],
                       output_names=plan.outputs, time_grid=None, attrs=plan.attrs,
                       describe=plan.describe, parameter_units=plan.parameter_units)
            built = time.perf_counter()
            write(ds, Path(folder) / "study.nc")
            written = time.perf_counter()
            summarize(ds)
            summarized = time.perf_counter()
            first = first or {"dataset_first": built - start, "netcdf_first": written - built,
                              "summary_first": summarized - written}
    return {"solver_mean": statistics.fmean(calls), "solver_median": statistics.median(calls),
            "recording": statistics.median(rest), "metrics": statistics.median(metrics),
            "checkpoint": lines, "dataset": (built - start) / runs,
            "netcdf": (written - built) / runs, "summary": (summarized - written) / runs,
            "probed": len(calls), **first, "worker_start": worker_start(sim.module.__file__),
            "failed": sum(1 for r in records if r["failed"])}


def worker_start(library: str, rounds: int = 5) -> float:
    """A study worker's start-up (s, median wall time of `rounds` processes): the interpreter,
    the imports of `depsim.runtime.sweep.worker` and the model's library loaded as a pool
    worker's initializer loads it, in a process of its own (this python: this tree's)."""
    code = ("from depsim.runtime.sweep import worker; "
            f"worker.load_module(worker.ModuleRef.from_path({library!r}))")
    env = {**os.environ, **SINGLE_THREAD}
    return statistics.median(timed([sys.executable, "-c", code], env=env)[0]
                             for _ in range(rounds))


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

SINGLE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}  # as a study's workers


def tree_jobs(args, tree: Path, python: str, folder: Path) -> dict:
    """The study, its fixed cost and the probe of the depsim installed in `tree` (its python)."""
    env = {**os.environ, **SINGLE_THREAD}
    return {
        "study": lambda: timed(study_command(python, tree, args.runs, folder / "study.nc",
                                             args.workers), cwd=tree),
        "fixed": lambda: timed(study_command(python, tree, 2, folder / "two.nc", args.workers),
                               cwd=tree),
        "probe": lambda: timed([python, __file__, "--runs", str(args.runs), "--probe",
                                str(args.probe), "--probe-only", "--model",
                                str(tree / MODEL.relative_to(ROOT))], env=env, cwd=tree),
    }


def rounds(args, folder: Path) -> tuple[dict[str, dict[str, list]], list[Path]]:
    """Each measurement once a round, in an order that turns from round to round: this
    tree's, the other tree's (--against), the hand-written solver's."""
    trees = {"this": (ROOT, sys.executable)}
    if args.against:
        other = Path(args.against).resolve()
        trees["against"] = (other, str(other / ".venv" / "bin" / "python"))
    jobs, studies = {}, []
    for label, (tree, python) in trees.items():
        (folder / label).mkdir()
        studies.append(folder / label / "study.nc")
        for name, job in tree_jobs(args, tree, python, folder / label).items():
            jobs[(label, name)] = job
    hand = hand_solver(folder)
    if hand is not None:
        jobs[("machine", "hand")] = lambda: (statistics.median(timed(hand)[0]
                                                               for _ in range(21)), "")
    seen: dict[str, dict[str, list]] = {}
    order = list(jobs)
    for k in range(args.repeat):
        for label, name in order[k % len(order):] + order[:k % len(order)]:
            wall, text = jobs[(label, name)]()
            mine = seen.setdefault(label, {})
            mine.setdefault(name, []).append(json.loads(text) if name == "probe" else wall)
            print(f"  round {k + 1}: {label} {name} {wall:.3f} s", file=sys.stderr, flush=True)
            if name == "study":
                mine.setdefault("study_solver", []).append(
                    study_solver(folder / label / "study.nc"))
    return seen, studies


def study_solver(path: Path) -> float:
    """The median of the study's own `wall_time`s: a run's time inside its worker, with both
    cores busy."""
    from depsim.runtime.sweep import open_study

    return float(open_study(path)["wall_time"].median())


def same_studies(paths: list[Path]) -> bool:
    """Whether the studies hold the same numbers (every variable and coordinate but the runs'
    wall times; NaN equal to NaN)."""
    from depsim.runtime.sweep import open_study

    first, *others = [open_study(path).drop_vars("wall_time") for path in paths]
    return all(first.equals(other) for other in others)


def report(args, seen: dict[str, list], label: str) -> dict:
    """Print the figures of one tree's measurements; return them."""
    workers = args.workers or len(os.sched_getaffinity(0))
    median = statistics.median
    probes = seen["probe"]
    part = {key: median(p[key] for p in probes) for key in probes[0] if key != "failed"}
    study, fixed = median(seen["study"]), median(seen["fixed"])
    setup = fixed - part["solver_mean"]  # the 2-run command less its runs (one a worker)
    per_worker_run = part["solver_mean"] + part["recording"] + part["metrics"] \
        + part["checkpoint"]
    written = part["dataset"] + part["netcdf"] + part["summary"]
    predicted = setup + args.runs * per_worker_run / workers + args.runs * written
    floor = args.runs * part["solver_mean"] / workers
    out = {"runs": args.runs, "workers": workers, "rounds": args.repeat, "study_s": study,
           "runs_per_s": args.runs / study, "fixed_s": setup, "predicted_s": predicted,
           "solver_floor_s": floor, "study_solver_median_s": median(seen["study_solver"]),
           **{f"{key}_s": value for key, value in part.items() if key != "probed"},
           "probed": probes[0]["probed"]}
    ms = 1e3
    print(f"{label}")
    print(f"  whole `depsim sweep` command        {study:8.2f} s   ({args.runs / study:.0f} "
          "runs/s; NetCDF written)")
    print(f"  solver, a run (dep_simulate)        {ms * part['solver_mean']:8.3f} ms mean, "
          f"{ms * part['solver_median']:.3f} ms median (CPU time, the first {out['probed']} "
          "runs)")
    print(f"    {args.runs:,} runs of it on {workers} workers {floor:10.2f} s   (the floor "
          "without any other cost)")
    print(f"    inside the study's workers        {ms * out['study_solver_median_s']:8.3f} ms "
          "median (its wall_time: both cores busy)")
    print(f"  fixed cost: process and setup       {setup:8.2f} s   (the 2-run command less a "
          "run: start-up, model, workers, summary, file)")
    if "worker_start" in part:
        print(f"    a worker's start (process, imports, model) {part['worker_start']:6.3f} s")
        print(f"    the first dataset, NetCDF, summary {part['dataset_first']:6.3f}, "
              f"{part['netcdf_first']:.3f}, {part['summary_first']:.3f} s  (parent: their "
              "imports, probe's runs)")
    print("  cost a run beyond the solver (CPU time)")
    print(f"    recording (run's end, record)     {ms * part['recording']:8.3f} ms  (worker)")
    print(f"    metrics                           {ms * part['metrics']:8.3f} ms  (worker)")
    print(f"    checkpoint line                   {ms * part['checkpoint']:8.3f} ms  (parent)")
    print(f"    dataset, NetCDF, summary          {ms * written:8.3f} ms  (parent, after the "
          f"runs: {args.runs * written:.2f} s)")
    overhead = predicted - floor
    print(f"  predicted {predicted:.2f} s = solver {floor:.2f} s + everything else "
          f"{overhead:.2f} s; the study took {study - predicted:+.2f} s more (scheduling, "
          "contention)")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000, help="runs of the study (10,000)")
    parser.add_argument("--repeat", type=int, default=3, help="rounds (3)")
    parser.add_argument("--workers", type=int, default=None, help="worker processes (a core "
                        "each)")
    parser.add_argument("--probe", type=int, default=400,
                        help="runs the probe times one at a time (400)")
    parser.add_argument("--against", metavar="TREE", help="also measure the depsim of another "
                        "git worktree (its .venv), interleaved, and compare the studies' numbers")
    parser.add_argument("--json", metavar="PATH", help="also write the figures as JSON")
    parser.add_argument("--probe-only", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--model", default=str(MODEL), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.probe_only:  # a round's probe process: its figures as JSON on stdout
        print(json.dumps(probe(Path(args.model), args.runs, args.probe)))
        return 0
    workers = args.workers or len(os.sched_getaffinity(0))
    print(f"INTELSAT V study: {args.runs:,} runs, {len(SAMPLES)} spread parameters, {workers} "
          f"workers on {os.cpu_count()} cores; medians of {args.repeat} round"
          f"{'s' * (args.repeat != 1)} of whole processes, interleaved", flush=True)
    with tempfile.TemporaryDirectory() as folder:
        seen, studies = rounds(args, Path(folder))
        out = {label: report(args, seen[label], title)
               for label, title in (("this", f"this tree ({ROOT})"),
                                    ("against", f"against {args.against}"))
               if label in seen}
        if args.against:
            out["identical"] = same_studies(studies)
            ratio = out["this"]["study_s"] / out["against"]["study_s"]
            print(f"this tree / against: study {ratio:.3f}, solver "
                  f"{out['this']['solver_mean_s'] / out['against']['solver_mean_s']:.3f}; "
                  f"the two studies' numbers identical (all but wall_time): "
                  f"{'yes' if out['identical'] else 'NO'}")
    if seen.get("machine"):
        out["hand_solver_s"] = statistics.median(seen["machine"]["hand"])
        print(f"the machine this hour: the hand-written solver, 0-80 s, no rows: "
              f"{1e3 * out['hand_solver_s']:.2f} ms a process")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
