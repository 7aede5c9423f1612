"""The public Python API: load a model, compile it, run it.

    import depsim
    model = depsim.load("examples/intelsat5.dep")
    sim = model.compile(target="numpy")
    result = sim.run(set={"h2.friction": 0.7, "h1.preload": "1.5 N*m"}, t_end=30.0)
    result.to_csv("intelsat5.csv")

One compile serves every run: a run only changes the parameter vector.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
from pathlib import Path
from typing import Mapping

import numpy as np

from depsim import __version__
from depsim.dsl import check_parameters, ir, load_model, parse_quantity, with_elements
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

    def compile(self, target: str = "numpy", out_dir: str | os.PathLike | None = None) -> Simulator:
        """Generate code for `target` and load it: "numpy" (a Python module) or "c" (a C
        folder whose model is built into a shared library). Either runs on the integrator
        core (built once per cache). Artifacts are cached under `out_dir` or the user cache,
        keyed by the model hash, element counts and depsim version (the C build also by
        compiler and flags)."""
        if target == "fmu":
            raise UsageError("an FMU is not run from Python: write it with "
                             "Model.export_fmu(path) (docs/fmu.md)")
        if target not in TARGETS:
            raise UsageError(f"unknown target '{target}' (available: {', '.join(TARGETS)})")
        directory = Path(out_dir) if out_dir is not None else _cache_dir(self.ir, target)
        from depsim.runtime.core import core

        core()  # the integrator: built once per cache; CBuildError without a C compiler
        if target == "c":
            from depsim.codegen import compile_c
            from depsim.runtime.binding import load_folder

            return Simulator(self, load_folder(compile_c(self.ir, directory)), target)
        from depsim.codegen import compile_numpy, load_generated

        return Simulator(self, load_generated(compile_numpy(self.ir, directory)), target)

    def export_fmu(self, path: str | os.PathLike) -> Path:
        """Write the model as an FMI 2.0 Co-Simulation FMU (a `.fmu` archive with its
        modelDescription.xml, a linux64 binary built with the system C compiler, and the C
        sources) to `path`, atomically; returns the path. See docs/fmu.md."""
        from depsim.codegen.fmu import compile_fmu

        return compile_fmu(self.ir, path)


def _cache_dir(model: ir.Model, target: str) -> Path:
    from depsim.runtime.core import cache_root

    root = cache_root()
    elements = ",".join(f"{b.name}={b.elements}" for b in model.beams)
    key = hashlib.sha256(f"{model.source_sha256}|{elements}|{__version__}|{target}".encode())
    return root / f"{model.name}-{key.hexdigest()[:16]}"


class Simulator:
    """A compiled model: runs it for any parameter vector."""

    def __init__(self, model: Model, module, target: str):
        self.model = model
        self.module = module
        self.target = target
        self.parameter_names: tuple[str, ...] = tuple(module.PARAMETERS)
        self.defaults = np.array(module.PARAMETER_DEFAULTS, dtype=float)

    def parameters(self, set: Mapping[str, float | str] | None = None) -> np.ndarray:
        """The parameter vector: defaults with `set` applied. Values are SI numbers (floats or
        text such as "0.7") or text with units ("1.5 N*m"), checked against the parameter's
        dimension."""
        p = self.defaults.copy()
        by_name = {m.name: i for i, m in enumerate(self.model.ir.params)}
        derived = {d.name: d for d in self.model.ir.derived}
        for name, value in (set or {}).items():
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

    def run(self, set: Mapping[str, float | str] | None = None, t_end: float | None = None,
            dt_out: float | None = None, tol: float | None = None, progress: bool = False,
            max_steps: float | None = None, inputs=None):
        """Simulate with parameters `set` applied; returns a `depsim.runtime.Result`.
        max_steps: the most steps the run may take (default 1e6; docs/method.md, 6);
        inputs: {input: time table as rows (t, u) in SI, or one number} (docs/api.md)."""
        from depsim.runtime import simulate

        return simulate(self.module, self.parameters(set), t_end=t_end, dt_out=dt_out,
                        tol=tol, progress=progress, max_steps=max_steps, inputs=inputs)


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


def sweep(sim: Simulator, *, grid=None, samples=None, runs=None, seed=None, metrics=None,
          t_end=None, dt_out=None, tol=None, time_grid=None, workers=None, scheduler=None,
          out=None, resume=False, progress=None):
    """Run a parameter study of a compiled model; returns an xarray Dataset (also written to
    `out` as NetCDF). `grid`: ["NAME=START:STOP:N", ...]; `samples`: ["NAME=normal(MU,SIGMA)",
    "NAME=uniform(A,B)", ...] with `runs` and `seed`. Values may carry units ("1.5N*m").
    `scheduler`: None for a local process pool, or a Dask scheduler address / Client.
    See docs/api.md."""
    from depsim.runtime import sweep as studies

    index = {name: i for i, name in enumerate(sim.parameter_names)}

    def quantity(name: str, text: str) -> float:
        return float(sim.parameters({name: text})[index[name]])

    module = sim.module if sim.target == "numpy" else sim.module.__file__  # workers load it
    return studies.sweep(module, grid=grid, samples=samples, runs=runs, seed=seed,
                         metrics=metrics, t_end=t_end, dt_out=dt_out, tol=tol,
                         time_grid=time_grid, workers=workers, scheduler=scheduler, out=out,
                         resume=resume, progress=progress, quantity=quantity,
                         defaults=sim.defaults)
