"""What runs inside a worker: load the generated module once, run batches of parameter vectors.

Everything here is plain data in, plain data out (picklable), so the same `run_batch` serves the
in-process runner, the local process pool and Dask workers. This module imports neither sympy
nor `depsim.dsl` / `depsim.codegen`: a generated module is loaded from its file with importlib.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import math
import os
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from types import ModuleType

import numpy as np

from .metrics import Metric, evaluate

__all__ = ["ModuleRef", "RunConfig", "load_module", "run_one", "run_batch", "file_sha256"]


def file_sha256(path: str | os.PathLike) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@dataclasses.dataclass(frozen=True)
class ModuleRef:
    """A generated module file, identified by the SHA-256 of its bytes.

    `source` carries the file's bytes for workers that cannot see `path` (remote Dask
    workers); they write it to a local cache keyed by the hash and import it from there."""

    path: str
    sha256: str
    source: bytes | None = None

    @classmethod
    def from_path(cls, path: str | os.PathLike, include_source: bool = False) -> ModuleRef:
        path = Path(path).resolve()
        data = path.read_bytes()
        return cls(str(path), hashlib.sha256(data).hexdigest(), data if include_source else None)

    def with_source(self) -> ModuleRef:
        if self.source is not None:
            return self
        data = Path(self.path).read_bytes()
        if hashlib.sha256(data).hexdigest() != self.sha256:
            raise RuntimeError(f"{self.path} changed since the study started")
        return dataclasses.replace(self, source=data)


_MODULES: dict[str, ModuleType] = {}  # sha256 -> module, one load per process


def _cache_root() -> Path:
    """Where workers keep module files sent as source: the cache's sweep-modules folder."""
    from depsim.runtime.core import cache_root

    return cache_root() / "sweep-modules"


def load_module(ref: ModuleRef | str | os.PathLike) -> ModuleType:
    """Import a generated module (once per process per file hash) from its path, or from the
    source text `ref` carries when the path is not visible here or holds another file."""
    if not isinstance(ref, ModuleRef):
        ref = ModuleRef.from_path(ref)
    module = _MODULES.get(ref.sha256)
    if module is not None:
        return module
    path = Path(ref.path)
    if not (path.is_file() and file_sha256(path) == ref.sha256):
        if ref.source is None:
            raise FileNotFoundError(
                f"generated module {ref.path} (sha256 {ref.sha256[:12]}) is not on this machine; "
                "send its source (remote Dask workers get it automatically)")
        if hashlib.sha256(ref.source).hexdigest() != ref.sha256:
            raise RuntimeError("generated module source does not match its hash")
        folder = _cache_root() / ref.sha256[:32]
        path = folder / Path(ref.path).name
        if not (path.is_file() and file_sha256(path) == ref.sha256):
            folder.mkdir(parents=True, exist_ok=True)
            tmp = folder / f".{path.name}.{os.getpid()}.tmp"
            tmp.write_bytes(ref.source)
            os.replace(tmp, path)
    if path.suffix in (".so", ".dylib", ".dll"):  # a C target's shared library
        from depsim.runtime.binding import load_c_module

        module = _MODULES[ref.sha256] = load_c_module(path)
        return module
    name = f"_depsim_generated_{Path(ref.path).stem}_{ref.sha256[:16]}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot import {path}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    _MODULES[ref.sha256] = module
    return module


@dataclasses.dataclass(frozen=True, eq=False)
class RunConfig:
    """How every run of a study is simulated and measured (sent to each worker once)."""

    t_end: float | None = None
    dt_out: float | None = None
    tol: float | None = None
    metrics: Mapping[str, Metric] | None = None
    builtin: bool = True
    time_grid: np.ndarray | None = None  # outputs sampled at these times, dims (run, time)
    simulate: Callable | None = None  # None: depsim.runtime.simulate


def _simulator(config: RunConfig, module: ModuleType) -> Callable[[np.ndarray], object]:
    """f(p) -> what the run's metrics read. When the built-in metrics alone read the runs
    (no metrics of the study's own, no time grid, depsim's own simulate), the run's end alone
    (`RunEnds`: the same C call, the same numbers, no rows read and no Result built); else the
    whole Result of `config.simulate`, or of depsim.runtime.simulate."""
    if config.simulate is None and not config.metrics and config.time_grid is None:
        from depsim.runtime.runner import RunEnds  # the runtime package, not dsl/codegen

        ends: list[RunEnds] = []

        def run_end(p: np.ndarray):  # made at the first run: what it raises fails that run
            if not ends:
                ends.append(RunEnds(module, t_end=config.t_end, dt_out=config.dt_out,
                                    tol=config.tol))
            return ends[0].run(p)

        return run_end
    simulate = config.simulate
    if simulate is None:
        from depsim.runtime import simulate

    def run(p: np.ndarray):
        return simulate(module, p, t_end=config.t_end, dt_out=config.dt_out, tol=config.tol,
                        progress=False)

    return run


def _sample(times: np.ndarray, values: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Outputs at the grid times (linear interpolation); NaN past the end of the run."""
    if times.size == 0:
        return np.full(grid.shape, math.nan)
    out = np.interp(grid, times, values)
    slack = 1e-9 * max(1.0, abs(float(times[-1])))
    out[(grid > times[-1] + slack) | (grid < times[0] - slack)] = math.nan
    return out


def run_one(module: ModuleType, config: RunConfig, index: int, params: np.ndarray,
            simulate: Callable[[np.ndarray], object] | None = None) -> dict:
    """Simulate one parameter vector and measure it. Never raises for a failing run: the
    record carries the error text and no metric values (NaN later). simulate: f(p), as
    `_simulator` makes it (None: made for this run)."""
    from .metrics import result_output, result_times

    simulate = simulate or _simulator(config, module)
    p = np.array(params, dtype=float)
    start = time.perf_counter()
    try:
        result = simulate(p)
    except Exception as exc:  # SolverError, a bad sample (negative mass), anything: recorded
        return {"run": int(index), "failed": True, "error": _error_text(exc), "values": {},
                "wall": time.perf_counter() - start, "series": None}
    wall = time.perf_counter() - start
    values, errors = evaluate(result, module, config.metrics, config.builtin)
    series = None
    if config.time_grid is not None:
        try:
            times = result_times(result)
            series = [_sample(times, result_output(result, name), config.time_grid).tolist()
                      for name in getattr(module, "OUTPUTS", ())]
        except Exception as exc:
            errors.append(f"outputs on the time grid: {_error_text(exc)}")
    return {"run": int(index), "failed": False, "error": "; ".join(errors), "values": values,
            "wall": wall, "series": series}


def _error_text(exc: BaseException) -> str:
    text = str(exc).strip()
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def run_batch(ref: ModuleRef, config: RunConfig, indices: Sequence[int],
              params: np.ndarray) -> list[dict]:
    """Run rows `params` (runs x NP) with run numbers `indices`: one record per run."""
    module = load_module(ref)
    simulate = _simulator(config, module)
    return [run_one(module, config, i, row, simulate) for i, row in zip(indices, params)]


# --- local process pool: the module and config are set up once per worker process ----------

_STATE: dict[str, object] = {}


def init_pool_worker(ref: ModuleRef, config_blob: bytes) -> None:
    """ProcessPoolExecutor initializer: die with the parent process, ignore Ctrl-C (the parent
    handles it), load the module and the config once."""
    import pickle
    import signal

    die_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _STATE["ref"] = ref
    _STATE["config"] = pickle.loads(config_blob)
    load_module(ref)


def pool_run_batch(indices: Sequence[int], params: np.ndarray) -> list[dict]:
    """A batch in a pool worker (set up by `init_pool_worker`)."""
    return run_batch(_STATE["ref"], _STATE["config"], indices, params)


PR_SET_PDEATHSIG = 1  # linux/prctl.h
WATCH_PARENT_EVERY = 1.0  # s, where the kernel cannot be asked (not Linux)


def die_with_parent() -> None:
    """End this worker process when its parent (the study) ends, however it ends: a parent
    killed with SIGKILL runs no cleanup, and its pool workers, blocked on a queue the parent
    will never write, would otherwise live on (and with them multiprocessing's resource
    tracker). Linux: the kernel sends SIGKILL at the parent's death (prctl PR_SET_PDEATHSIG);
    elsewhere a daemon thread polls the parent's pid."""
    import multiprocessing
    import signal
    import threading

    parent = multiprocessing.parent_process()
    if parent is None:  # not started by multiprocessing
        return
    if sys.platform.startswith("linux") and _prctl(PR_SET_PDEATHSIG, signal.SIGKILL):
        if os.getppid() != parent.pid:  # the parent died before prctl took effect
            os._exit(1)
        return

    def watch() -> None:
        while os.getppid() == parent.pid:
            time.sleep(WATCH_PARENT_EVERY)
        os._exit(1)

    threading.Thread(target=watch, name="depsim-parent-watch", daemon=True).start()


def _prctl(option: int, value: int) -> bool:
    """prctl(2) through the C library; False when it cannot be called or fails."""
    import ctypes

    try:
        libc = ctypes.CDLL(None, use_errno=True)  # this process's symbols: the C library's
        return libc.prctl(option, value, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False
