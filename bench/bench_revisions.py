"""The standalone C programs of two revisions of depsim, side by side in one run: the same
models compiled by each revision's own code (its codegen and its core), timed as whole
processes, interleaved, and their outputs compared byte for byte.

    .venv/bin/python bench/bench_revisions.py --against fc5c18e            # vs a commit
    .venv/bin/python bench/bench_revisions.py --against main~3 --repeat 31 --model accordion

The other revision is checked out into a temporary git worktree with a virtual environment of
its own (its `pip install -e .`, a minute or two). Each model runs with its own settings,
writing its CSV (rows) and with `--dt-out` at its end time (no rows: the solver's own cost
with the process start). Medians of `--repeat` runs; the ratio is this tree's over the other.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODELS = ("intelsat5", "accordion", "two_link_flex")


def install(worktree: Path) -> Path:
    """A virtual environment with the worktree's depsim installed; its python."""
    venv = worktree / ".venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    subprocess.run([str(venv / "bin" / "pip"), "install", "--quiet", "-e", str(worktree)],
                   check=True)
    return venv / "bin" / "python"


def build(python: Path, model: str, folder: Path) -> Path:
    """The model's standalone program, compiled by that depsim."""
    subprocess.run([str(python), "-m", "depsim", "compile", str(ROOT / "examples" / f"{model}.dep"),
                    "--target", "c", "-o", str(folder)], check=True, capture_output=True,
                   env={"DEPSIM_CACHE": str(folder.parent / "cache"), "PATH": "/usr/bin:/bin"})
    subprocess.run(["make", "-s", "-j2", "-C", str(folder)], check=True)
    return folder / model


def end_time(program: Path) -> str:
    """The model's t_end, from the program's --help."""
    text = subprocess.run([str(program), "--help"], capture_output=True, text=True).stdout
    return text.split("--t-end T         end time, s (default ")[1].split(")")[0]


def timed(program: Path, arguments: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run([str(program), *arguments], check=True, capture_output=True)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", required=True, help="the other revision (a git commit)")
    parser.add_argument("--repeat", type=int, default=15)
    parser.add_argument("--model", action="append", choices=MODELS)
    args = parser.parse_args()
    models = args.model or list(MODELS)
    with tempfile.TemporaryDirectory(prefix="depsim-revisions-") as scratch:
        scratch = Path(scratch)
        other = scratch / "other"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(other),
                        args.against], check=True, capture_output=True)
        try:
            print(f"installing {args.against} into a worktree ...", flush=True)
            python = {"this": Path(sys.executable), "other": install(other)}
            print(f"{'model':14} {'rows':5} {'this (ms)':>10} {'other (ms)':>11} "
                  f"{'ratio':>6}  outputs")
            for model in models:
                programs = {name: build(python[name], model, scratch / name / model)
                            for name in ("this", "other")}
                t_end = end_time(programs["this"])
                for rows, extra in (("yes", []), ("no", ["--dt-out", t_end])):
                    times = {"this": [], "other": []}
                    for k in range(args.repeat):
                        for name in ("this", "other") if k % 2 == 0 else ("other", "this"):
                            out = scratch / f"{name}-{model}.csv"
                            times[name].append(timed(programs[name], [*extra, "-o", str(out)]))
                    same = ((scratch / f"this-{model}.csv").read_bytes()
                            == (scratch / f"other-{model}.csv").read_bytes())
                    this, that = (statistics.median(times[n]) for n in ("this", "other"))
                    print(f"{model:14} {rows:5} {1e3 * this:10.2f} {1e3 * that:11.2f} "
                          f"{this / that:6.3f}  {'byte for byte' if same else 'DIFFER'}",
                          flush=True)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                            str(other)], capture_output=True)


if __name__ == "__main__":
    main()
