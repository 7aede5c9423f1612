"""Benchmark the targets: wall time per simulated second of INTELSAT V and the two flexible
links, at each model's own tolerance, side by side in one run:

    c-library   depsim.runtime.simulate on the C target: the core with the compiled model
                (the Result built in Python)
    c-program   the standalone program of the C target folder (process start, CSV written)
    numpy       depsim.runtime.simulate on the NumPy module: the same core, the model's
                functions called back in Python
    scipy       the test suite's reference solver (tests/references/direct.py): scipy
                solve_ivp (DOP853) on the index-1 equations, factorising the augmented matrix
                at every evaluation (friction by the regularised law, no latches)

Each time is the median of --repeat runs; ratios are to the C library (higher: slower).

    .venv/bin/python bench/bench_backends.py
    .venv/bin/python bench/bench_backends.py --repeat 1 --t-end intelsat5=2 \
        --t-end two_link_flex=0.005
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the reference solver
MODELS = {"intelsat5": 10.0, "two_link_flex": 0.02}  # default simulated time (s)
BACKENDS = ("c-library", "c-program", "numpy", "scipy")


def median_time(run, repeat: int) -> float:
    """Median wall time (s) of `repeat` calls of run()."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def prepare(name: str, folder: Path):
    """The NumPy module, the C module (library) and the built program of examples/<name>."""
    from depsim.codegen import compile_c, compile_numpy, derive, load_generated
    from depsim.codegen.c_emit import c_program_name
    from depsim.dsl import load_model
    from depsim.runtime.binding import load_folder

    model = load_model(ROOT / "examples" / f"{name}.dep")
    system = derive(model)
    numpy_module = load_generated(compile_numpy(model, folder / "numpy", system))
    c_folder = compile_c(model, folder / "c", system)
    subprocess.run(["make", "-s", "-C", str(c_folder), c_program_name(model)], check=True)
    return numpy_module, load_folder(c_folder), c_folder / c_program_name(model)


def runners(numpy_module, c_module, program: Path, t_end: float, out: Path) -> dict:
    from depsim.runtime import simulate
    from references.direct import solve_direct

    def direct():
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")  # solve_ivp's rejected trial steps overflow
            solve_direct(numpy_module, t_end=t_end)

    return {
        "c-library": lambda: simulate(c_module, t_end=t_end),
        "c-program": lambda: subprocess.run([str(program), "--t-end", repr(t_end), "-o",
                                             str(out)], check=True, stdout=subprocess.DEVNULL),
        "numpy": lambda: simulate(numpy_module, t_end=t_end),
        "scipy": direct,
    }


def bench(name: str, t_end: float, repeat: int, backends) -> list[dict]:
    with tempfile.TemporaryDirectory() as tmp:
        numpy_module, c_module, program = prepare(name, Path(tmp))
        run = runners(numpy_module, c_module, program, t_end, Path(tmp) / "out.csv")
        rows = []
        for backend in backends:
            seconds = median_time(run[backend], repeat)
            rows.append({"model": name, "backend": backend, "t_end": t_end, "repeat": repeat,
                         "median_s": seconds, "per_simulated_s": seconds / t_end})
    base = next((r["median_s"] for r in rows if r["backend"] == "c-library"), None)
    for row in rows:
        row["vs_c_library"] = row["median_s"] / base if base else float("nan")
    return rows


def table(rows: list[dict]) -> str:
    lines = [f"{'model':<14} {'backend':<10} {'t_end s':>8} {'median s':>10} "
             f"{'s per sim. s':>13} {'x C library':>12}"]
    for r in rows:
        lines.append(f"{r['model']:<14} {r['backend']:<10} {r['t_end']:>8.3g} "
                     f"{r['median_s']:>10.4g} {r['per_simulated_s']:>13.4g} "
                     f"{r['vs_c_library']:>12.1f}")
    return "\n".join(lines)


def parse_t_end(items: list[str]) -> dict[str, float]:
    t_end = dict(MODELS)
    for item in items:
        name, _, value = item.partition("=")
        if name not in MODELS or not value:
            raise SystemExit(f"--t-end {item!r}: expected MODEL=SECONDS, MODEL one of "
                             f"{', '.join(MODELS)}")
        t_end[name] = float(value)
    return t_end


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs per backend (median; 5)")
    parser.add_argument("--t-end", action="append", default=[], metavar="MODEL=SECONDS",
                        help="simulated time per model (intelsat5=10, two_link_flex=0.02)")
    parser.add_argument("--models", default=",".join(MODELS), help="comma-separated models")
    parser.add_argument("--backends", default=",".join(BACKENDS), help="comma-separated")
    parser.add_argument("--json", metavar="PATH", help="also write the rows as JSON")
    args = parser.parse_args(argv)
    t_end = parse_t_end(args.t_end)
    backends = [b for b in args.backends.split(",") if b]
    unknown = set(backends) - set(BACKENDS)
    if unknown:
        raise SystemExit(f"unknown backends: {', '.join(sorted(unknown))}")
    rows = []
    for name in filter(None, args.models.split(",")):
        rows += bench(name, t_end[name], args.repeat, backends)
        print(table([r for r in rows if r["model"] == name]), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
