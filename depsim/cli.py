"""The `depsim` command line.

Exit codes: 0 ok, 1 model error, 2 usage error, 3 solver failure. Errors go to stderr, data
to stdout; no traceback reaches the user for anything they caused.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

EXIT_OK, EXIT_MODEL, EXIT_USAGE, EXIT_SOLVER = 0, 1, 2, 3


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    try:
        return args.command(args)
    except KeyboardInterrupt:
        print("depsim: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # stdout closed early (`depsim run ... | head`): not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except Exception as exc:  # map every user-caused failure to its exit code
        code = _report(exc)
        if code is None:
            raise
        return code


def _report(exc: Exception) -> int | None:
    """Print a user-facing error for `exc`; its exit code, or None for a bug."""
    from depsim.codegen import CodegenError
    from depsim.dsl import ModelError, format_diagnostics
    from depsim.errors import UsageError
    from depsim.runtime import SolverError
    from depsim.runtime.core import CBuildError
    from depsim.runtime.sweep import CheckpointError, StudyError, SweepSpecError

    if isinstance(exc, ModelError):
        print(format_diagnostics(exc.diagnostics, exc.source), file=sys.stderr, end="")
        return EXIT_MODEL
    # (exception types, message prefix, exit code): everything else the user can cause
    outcomes = [((CodegenError,), "error", EXIT_MODEL),
                ((UsageError, CBuildError, SweepSpecError, CheckpointError), "error", EXIT_USAGE),
                ((StudyError,), "study stopped", EXIT_SOLVER),
                ((SolverError,), "solver failure", EXIT_SOLVER)]
    for types, prefix, code in outcomes:
        if isinstance(exc, types):
            print(f"depsim: {prefix}: {exc}", file=sys.stderr)
            return code
    return None


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="depsim", description="Model, compile and simulate deployable mechanisms.")
    from depsim import __version__
    parser.add_argument("--version", action="version", version=f"depsim {__version__}")
    commands = parser.add_subparsers(title="commands", required=True, metavar="COMMAND")

    check = commands.add_parser("check", help="check a model and print its summary")
    check.add_argument("model", help="the .dep file")
    check.set_defaults(command=_check)

    compile_ = commands.add_parser("compile", help="generate code for a model")
    compile_.add_argument("model", help="the .dep file")
    compile_.add_argument("--target", choices=["numpy", "c"], default="numpy",
                          help="numpy: a Python module; c: a standalone C folder (make -C DIR)")
    compile_.add_argument("-o", "--out", required=True, metavar="DIR", help="output folder")
    _add_elements(compile_)
    compile_.set_defaults(command=_compile)

    run = commands.add_parser("run", help="compile and simulate a model")
    run.add_argument("model", help="the .dep file")
    run.add_argument("--target", choices=["numpy", "c"], default="numpy",
                     help="numpy (default: a Python module) or c (a compiled model); both run "
                          "on the compiled integrator core")
    run.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                     help="override a parameter, units allowed (h1.preload=1.5N*m); repeatable")
    run.add_argument("--t-end", type=_positive_float, metavar="T", help="end time (s)")
    run.add_argument("--dt-out", type=_positive_float, metavar="DT", help="output interval (s)")
    run.add_argument("--tol", type=_positive_float, metavar="TOL", help="integration tolerance")
    run.add_argument("-o", "--out", metavar="CSV", help="write outputs to a CSV file")
    run.add_argument("--summary", metavar="JSON", help="write a JSON run summary")
    run.add_argument("--plot", metavar="PNG", help="plot every output against time")
    run.add_argument("--animate", metavar="GIF", help="animate the mechanism moving")
    _add_elements(run)
    run.set_defaults(command=_run)

    sweep = commands.add_parser("sweep", help="run a parameter study (grid or Monte Carlo)")
    sweep.add_argument("model", help="the .dep file")
    sweep.add_argument("--target", choices=["numpy", "c"], default="c",
                       help="c (default: compiled model) or numpy")
    sweep.add_argument("--grid", action="append", default=[], metavar="NAME=START:STOP:N",
                       help="a grid axis; several axes give the full factorial; repeatable")
    sweep.add_argument("--sample", action="append", default=[], metavar="NAME=DIST(...)",
                       help="normal(MU,SIGMA), uniform(A,B), lognormal(MEDIAN,SIGMA_LN), "
                            "triangular(A,MODE,B); repeatable")
    sweep.add_argument("--runs", type=_positive_int, help="Monte Carlo runs")
    sweep.add_argument("--seed", type=_natural_int, help="random seed (stored in the file)")
    sweep.add_argument("--workers", type=_positive_int, help="local worker processes")
    sweep.add_argument("--scheduler", metavar="URL", help="a Dask scheduler, tcp://HOST:PORT")
    sweep.add_argument("--t-end", type=_positive_float, metavar="T", help="end time (s)")
    sweep.add_argument("--dt-out", type=_positive_float, metavar="DT", help="output interval (s)")
    sweep.add_argument("--tol", type=_positive_float, metavar="TOL", help="integration tolerance")
    sweep.add_argument("--time-grid", type=_positive_int, metavar="N",
                       help="also store every output at N times")
    sweep.add_argument("-o", "--out", metavar="NC", help="NetCDF file (default MODEL-sweep.nc)")
    sweep.add_argument("--plot", metavar="PNG", help="histograms and scatter plots")
    sweep.add_argument("--resume", action="store_true", help="complete an interrupted study")
    _add_elements(sweep)
    sweep.set_defaults(command=_sweep)
    return parser


def _add_elements(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--elements", type=_elements, default={}, metavar="BEAM=N,...",
                        help="beam element counts, e.g. link1=8,link2=8")


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"'{text}' must be a positive number")
    return value


def _positive_int(text: str) -> int:
    if not text.strip().isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"'{text}' must be a positive integer")
    return int(text)


def _natural_int(text: str) -> int:
    if not text.strip().isdigit():
        raise argparse.ArgumentTypeError(f"'{text}' must be a non-negative integer")
    return int(text)


def _elements(text: str) -> dict[str, int]:
    counts = {}
    for item in filter(None, text.split(",")):
        name, sep, count = item.partition("=")
        if not sep or not count.strip().isdigit() or int(count) < 1:
            raise argparse.ArgumentTypeError(
                f"'{item}' is not BEAM=N with N a positive integer (e.g. link1=8)")
        counts[name.strip()] = int(count)
    return counts


def _settings(items: list[str]) -> dict[str, str]:
    from depsim.errors import UsageError

    settings = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise UsageError(f"--set '{item}': expected NAME=VALUE, e.g. --set h2.friction=0.7")
        settings[name.strip()] = value.strip()
    return settings


def _load(args):
    import depsim

    model = depsim.load(args.model)
    _print_warnings(model)
    return model.with_elements(args.elements) if getattr(args, "elements", None) else model


def _print_warnings(model) -> None:
    from depsim.dsl import format_diagnostics

    if model.ir.warnings:
        source = Path(model.path).read_text(encoding="utf-8")
        print(format_diagnostics(model.ir.warnings, source), file=sys.stderr, end="")


def _check(args) -> int:
    from depsim.dsl import summary

    model = _load(args)
    print(summary(model.ir))
    return EXIT_OK


def _compile(args) -> int:
    model = _load(args)
    if args.target == "c":
        from depsim.codegen import compile_c
        from depsim.codegen.c_emit import c_program_name

        folder = compile_c(model.ir, Path(args.out))
        print(f"wrote {folder}: build with `make -C {folder}`, "
              f"run `{folder}/{c_program_name(model.ir)} --help`")
        return EXIT_OK
    from depsim.codegen import compile_numpy

    print(f"wrote {compile_numpy(model.ir, Path(args.out))}")
    return EXIT_OK


def _run(args) -> int:
    model = _load(args)
    settings = _settings(args.set)
    sim = model.compile(target=args.target)
    result = sim.run(set=settings, t_end=args.t_end, dt_out=args.dt_out, tol=args.tol,
                     progress=True)
    if args.out:
        result.to_csv(args.out)
    if args.summary:
        result.to_json(args.summary)
    if args.plot:
        from depsim.runtime.plot import plot_outputs
        plot_outputs(result, args.plot)
    if args.animate:
        from depsim.runtime import animate
        animate(result, sim.module, args.animate)
    print(result.report())
    return EXIT_OK


def _sweep(args) -> int:
    import depsim
    from depsim.runtime.sweep import plot_study, summarize

    sim = _load(args).compile(target=args.target)
    out = args.out or f"{Path(args.model).stem}-sweep.nc"
    study = depsim.sweep(sim, grid=args.grid, samples=args.sample, runs=args.runs,
                         seed=args.seed, t_end=args.t_end, dt_out=args.dt_out, tol=args.tol,
                         time_grid=args.time_grid, workers=args.workers,
                         scheduler=args.scheduler, out=out, resume=args.resume)
    print(summarize(study))
    if args.plot:
        plot_study(study, args.plot)
    print(f"wrote {out}")
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
