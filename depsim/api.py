"""The public Python API: load a model, compile it, run it.

    import depsim
    model = depsim.load("examples/intelsat5.dep")
    sim = model.compile(target="numpy")
    result = sim.run(set={"h2.friction": 0.7, "h1.preload": "1.5 N*m"}, t_end=30.0)
    result.to_csv("intelsat5.csv")

One compile serves every run: a run only changes the parameter vector.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import functools
import hashlib
import math
import os
import shutil
import threading
from pathlib import Path
from typing import Mapping

import numpy as np

from depsim import __version__
from depsim.dsl import check_parameters, ir, load_model, parse_quantity, with_elements
from depsim.dsl.structural import fixed_message
from depsim.errors import UsageError


TARGETS = ("numpy", "c")


def load(path: str | os.PathLike) -> Model:
    """Parse and check a `.dep` file. Raises `depsim.dsl.ModelError` on a bad model."""
    return Model(load_model(path), Path(path))


@dataclasses.dataclass(frozen=True)
class Model:
    """A checked model (the IR) and where it came from."""

    ir: ir.Model
    path: Path

    @property
    def name(self) -> str:
        return self.ir.name

    def with_elements(self, elements: Mapping[str, int | str]) -> Model:
        """The same model with other beam element counts, e.g. {"link1": 8} (checked against
        the language's limits, docs/language.md)."""
        try:
            return Model(with_elements(self.ir, elements), self.path)
        except ValueError as exc:
            raise UsageError(f"--elements: {exc}") from None

    def compile(self, target: str = "numpy", out_dir: str | os.PathLike | None = None,
                tangents: bool = False) -> Simulator:
        """Generate code for `target` and load it: "numpy" (a Python module) or "c" (a C
        folder whose model is built into a shared library). Either runs on the integrator
        core (built once per cache). The code is generated into `out_dir`, else into the
        user cache (`generated_code`), keyed by the model text's hash, its file name, the
        element counts, depsim's version and `tangents`, and taken from there without
        deriving anything the next time (`Simulator.cached`); the C build is cached by
        compiler and flags. `tangents`: generate the tangent functions too (forward
        sensitivities, docs/generated-module.md, Tangents; about twice the code)."""
        if target == "fmu":
            raise UsageError("an FMU is not run from Python: write it with "
                             "Model.export_fmu(path) (docs/fmu.md)")
        if target not in TARGETS:
            raise UsageError(f"unknown target '{target}' (available: {', '.join(TARGETS)})")
        from depsim.runtime.core import core

        # the integrator, built once per cache, beside the model's code being generated (its
        # C compile and sympy's work each take one CPU); CBuildError without a C compiler
        with concurrent.futures.ThreadPoolExecutor(1) as pool:
            built = pool.submit(core)
            if out_dir is not None:
                module = _generate(self.ir, target, Path(out_dir), tangents)
                built.result()
                return Simulator(self, module, target)
            artifact, reused = self.generated_code(target, tangents)
            built.result()
        folder = artifact.parent if artifact.is_file() else artifact
        return Simulator(self, _load(target, artifact), target,
                         cached=folder if reused else None)

    def generated_code(self, target: str, tangents: bool = False) -> tuple[Path, bool]:
        """The model's generated code for `target` (with the tangent functions when
        `tangents`) in the cache (a NumPy module's file, a C target's folder), derived and
        emitted unless it is there already; and whether it was (then nothing was
        derived)."""
        artifact = self.cached_code(target, tangents)
        if artifact is not None:
            return artifact, True
        directory, key = _cache_dir(self.ir, target, tangents)
        # generated beside the entry and renamed into place, so that processes compiling the
        # same model at once (a test run's workers, studies started together) never read
        # each other's half-written files: the first rename wins, the others take its entry
        building = directory.with_name(f".{directory.name}.{os.getpid()}.{threading.get_ident()}")
        shutil.rmtree(building, ignore_errors=True)
        try:
            if target == "c":
                artifact = _compile_c(self.ir, building, tangents)
            else:
                from depsim.codegen import compile_numpy

                artifact = compile_numpy(self.ir, building, tangents=tangents)
            name = artifact.name if artifact != building else "."
            _write_atomic(building / CACHE_STAMP, f"{key}\n{name}")
            if directory.exists() and self.cached_code(target, tangents) is None:
                shutil.rmtree(directory, ignore_errors=True)  # a stale or half-written entry
            try:
                os.rename(building, directory)
            except OSError:  # another process's entry is there now
                pass
        finally:
            shutil.rmtree(building, ignore_errors=True)
        artifact = self.cached_code(target, tangents)
        if artifact is None:
            raise OSError(f"the code cache entry {directory} could not be written")
        return artifact, False

    def cached_code(self, target: str, tangents: bool = False) -> Path | None:
        """The code `compile(target, tangents=tangents)` generated before for this model
        text, file name, element counts and depsim version (a NumPy module's file, a C
        target's folder), or None. Taking it does no symbolic work. The stamp naming it is
        written last, so a half-written entry is never taken."""
        directory, key = _cache_dir(self.ir, target, tangents)
        stamp = directory / CACHE_STAMP
        found = stamp.read_text(encoding="utf-8").split("\n") if stamp.is_file() else []
        if len(found) == 2 and found[0] == key and (directory / found[1]).exists():
            return (directory / found[1]).resolve()
        return None

    def export_fmu(self, path: str | os.PathLike) -> Path:
        """Write the model as an FMI 2.0 Co-Simulation FMU (a `.fmu` archive with its
        modelDescription.xml, a linux64 binary built with the system C compiler, and the C
        sources) to `path`, atomically; returns the path. See docs/fmu.md."""
        from depsim.codegen.fmu import compile_fmu

        return compile_fmu(self.ir, path)


CACHE_STAMP = "depsim-generated"  # in a cached folder: its key, then the artifact's name


def _cache_dir(model: ir.Model, target: str, tangents: bool = False) -> tuple[Path, str]:
    """The cache folder of the model's generated code and its key: the model text's hash,
    its file name (in the generated header), the element counts, depsim's version, the code
    generator itself (its sources and templates: a changed generator never reuses old code),
    the target and whether it has the tangent functions. Parameters never enter it: one
    generated module serves every parameter set."""
    from depsim.runtime.core import cache_root

    elements = ",".join(f"{b.name}={b.elements}" for b in model.beams)
    source = model.source_file.replace("\\", "/").rsplit("/", 1)[-1]
    key = hashlib.sha256(f"{model.source_sha256}|{source}|{elements}|{__version__}|"
                         f"{_generator_digest()}|{target}|tangents={int(tangents)}".encode()
                         ).hexdigest()
    return cache_root() / "models" / f"{model.name}-{key[:16]}", key


@functools.cache
def _generator_digest() -> str:
    """SHA-256 of the code generator's files, the model interface, the words of the range
    checks (depsim.dsl.limits, which the generated code carries) and the integrator core's C
    sources, which a C folder carries (without importing them: sympy stays unloaded)."""
    import importlib.util

    digest = hashlib.sha256()
    for package in ("depsim.codegen", "depsim.runtime", "depsim.dsl"):
        folder = Path(importlib.util.find_spec(package).submodule_search_locations[0])
        if package == "depsim.codegen":
            files = sorted(folder.glob("templates/**/*.j2")) + sorted(folder.glob("*.py"))
        elif package == "depsim.dsl":
            files = [folder / "limits.py"]
        else:
            files = [folder / "interface.py"] + sorted(
                path for path in folder.glob("c/**/*") if path.suffix in (".c", ".h", ".inc"))
        for path in files:
            digest.update(path.relative_to(folder).as_posix().encode() + b"\0"
                          + path.read_bytes())
    return digest.hexdigest()


def _generate(model: ir.Model, target: str, directory: Path, tangents: bool = False):
    """Derive and emit the model's code (with the tangent functions when `tangents`) into
    `directory` (not the cache); the module."""
    if target == "c":
        from depsim.runtime.binding import load_folder

        return load_folder(_compile_c(model, directory, tangents))
    from depsim.codegen import compile_numpy, load_generated

    return load_generated(compile_numpy(model, directory, tangents=tangents))


def _compile_c(model: ir.Model, directory: Path, tangents: bool) -> Path:
    """The model's C folder in `directory`, each generated file compiled as soon as it is
    written (beside the lowering of the next: a large model's C compile takes about as
    long), so that building its library afterwards only links."""
    from depsim.codegen import compile_c
    from depsim.runtime.binding import ModelPrebuild

    prebuild = ModelPrebuild(directory)
    try:
        return compile_c(model, directory, tangents=tangents, written=prebuild)
    finally:
        prebuild.finish()


def _load(target: str, path: Path):
    """A module generated before: a C folder (its library cached by its own hash) or a
    NumPy module's file."""
    if target == "c":
        from depsim.runtime.binding import load_folder

        return load_folder(path)
    from depsim.runtime.binding import load_module

    return load_module(path)


def _write_atomic(path: Path, text: str) -> None:
    temporary = path.with_name(f".{path.name}.{os.getpid()}")
    temporary.write_text(text, encoding="utf-8")
    os.replace(temporary, path)


class Simulator:
    """A compiled model: runs it for any parameter vector."""

    def __init__(self, model: Model, module, target: str, cached: Path | None = None):
        self.model = model
        self.module = module
        self.target = target
        self.cached = cached  # the cache folder its code was reused from, or None
        self._tangents = None  # the module with tangent functions, once sensitivities ran
        self.parameter_names: tuple[str, ...] = tuple(module.PARAMETERS)
        self.defaults = np.array(module.PARAMETER_DEFAULTS, dtype=float)

    def parameters(self, set: Mapping[str, float | str] | None = None) -> np.ndarray:
        """The parameter vector: defaults with `set` applied. Values are SI numbers (floats or
        text such as "0.7") or text with units ("1.5 N*m"), checked against the parameter's
        dimension."""
        p = self.defaults.copy()
        by_name = {m.name: i for i, m in enumerate(self.model.ir.params)}
        derived = {d.name: d for d in self.model.ir.derived}
        structural = {s.name: s.value for s in self.model.ir.structural}
        for name, value in (set or {}).items():
            if name in structural:  # a loop bound or index: fixed in the model text
                raise UsageError(fixed_message(name, structural[name]))
            if name not in by_name:
                raise UsageError(_unknown_parameter(name, by_name, derived))
            p[by_name[name]] = _parameter_value(self.model.ir.params[by_name[name]], value)
        # the model text's range checks (a length > 0, stop_min < stop_max, ...) hold for
        # every value set here too
        problems = check_parameters(self.model.ir, p, {n: f"{n}={v}" for n, v in
                                                       (set or {}).items()})
        if problems:
            raise UsageError("; ".join(problems))
        return p

    def outlines(self, params=None) -> dict[str, np.ndarray]:
        """Each rigid member's points in its own frame (m, from its centre of mass; (k, 2),
        or (k, 3) in a spatial model, whose "ground" entry holds the ground's declared
        points) for the parameter vector `params` (default: the defaults): what
        `depsim.runtime.animate` draws its outline through (`depsim.outlines.member_points`:
        a bar's ends, declared points, the centre; a body of fewer than three points gets
        the corners of a square of its radius of gyration, or in 3-D of the uniform box of
        its principal moments)."""
        from depsim.outlines import member_points

        return member_points(self.model.ir, self.defaults if params is None
                             else np.asarray(params, dtype=float))

    def run(self, set: Mapping[str, float | str] | None = None, t_end: float | None = None,
            dt_out: float | None = None, tol: float | None = None, progress: bool = False,
            max_steps: float | None = None, inputs=None, stepping: str = "auto",
            sensitivities=()):
        """Simulate with parameters `set` applied; returns a `depsim.runtime.Result`.
        max_steps: the most steps the run may take (default 1e6; docs/method.md, 6);
        inputs: {input: time table as rows (t, u) in SI, or one number} (docs/api.md);
        stepping: "auto", "explicit" or "implicit" (docs/method.md, 10); sensitivities:
        parameter names whose forward sensitivities to follow (`Result.sensitivities`,
        docs/calibration.md): the model's code with its tangent functions is generated the
        first time they are asked for (then cached)."""
        from depsim.runtime import simulate

        for name in inputs or {}:  # a table sets the input's value and rate over time
            for given in (name, f"{name}.rate"):
                if given in (set or {}):
                    raise UsageError(f"input '{name}' is given both a time table (inputs) "
                                     f"and a value (set['{given}']): give one")
        p = self.parameters(set)
        if sensitivities:
            self._check_sensitivities()
        module = self.module if not sensitivities else self.tangent_module()
        return simulate(module, p, t_end=t_end, dt_out=dt_out,
                        tol=tol, progress=progress, max_steps=max_steps, inputs=inputs,
                        stepping=stepping, sensitivities=tuple(sensitivities))

    def _check_sensitivities(self) -> None:
        """UsageError for what forward sensitivities cannot follow, known from the model text:
        a one-sided spring, whose force law switches where it engages (a jump with a preload
        or damping, a kink without) at a time no event marks, so the sensitivities would miss
        the switch's term (docs/calibration.md, what the sensitivities follow)."""
        one_sided = [s.name for s in self.model.ir.springs if s.acts is not ir.SpringActs.BOTH]
        if one_sided:
            raise UsageError(
                f"sensitivities: spring{'s' if len(one_sided) > 1 else ''} "
                f"{', '.join(one_sided)} act{'' if len(one_sided) > 1 else 's'} one way (push "
                "or pull), and the sensitivities do not follow the switch where such a spring "
                "engages or lets go (without `acts` a spring acts both ways)")

    def tangent_module(self):
        """The model's module with its tangent functions (generated into the cache the first
        time, for this simulator's target)."""
        from depsim.runtime.binding import bind

        if self._tangents is None:
            if bind(self.module).tangents:
                self._tangents = self.module
            else:
                self._tangents = self.model.compile(self.target, tangents=True).module
        return self._tangents


    def modes(self, at: str | float = "t=0", count: int | None = None,
              set: Mapping[str, float | str] | None = None, t_end: float | None = None,
              tol: float | None = None):
        """The natural frequencies (Hz) and mode shapes of the mechanism linearised at `at`:
        "t=T" (or a time T in s: the state the run reaches at T, its locked hinges locked)
        or "deployed" (the run to its end must latch every latch; each latched hinge locked
        at its latch angle, compliant latches as springs, at the static equilibrium near the
        final state). `count`: the lowest so many. Returns depsim.runtime.modes.Modes
        (docs/modes.md)."""
        from depsim.runtime import simulate
        from depsim.runtime.modes import deployed_state, modes, state_of

        p = self.parameters(set)
        moment = parse_moment(at)
        if moment is None:
            result = simulate(self.module, p, t_end=t_end, tol=tol)
            if not result.deployment.deployed:
                open_ = [h for h in result.deployment.latch_hinges
                         if h not in {r.hinge for r in result.deployment.latches}]
                why = ("the model has no latch" if result.deployment.deployed is None else
                       f"{', '.join(open_)} still open at t = {result.t_end:g} s")
                raise UsageError(f"--at deployed: the run does not deploy ({why}); give a "
                                 "longer --t-end, or --at t=T")
            state = deployed_state(result, self.module)
            last = result.deployment.time
            return modes(self.module, p, state, f"deployed (last latch at t = {last:.6g} s; "
                         f"state at t = {result.t_end:g} s, moved to its equilibrium)",
                         equilibrium=True, count=count)
        short = moment == 0.0
        horizon = 1e-6 if short else moment
        result = simulate(self.module, p, t_end=horizon, dt_out=horizon, tol=tol)
        row = 0 if short else len(result.times) - 1
        return modes(self.module, p, state_of(result, self.module, row), f"t = {moment:g} s",
                     count=count)


def parse_moment(at: str | float) -> float | None:
    """`at` of Simulator.modes as a time in s, or None for "deployed"; UsageError if
    neither ("t=12.5", "t=12.5 s", "12.5", 12.5)."""
    if isinstance(at, (int, float)) and not isinstance(at, bool):
        value = float(at)
    elif isinstance(at, str) and at.strip() == "deployed":
        return None
    else:
        text = str(at).strip()
        text = text[2:] if text.startswith("t=") else text
        try:
            value, dim = parse_quantity(text)
        except ValueError as exc:
            raise UsageError(f"--at {at}: expected t=TIME (s) or deployed ({exc})") from None
        if dim not in (ir.Dim(), ir.Dim(time=1)):
            raise UsageError(f"--at {at}: a time is in s")
    if not (math.isfinite(value) and value >= 0):
        raise UsageError(f"--at {at}: the time must be zero or positive")
    return value


def _range_check(model: ir.Model, varied: list):
    """check(p) -> the messages of the model's range checks that p breaks
    (`depsim.dsl.check_parameters`, as for `set`), testing only the ranges that depend on
    a varied parameter (the others hold at the defaults)."""
    from depsim.dsl.evaluate import param_indices

    index = {p.name: i for i, p in enumerate(model.params)}
    varied_indices = {index[name] for name in varied if name in index}

    def depends(limit: ir.Limit) -> bool:
        used = param_indices(limit.expr)
        if limit.bound is not None:
            used |= param_indices(limit.bound)
        return bool(used & varied_indices)

    relevant = dataclasses.replace(model, limits=tuple(filter(depends, model.limits)))
    return functools.partial(check_parameters, relevant)


def _unknown_parameter(name: str, by_name, derived) -> str:
    import difflib

    if name in derived:
        deps = ", ".join(f"'{d}'" for d in derived[name].depends_on) or "its params"
        return f"'{name}' is computed from {deps} in the model; set {deps} instead"
    close = difflib.get_close_matches(name, list(by_name) + list(derived), n=1)
    hint = f"; did you mean '{close[0]}'?" if close else ""
    return f"unknown parameter '{name}'{hint} (`depsim check MODEL` lists them)"


def _parameter_value(param: ir.Param, value: float | str) -> float:
    if isinstance(value, str):
        try:
            number, dim = parse_quantity(value)
        except ValueError as exc:
            raise UsageError(f"bad value for '{param.name}': {exc}") from None
        # a bare number is the SI value; a number with a unit must have the right dimension
        if dim != param.dim and dim != ir.Dim():
            raise UsageError(f"'{param.name}' needs a value in {param.unit or 'no unit'}; "
                             f"'{value}' has another dimension")
        value = number
    value = float(value)
    if not np.isfinite(value):
        raise UsageError(f"bad value for '{param.name}': {value} is not a finite number")
    return value


def local_study(sim: Simulator, samples, *, set=None, t_end=None, tol=None):
    """A local sensitivity study (depsim.runtime.sweep.LocalStudy): one run with forward
    sensitivities at the samples' means (the other parameters at their values, `set`
    applied), the deployment metrics' derivatives there and their first-order spread from
    the samples' standard deviations. `samples`: ["NAME=normal(MU,SIGMA)", ...] as for
    `sweep`, values may carry units. A first look before a Monte Carlo (docs/calibration.md,
    Local sensitivities)."""
    from depsim.runtime.sweep import local_study as study_of, parse_sample

    index = {name: i for i, name in enumerate(sim.parameter_names)}
    items = [samples] if isinstance(samples, str) else list(samples or ())
    if not items:
        raise UsageError("a local study needs the parameters' spreads: --sample "
                         "NAME=DIST(...)")

    def quantity(name: str, text: str) -> float:
        if name not in index:
            raise UsageError(f"sample '{name}': not a parameter of the model")
        return float(sim.parameters({name: text})[index[name]])

    try:
        spreads = [parse_sample(item, quantity) for item in items]
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    point = {**dict(set or {}), **{d.name: repr(d.mean) for d in spreads}}
    result = sim.run(set=point, t_end=t_end, tol=tol,
                     sensitivities=[d.name for d in spreads])
    return study_of(result, {d.name: d.std for d in spreads})


def sweep(sim: Simulator, *, grid=None, samples=None, runs=None, seed=None, metrics=None,
          t_end=None, dt_out=None, tol=None, time_grid=None, workers=None, scheduler=None,
          out=None, resume=False, progress=None, target="c", as_xarray=True):
    """Run a parameter study of a compiled model; returns an xarray Dataset (also written to
    `out` as NetCDF; as_xarray=False: the same study as plain numpy arrays, a StudyTable with
    `.to_xarray()`, without importing xarray). `grid`: ["NAME=START:STOP:N", ...]; `samples`: ["NAME=normal(MU,SIGMA)",
    "NAME=uniform(A,B)", ...] with `runs` and `seed`. Values may carry units ("1.5N*m").
    `scheduler`: None for a local process pool, or a Dask scheduler address / Client.
    `target`: the code the runs use, "c" (default, about 30 times faster) or "numpy"; a
    Simulator of the other target is compiled for it (once; then from the cache).
    See docs/api.md."""
    from depsim.runtime import sweep as studies

    if target not in TARGETS:
        raise UsageError(f"unknown target '{target}' (available: {', '.join(TARGETS)})")
    if sim.target != target:
        sim = sim.model.compile(target)

    structural = {s.name: s.value for s in sim.model.ir.structural}
    names = []  # the varied parameters' names
    for spec in (grid, samples):  # a string, strings, or a mapping name -> text
        items = [spec] if isinstance(spec, str) else list(spec or ())
        for item in items:
            name = item.split("=", 1)[0].strip() if isinstance(item, str) else None
            if name in structural:  # a loop bound or index: one model per value
                raise UsageError(fixed_message(name, structural[name]))
            names.append(name)
    index = {name: i for i, name in enumerate(sim.parameter_names)}

    def quantity(name: str, text: str) -> float:
        return float(sim.parameters({name: text})[index[name]])

    module = sim.module if sim.target == "numpy" else sim.module.__file__  # workers load it
    return studies.sweep(module, grid=grid, samples=samples, runs=runs, seed=seed,
                         metrics=metrics, t_end=t_end, dt_out=dt_out, tol=tol,
                         time_grid=time_grid, workers=workers, scheduler=scheduler, out=out,
                         resume=resume, progress=progress, quantity=quantity,
                         defaults=sim.defaults, check=_range_check(sim.model.ir, names),
                         as_xarray=as_xarray)
