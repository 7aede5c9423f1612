"""Benchmark parameter studies: runs per second of an INTELSAT V Monte Carlo on the local
process pool and on a Dask LocalCluster, and the share of wall time spent inside the solver.

    .venv/bin/python bench/bench_sweep.py                    # 1000 runs, both backends
    .venv/bin/python bench/bench_sweep.py --runs 20 --t-end 5 --backends pool

Solver share = (sum of the per-run wall time measured around `simulate` inside the workers)
/ (study wall time x workers): what is left is process start-up, module loading, scheduling,
result transfer, checkpointing and NetCDF writing.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# Spreads of the INTELSAT V deployment parameters (normal, about 10 % of the nominal value).
SAMPLES = [
    "h1.friction=normal(0.68, 0.068)", "h2.friction=normal(0.64, 0.064)",
    "h3.friction=normal(0.69, 0.069)", "h4.friction=normal(0.70, 0.070)",
    "h1.preload=normal(1.70, 0.17)", "h2.preload=normal(0.85, 0.085)",
    "cable_k=uniform(4000, 5000)",
]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=1000, help="Monte Carlo runs (1000)")
    parser.add_argument("--t-end", type=float, default=None, help="end time, s (model's)")
    parser.add_argument("--workers", type=int, default=None, help="processes (all cores)")
    parser.add_argument("--backends", default="pool,dask", help="pool, dask or both")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--batch-size", type=int, default=None)
    parser.add_argument("--model", default=str(ROOT / "examples" / "intelsat5.dep"))
    parser.add_argument("--target", choices=["c", "numpy"], default="c",
                        help="c: the compiled shared library (default); numpy")
    parser.add_argument("--json", metavar="PATH", help="also write the numbers as JSON")
    args = parser.parse_args(argv)

    from depsim.codegen import compile_c, compile_numpy
    from depsim.dsl import load_model
    from depsim.runtime import simulate
    from depsim.runtime.binding import build_model_library
    from depsim.runtime.sweep import Study, default_workers, load_module, make_design, run_study
    from depsim.runtime.sweep.metrics import evaluate

    workers = args.workers or default_workers()
    with tempfile.TemporaryDirectory() as tmp:
        model = load_model(args.model)
        if args.target == "c":
            module_path = build_model_library(compile_c(model, Path(tmp) / "generated"))
        else:
            module_path = compile_numpy(model, Path(tmp) / "generated")
        module = load_module(module_path)
        names = tuple(module.PARAMETERS)
        samples = [s for s in SAMPLES if s.split("=")[0] in names]
        design = make_design(names, module.PARAMETER_DEFAULTS, samples=samples, runs=args.runs,
                             seed=args.seed)
        start = time.perf_counter()
        first = simulate(module, design.matrix[0], t_end=args.t_end)
        single = time.perf_counter() - start
        first_metrics, _ = evaluate(first, module, None)
        report = {"model": module.MODEL_NAME, "target": args.target, "runs": args.runs, "workers": workers,
                  "cores": os.cpu_count(), "t_end": args.t_end, "single_run_s": single,
                  "backends": {}}
        print(f"{module.MODEL_NAME} ({args.target}): one run in this process {single:.3f} s "
              f"(serial estimate {args.runs * single:.1f} s for {args.runs} runs)")
        study = Study(module_path, design, t_end=args.t_end)
        for backend in [b.strip() for b in args.backends.split(",") if b.strip()]:
            out = Path(tmp) / f"{backend}.nc"
            if backend == "pool":
                t0 = time.perf_counter()
                ds = run_study(study, workers=workers, store=out, batch_size=args.batch_size)
                wall = time.perf_counter() - t0
            elif backend == "dask":
                from distributed import Client, LocalCluster

                with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                  dashboard_address=None, silence_logs=logging.ERROR) as cluster, \
                        Client(cluster) as client:
                    t0 = time.perf_counter()
                    ds = run_study(study, scheduler=client, store=out,
                                   batch_size=args.batch_size)
                    wall = time.perf_counter() - t0
            else:
                parser.error(f"unknown backend '{backend}' (pool, dask)")
            solver = float(ds["wall_time"].sum())
            same = all(float(ds[name].values[0]) == value for name, value in first_metrics.items())
            row = {"wall_s": wall, "runs_per_s": args.runs / wall,
                   "solver_s": solver, "solver_share": solver / (wall * workers),
                   "failed": int(ds["failed"].sum()), "run0_bit_for_bit": same}
            report["backends"][backend] = row
            print(f"{backend:5s}: {args.runs} runs in {wall:.2f} s = {row['runs_per_s']:.2f} "
                  f"runs/s; solver {solver:.2f} s = {100 * row['solver_share']:.1f} % of "
                  f"{workers} x wall; {row['failed']} failed; run 0 equals a single "
                  f"simulate bit for bit: {same}")
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
