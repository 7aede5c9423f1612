"""The `depsim` command line.

Exit codes: 0 ok, 1 model error, 2 usage error, 3 solver failure. Errors go to stderr, data
to stdout; no traceback reaches the user for anything they caused. Every output path is
checked before anything runs, and a command writes all its output files or none
(depsim.runtime.output).
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


# (module, exception class, message prefix, exit code): everything the user can cause besides
# model errors and files. The classes are looked up among the modules already imported (an
# exception's class was imported to raise it): importing the stages to test an exception
# against them made every failing `depsim check` pay for sympy.
_OUTCOMES = (
    ("depsim.codegen.errors", "CodegenError", "error", EXIT_MODEL),
    ("depsim.errors", "UsageError", "error", EXIT_USAGE),
    ("depsim.runtime.core", "CBuildError", "error", EXIT_USAGE),
    ("depsim.runtime.sweep.spec", "SweepSpecError", "error", EXIT_USAGE),
    ("depsim.runtime.sweep.storage", "CheckpointError", "error", EXIT_USAGE),
    ("depsim.runtime.sweep.backends", "StudyError", "study stopped", EXIT_SOLVER),
    ("depsim.runtime.errors", "SolverError", "solver failure", EXIT_SOLVER),
    ("depsim.runtime.fit", "FitError", "fit failed", EXIT_SOLVER),
)


def _report(exc: Exception) -> int | None:
    """Print a user-facing error for `exc`; its exit code, or None for a bug."""
    model_error = _imported("depsim.dsl.errors", "ModelError")
    if model_error is not None and isinstance(exc, model_error):
        from depsim.dsl import format_diagnostics

        print(format_diagnostics(exc.diagnostics, exc.source), file=sys.stderr, end="")
        return EXIT_MODEL
    data_error = _imported("depsim.errors", "DataError")
    if data_error is not None and isinstance(exc, data_error):  # FILE:LINE: error: ...
        print(exc, file=sys.stderr)
        return EXIT_MODEL
    for module, name, prefix, code in _OUTCOMES:
        kind = _imported(module, name)
        if kind is not None and isinstance(exc, kind):
            print(f"depsim: {prefix}: {exc}", file=sys.stderr)
            return code
    if isinstance(exc, OSError):  # a file that cannot be written or read (OutputError too)
        print(f"depsim: error: {_os_message(exc)}", file=sys.stderr)
        return EXIT_USAGE
    return None


def _report_as_is(exc: Exception) -> bool:
    """Whether `exc` is one of the _OUTCOMES (reported with its own prefix and exit code)."""
    kinds = [_imported(module, name) for module, name, _, _ in _OUTCOMES]
    return isinstance(exc, tuple(kind for kind in kinds if kind is not None))


def _imported(module: str, name: str) -> type | None:
    return getattr(sys.modules.get(module), name, None)


def _os_message(exc: OSError) -> str:
    if exc.strerror and exc.filename is not None:
        return f"{exc.filename}: {exc.strerror}"
    return str(exc)


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
    compile_.add_argument("--target", choices=["numpy", "c", "fmu"], default="numpy",
                          help="numpy: a Python module; c: a standalone C folder (make -C DIR); "
                               "fmu: an FMI 2.0 Co-Simulation FMU (docs/fmu.md)")
    compile_.add_argument("-o", "--out", metavar="DIR",
                          help="output folder (numpy, c; required), or the .fmu file (fmu; "
                               "default MODEL.fmu in the current folder)")
    _add_elements(compile_)
    compile_.set_defaults(command=_compile)

    run = commands.add_parser("run", help="compile and simulate a model")
    run.add_argument("model", help="the .dep file")
    run.add_argument("--target", choices=["numpy", "c"], default="numpy",
                     help="numpy (default: a Python module) or c (a compiled model); both run "
                          "on the compiled integrator core")
    run.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                     help="override a parameter, units allowed (h1.preload=1.5N*m); repeatable")
    run.add_argument("--input", action="append", default=[], metavar="NAME=FILE",
                     help="drive input NAME by the time table in FILE (CSV lines 't,u' in SI, "
                          "linear in between); a constant input is a --set; repeatable")
    run.add_argument("--t-end", type=_positive_float, metavar="T", help="end time (s)")
    run.add_argument("--dt-out", type=_positive_float, metavar="DT", help="output interval (s)")
    run.add_argument("--tol", type=_tolerance, metavar="TOL",
                     help="integration tolerance, between 0 and 1")
    run.add_argument("--max-steps", type=_positive_float, metavar="N",
                     help="the most steps the run may take (default 1e6); a stiff run that "
                          "would need more stops at once")
    run.add_argument("--stepping", choices=("auto", "explicit", "implicit"), default="auto",
                     help="the ODE method under the multiplier iteration: auto (default: "
                          "explicit, and linearly implicit once a beam's stiff modes bound "
                          "the explicit step), explicit or implicit (docs/method.md)")
    run.add_argument("--sensitivity", action="append", default=[], metavar="NAME",
                     help="also follow d/d NAME (a parameter) along the run: the outputs' "
                          "derivatives as CSV columns d(OUTPUT)/d(NAME), each event time's in "
                          "the summary (dt_dp) and the report (docs/calibration.md); "
                          "repeatable")
    run.add_argument("-o", "--out", metavar="CSV", help="write outputs to a CSV file")
    run.add_argument("--summary", metavar="JSON", help="write a JSON run summary")
    run.add_argument("--plot", metavar="PNG", help="plot every output against time (.png, "
                                                   ".pdf, .svg, ...: the extension decides)")
    run.add_argument("--animate", metavar="GIF", help="animate the mechanism moving (.gif; "
                                                      ".mp4 with ffmpeg installed)")
    _add_view(run, "--animate")
    _add_elements(run)
    run.set_defaults(command=_run)

    modes = commands.add_parser("modes", help="natural frequencies and mode shapes of the "
                                              "mechanism at a state (linearised)")
    modes.add_argument("model", help="the .dep file")
    modes.add_argument("--at", default="t=0", metavar="t=T|deployed",
                       help="the state: t=T (the run's state at T s, locked hinges locked; "
                            "default t=0) or deployed (every latch latched and locked, at the "
                            "equilibrium near the end of the run)")
    modes.add_argument("--count", type=_positive_int, metavar="N",
                       help="the lowest N modes (default: all)")
    modes.add_argument("--target", choices=["numpy", "c"], default="c",
                       help="c (default: compiled model) or numpy")
    modes.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                       help="override a parameter, units allowed; repeatable")
    modes.add_argument("--t-end", type=_positive_float, metavar="T",
                       help="end time of the run for --at deployed (s)")
    modes.add_argument("--tol", type=_tolerance, metavar="TOL",
                       help="integration tolerance of the run, between 0 and 1")
    modes.add_argument("--json", metavar="JSON", help="write the frequencies and mode shapes")
    modes.add_argument("--plot", metavar="PNG", help="draw the mode shapes (.png, .pdf, .svg, "
                                                     "...: the extension decides)")
    modes.add_argument("--animate", metavar="GIF", help="the modes oscillating, one after the "
                                                        "other (.gif; .mp4 with ffmpeg)")
    _add_view(modes, "--plot and --animate")
    _add_elements(modes)
    modes.set_defaults(command=_modes)

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
    sweep.add_argument("--tol", type=_tolerance, metavar="TOL",
                       help="integration tolerance, between 0 and 1")
    sweep.add_argument("--time-grid", type=_positive_int, metavar="N",
                       help="also store every output at N times")
    sweep.add_argument("-o", "--out", metavar="NC", help="NetCDF file (default MODEL-sweep.nc)")
    sweep.add_argument("--plot", metavar="PNG", help="the study's figure: deployment, latch "
                                                     "times and peak loads, what drives what "
                                                     "(.png, .pdf, .svg, ...)")
    sweep.add_argument("--limit", action="append", default=[], metavar="METRIC=VALUE",
                       help="also give the probability that METRIC exceeds VALUE, with its "
                            "confidence interval, e.g. --limit 'peak.h1.torque=8 N*m'; "
                            "repeatable")
    sweep.add_argument("--resume", action="store_true", help="complete an interrupted study")
    sweep.add_argument("--local", action="store_true",
                       help="instead of the study: one run with forward sensitivities at the "
                            "samples' means, the metrics' derivatives there and the spread "
                            "they predict to first order (a first look; no file written)")
    _add_elements(sweep)
    sweep.set_defaults(command=_sweep)
    _fit_parser(commands)
    return parser


def _fit_parser(commands) -> None:
    fit = commands.add_parser("fit", help="calibrate a model's parameters to a ground test "
                                          "(weighted least squares; docs/calibration.md)")
    fit.add_argument("model", help="the .dep file")
    fit.add_argument("--data", metavar="CSV", help="measured time histories: header "
                                                   "'t [s], theta1 [deg], ...', then rows")
    fit.add_argument("--latch-times", metavar="CSV",
                     help="measured event times: rows 'event,t[,sigma]' (h1.latch,50.6)")
    fit.add_argument("--free", action="append", default=[], metavar="NAME[=LOW:HIGH]",
                     help="a parameter to fit, with optional bounds, units allowed "
                          "(h1.friction=0.3:1.2N*m); repeatable")
    fit.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                     help="override a parameter (a free one: its start), units allowed; "
                          "repeatable")
    fit.add_argument("--sigma", action="append", default=[], metavar="NAME=VALUE",
                     help="the noise of a measured column, or of the event times "
                          "(latch-times=0.02s), units allowed; without it, one noise per "
                          "kind is estimated from the residuals; repeatable")
    fit.add_argument("--target", choices=["numpy", "c"], default="c",
                     help="c (default: compiled model) or numpy")
    fit.add_argument("--t-end", type=_positive_float, metavar="T",
                     help="end time of the runs (s; default the model's)")
    fit.add_argument("--tol", type=_tolerance, metavar="TOL",
                     help="integration tolerance, between 0 and 1")
    fit.add_argument("-o", "--out", metavar="JSON", help="write the fit as JSON")
    fit.add_argument("--plot", metavar="PNG", help="measured, fitted and start values with "
                                                   "the residuals (.png, .pdf, .svg, ...)")
    _add_elements(fit)
    fit.set_defaults(command=_fit)


def _add_view(parser: argparse.ArgumentParser, pictures: str) -> None:
    parser.add_argument("--view", type=_view, metavar="ELEV,AZIM",
                        help=f"the 3-D view of a spatial model's {pictures}: elevation ELEV "
                             "and azimuth AZIM (deg) about the upright axis, the one against "
                             "gravity (z without gravity); default 35.26,-45, the isometric "
                             "view (a negative ELEV: --view=-20,30)")


def _view(text: str) -> tuple[float, float]:
    from depsim.runtime.animation3d import check_view

    try:
        return check_view(text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not ELEV,AZIM: two numbers in degrees, "
                                         "e.g. 30,-60") from None


def _check_view(args, model, pictures: tuple[str, ...]) -> None:
    """--view only with a picture it sets and for a spatial model."""
    if args.view is None:
        return
    if not any(getattr(args, name.lstrip("-")) for name in pictures):
        raise _usage(f"--view sets the 3-D view of {' or '.join(pictures)}: give one")
    if not model.ir.spatial:
        raise _usage(f"--view: '{model.name}' is a planar model, drawn in its plane; the "
                     "view is for a spatial model")


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


def _tolerance(text: str) -> float:
    value = _positive_float(text)
    if not value < 1:
        raise argparse.ArgumentTypeError(f"'{text}' must lie between 0 and 1 (e.g. 1e-8)")
    return value


def _positive_int(text: str) -> int:
    if not text.strip().isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"'{text}' must be a positive integer")
    return int(text)


def _natural_int(text: str) -> int:
    if not text.strip().isdigit():
        raise argparse.ArgumentTypeError(f"'{text}' must be a non-negative integer")
    return int(text)


def _elements(text: str) -> dict[str, str]:
    """BEAM=N,... as text: the counts are checked by Model.with_elements (ASCII digits,
    the language's limits)."""
    counts = {}
    for item in filter(None, text.split(",")):
        name, sep, count = item.partition("=")
        if not sep or not name.strip() or not count.strip():
            raise argparse.ArgumentTypeError(f"'{item}' is not BEAM=N (e.g. link1=8)")
        counts[name.strip()] = count.strip()
    return counts


def _settings(items: list[str], option: str = "--set", example: str = "h2.friction=0.7",
              each: str = "parameter") -> dict[str, str]:
    """NAME=VALUE items as {name: value text}; UsageError for a malformed or repeated one (the
    standalone program words its --set the same way)."""
    from depsim.errors import UsageError

    settings = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise UsageError(f"{option} '{item}': expected NAME=VALUE, e.g. {option} {example}")
        if name.strip() in settings:
            raise UsageError(f"{option} {name.strip()} is given twice "
                             f"({settings[name.strip()]} and {value.strip()}): give each "
                             f"{each} once")
        settings[name.strip()] = value.strip()
    return settings


def _input_tables(items: list[str]) -> dict:
    """--input NAME=FILE: each input's time table (depsim.runtime.tables)."""
    from depsim.errors import UsageError
    from depsim.runtime.tables import read_table

    tables = {}
    for item in items:
        name, sep, path = item.partition("=")
        if not sep or not name.strip() or not path.strip():
            raise UsageError(f"--input '{item}': expected NAME=FILE, e.g. --input "
                             "T_motor=torque.csv")
        if name.strip() in tables:
            raise UsageError(f"--input {name.strip()} is given twice: give each input one "
                             "table")
        try:
            tables[name.strip()] = read_table(path.strip())
        except ValueError as exc:
            raise UsageError(f"--input {name.strip()}: {exc}") from None
    return tables


def _load(args):
    import depsim

    model = depsim.load(args.model)
    _print_warnings(model)
    return model.with_elements(args.elements) if getattr(args, "elements", None) else model


def _print_warnings(model) -> None:
    from depsim.dsl import format_diagnostics, read_model_text

    if model.ir.warnings:
        source = read_model_text(model.path)
        print(format_diagnostics(model.ir.warnings, source), file=sys.stderr, end="")


def _check(args) -> int:
    from depsim.dsl import summary

    model = _load(args)
    print(summary(model.ir))
    return EXIT_OK


def _compile(args) -> int:
    if args.target == "fmu":
        return _compile_fmu(args)
    if args.out is None:
        raise _usage(f"--target {args.target} needs -o DIR, the folder to write")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise _usage(f"-o {args.out}: it exists and is not a folder; compile writes a folder "
                     "of files (give a new or an existing folder)")
    model = _load(args)
    generated, reused = model.generated_code(args.target)  # derived once, then cached
    written = _copy_generated(generated, out)
    print(f"wrote {written}" + (" (generated before, from the cache: nothing derived)"
                                if reused else ""))
    if args.target == "c":
        print(f"build with `make -C {written}`, run `{written}/{_program_name(written)} --help`")
    return EXIT_OK


def _copy_generated(cached: Path, out: Path) -> Path:
    """The cached NumPy module (a file) or C folder's sources (its core/ among them, not its
    build/) into `out`."""
    import shutil

    out.mkdir(parents=True, exist_ok=True)
    if cached.is_file():
        shutil.copyfile(cached, out / cached.name)
        return out / cached.name
    for path in sorted(cached.rglob("*")):
        relative = path.relative_to(cached)
        if (path.is_file() and relative.parts[0] != "build"
                and (path.suffix in (".c", ".h", ".inc") or path.name == "Makefile")):
            (out / relative).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, out / relative)
    return out


def _program_name(folder: Path) -> str:
    """The program the C folder's Makefile builds: the first target of its `all:` line."""
    for line in (folder / "Makefile").read_text(encoding="utf-8").splitlines():
        if line.startswith("all:"):
            return line.split()[1]
    raise AssertionError(f"{folder / 'Makefile'} has no `all:` line")


def _compile_fmu(args) -> int:
    """compile --target fmu: the FMU file, checked before anything is derived."""
    from depsim.runtime.output import check_output

    out = args.out or f"{Path(args.model).stem}.fmu"
    _check_outputs(args.model, [("-o", out, lambda p: check_output(p, ("fmu",)))])
    model = _load(args)
    print(f"wrote {model.export_fmu(out)}")
    return EXIT_OK


def _run(args) -> int:
    from depsim.runtime.animation import check_animation_path
    from depsim.runtime.output import all_or_none, check_output
    from depsim.runtime.plot import PLOT_FORMATS

    _check_outputs(args.model, [("-o", args.out, check_output),
                                ("--summary", args.summary, check_output),
                                ("--plot", args.plot, lambda p: check_output(p, PLOT_FORMATS)),
                                ("--animate", args.animate, check_animation_path)])
    settings = _settings(args.set)
    for name in (item.partition("=")[0].strip() for item in args.input):
        for given in (name, f"{name}.rate"):
            if given in settings:
                raise _usage(f"input {name} is given both a table (--input {name}=...) and "
                             f"a value (--set {given}=...): give one")
    tables = _input_tables(args.input)
    model = _load(args)
    _check_view(args, model, ("--animate",))
    _check_output_times(model, args)
    # a free-flying model: its momentum and energy balance in the summary and the report
    floating = bool(model.ir.free_joints) or any(w.code == "W001" for w in model.ir.warnings)
    sim = model.compile(target=args.target)
    try:
        result = sim.run(set=settings, t_end=args.t_end, dt_out=args.dt_out, tol=args.tol,
                         progress=True, max_steps=args.max_steps, inputs=tables,
                         stepping=args.stepping, sensitivities=args.sensitivity)
    except ValueError as exc:  # a setting the runtime refuses (simulate's documented ValueError)
        raise _usage(str(exc)) from exc
    with all_or_none():
        if args.out:
            result.to_csv(args.out)
        if args.summary:
            result.to_json(args.summary, system=floating)
        if args.plot:
            from depsim.runtime.plot import plot_outputs
            plot_outputs(result, args.plot)
        if args.animate:
            from depsim.runtime import animate
            animate(result, sim.module, args.animate,
                    outlines=sim.outlines(result.parameters), view=args.view)
    print(result.report())
    if result.sensitivities is not None:
        print(result.sensitivities.event_text(result.events))
    if floating and result.system_line():
        print(result.system_line())
    print(f"  code: reused from the cache ({sim.cached}): nothing derived" if sim.cached
          else "  code: derived and generated (kept in the cache for the next run)")
    return EXIT_OK


def _modes(args) -> int:
    from depsim.api import parse_moment
    from depsim.runtime.animation import check_animation_path
    from depsim.runtime.output import all_or_none, check_output
    from depsim.runtime.plot import PLOT_FORMATS

    _check_outputs(args.model, [("--json", args.json, check_output),
                                ("--plot", args.plot, lambda p: check_output(p, PLOT_FORMATS)),
                                ("--animate", args.animate, check_animation_path)])
    parse_moment(args.at)  # a bad --at before anything is compiled
    settings = _settings(args.set)
    model = _load(args)
    _check_view(args, model, ("--plot", "--animate"))
    sim = model.compile(target=args.target)
    found = sim.modes(at=args.at, count=args.count, set=settings, t_end=args.t_end,
                      tol=args.tol)
    p = sim.parameters(settings)
    with all_or_none():
        if args.json:
            found.to_json(args.json)
        if args.plot:
            from depsim.runtime.mode_figures import plot_modes
            plot_modes(found, sim.module, args.plot, p, outlines=sim.outlines(p),
                       view=args.view)
        if args.animate:
            from depsim.runtime.mode_figures import animate_modes
            animate_modes(found, sim.module, args.animate, p, outlines=sim.outlines(p),
                          view=args.view)
    print(found.table())
    return EXIT_OK


def _sweep(args) -> int:
    from depsim.runtime.output import all_or_none, check_output
    from depsim.runtime.plot import PLOT_FORMATS
    from depsim.runtime.sweep import plot_study, summarize
    from depsim.runtime.sweep.storage import check_store, partial_path

    if args.local:
        return _local_study(args)
    out = args.out or f"{Path(args.model).stem}-sweep.nc"
    _check_outputs(args.model, [("-o", out, check_store),
                                ("--plot", args.plot, lambda p: check_output(p, PLOT_FORMATS))])
    model = _load(args)
    _check_output_times(model, args)
    sim = model.compile(target=args.target)
    limits = _limits(args.limit, sim.module)
    try:
        with all_or_none():  # the study file and the plot, or neither (the runs stay kept)
            study = _study(sim, args, out)
            print(summarize(study, limits={n: v for n, v in limits.items() if n in study}))
            if args.plot:
                plot_study(study, args.plot, limits=limits)
    except OSError as exc:
        partial = partial_path(out)
        if partial.exists():
            raise _usage(f"{_os_message(exc)}; the finished runs are kept in {partial}: run "
                         "again with --resume to write the study without running them "
                         "again") from exc
        raise
    print(f"wrote {out}")
    return EXIT_OK


def _local_study(args) -> int:
    """sweep --local: the local sensitivity table of the samples' parameters."""
    import depsim

    ignored = [flag for flag, given in (("--grid", args.grid), ("--runs", args.runs),
                                        ("--seed", args.seed), ("-o", args.out),
                                        ("--plot", args.plot), ("--limit", args.limit),
                                        ("--resume", args.resume),
                                        ("--time-grid", args.time_grid),
                                        ("--workers", args.workers),
                                        ("--scheduler", args.scheduler)) if given]
    if ignored:
        raise _usage(f"--local takes the spreads of --sample alone; {', '.join(ignored)} "
                     "belong to a study")
    model = _load(args)
    sim = model.compile(target=args.target)
    try:
        study = depsim.local_study(sim, args.sample, t_end=args.t_end, tol=args.tol)
    except ValueError as exc:  # what the sensitivities cannot follow, said where it happens
        raise _usage(str(exc)) from exc
    print(study.text())
    return EXIT_OK


def _study(sim, args, out: str):
    import depsim

    try:
        return depsim.sweep(sim, grid=args.grid, samples=args.sample, runs=args.runs,
                            seed=args.seed, t_end=args.t_end, dt_out=args.dt_out, tol=args.tol,
                            time_grid=args.time_grid, workers=args.workers,
                            scheduler=args.scheduler, out=out, resume=args.resume,
                            target=args.target, as_xarray=False)
    except ValueError as exc:  # a SweepSpecError is reported as it is; another: a setting
        if _report_as_is(exc):
            raise
        raise _usage(str(exc)) from exc


def _fit(args) -> int:
    import depsim
    from depsim.runtime.output import all_or_none, check_output
    from depsim.runtime.plot import PLOT_FORMATS

    _check_outputs(args.model, [("-o", args.out, check_output),
                                ("--plot", args.plot, lambda p: check_output(p, PLOT_FORMATS))])
    settings = _settings(args.set)
    sigma = _settings(args.sigma, "--sigma", "theta1=0.05deg", "column")
    model = _load(args)
    sim = model.compile(target=args.target)
    found = depsim.fit(sim, data=args.data, free=args.free, latch_times=args.latch_times,
                       set=settings, sigma=sigma, tol=args.tol, t_end=args.t_end)
    with all_or_none():
        if args.out:
            found.to_json(args.out)
        if args.plot:
            found.plot(args.plot)
    print(found.report())
    return EXIT_OK


def _limits(items: list[str], module) -> dict[str, float]:
    """--limit METRIC=VALUE: {metric: SI value}, checked before the study runs: a metric a
    study of `module` has, a value in its unit (depsim.runtime.sweep.metrics)."""
    from depsim.dsl import parse_quantity
    from depsim.runtime.sweep.metrics import known_metric, metric_attributes

    limits = {}
    for item in items:
        name, sep, text = (part.strip() for part in item.partition("="))
        if not sep or not name or not text:
            raise _usage(f"--limit '{item}': expected METRIC=VALUE, e.g. --limit "
                         "'peak.h1.torque=8 N*m'")
        if not known_metric(name, module):
            raise _usage(f"--limit '{item}': no metric '{name}' in a study of this model "
                         "(deployed, time_to_deploy, event.<name>.<key>, peak.<hinge>.force, "
                         "peak.<hinge>.torque, dissipated.<kind>, final.<output>; "
                         "docs/api.md, Metrics)")
        unit = metric_attributes(name, module).get("units", "")
        try:
            value, dim = parse_quantity(text)
            wanted = parse_quantity(f"1 {unit}")[1] if unit not in ("", "1") else dim
        except ValueError as exc:
            raise _usage(f"--limit '{item}': {exc}") from None
        if dim != wanted and dim != type(dim)():
            raise _usage(f"--limit '{item}': {name} is in {unit}; '{text}' has another "
                         "dimension")
        limits[name] = value
    return limits


def _check_outputs(model: str, outputs) -> None:
    """Before anything runs: each output (option, path or None, check(path)) can be written
    (the check raises OutputError if not), and no two outputs, nor an output and the model,
    are the same file."""
    seen = {os.path.realpath(model): "the model file"}
    for option, path, check in outputs:
        if path is None:
            continue
        check(path)
        key = os.path.realpath(path)
        if key.startswith("/proc/") or (os.path.exists(key) and not os.path.isfile(key)):
            continue  # a pipe, a device, a descriptor (/dev/stdout): written in place
        if key in seen:
            raise _usage(f"{option} {path}: that is {seen[key]}; give another file")
        seen[key] = f"the file of {option}"


def _check_output_times(model, args) -> None:
    """UsageError when --t-end / --dt-out (or the model's values) ask for more output times
    than a run may record (depsim.runtime.results.MAX_OUTPUT_ROWS)."""
    from depsim.runtime.results import check_output_rows

    settings = model.ir.simulation
    t_end = args.t_end if args.t_end is not None else settings.t_end
    dt_out = args.dt_out if args.dt_out is not None else settings.dt_out
    try:
        check_output_rows(t_end, dt_out)
    except ValueError as exc:
        raise _usage(f"--t-end / --dt-out: {exc}") from None


def _usage(message: str):
    from depsim.errors import UsageError

    return UsageError(message)


if __name__ == "__main__":
    sys.exit(main())
