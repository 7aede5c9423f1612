"""Run a study: a design (run matrix) on a generated module, locally or on Dask, with an
incremental checkpoint, and assemble the results into a StudyTable (plain arrays) or an xarray
Dataset, and a NetCDF file."""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import importlib.util
import math
import os
import sys
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from types import ModuleType

import numpy as np

from ..output import when_written
from ..results import MAX_OUTPUT_ROWS, check_output_rows
from . import backends
from .metrics import Metric, metric_attributes, static_metric_names
from .progress import ProgressBar, StudyProgress
from .spec import Design, SweepSpecError, make_design
from .storage import (Checkpoint, CheckpointError, build_table, check_store, fingerprint,
                      open_study, partial_path, stored_seed, write_dataset)
from .worker import ModuleRef, RunConfig, load_module

__all__ = ["Study", "run_study", "sweep", "StudyError", "CheckpointError"]

StudyError = backends.StudyError


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("depsim")
    except Exception:
        return "unknown"


@dataclasses.dataclass(frozen=True, eq=False)
class Study:
    """Everything that decides a study's numbers (not how or where it is executed).

    module_path: the generated module file. design: the run matrix (`make_design`).
    t_end, dt_out, tol: passed to every `simulate` call (None: the model's own).
    metrics: extra metrics, name -> f(Result) -> float (module-level functions for the local
      pool, or anything cloudpickle handles). builtin_metrics: event times, deployed, peaks,
      final outputs, run statistics.
    time_grid: None, a number of points from 0 to t_end, or explicit times (s): every output
      sampled there, as variables `output.<name>` with dims (run, time).
    simulate: replaces depsim.runtime.simulate (tests, other runtimes); same signature.
    check: the model's range checks, f(parameter vector) -> [message, ...] ([] when every
      range holds); a run it objects to is recorded as failed with those messages and is
      not simulated (the facade passes `depsim.dsl.check_parameters`, as `--set` uses)."""

    module_path: Path
    design: Design
    t_end: float | None = None
    dt_out: float | None = None
    tol: float | None = None
    metrics: Mapping[str, Metric] | None = None
    builtin_metrics: bool = True
    time_grid: np.ndarray | int | None = None
    simulate: Callable | None = None
    check: Callable[[np.ndarray], list[str]] | None = None


OUT_OF_RANGE = "out of the model's ranges"  # the error text of a run the check refused


def _time_grid(study: Study, module: ModuleType) -> np.ndarray | None:
    grid = study.time_grid
    if grid is None:
        return None
    if isinstance(grid, (int, np.integer)) and not isinstance(grid, bool):
        if not 2 <= grid <= MAX_OUTPUT_ROWS:
            raise SweepSpecError(f"time_grid: give from 2 to {MAX_OUTPUT_ROWS:,} points "
                                 f"(got {grid:,})")
        t_end = study.t_end if study.t_end is not None else float(module.T_END)
        return np.linspace(0.0, t_end, int(grid))
    grid = np.asarray(grid, dtype=float).ravel()
    if grid.size == 0 or not np.all(np.isfinite(grid)) or np.any(np.diff(grid) <= 0):
        raise SweepSpecError("time_grid: times must be finite and increasing")
    return grid


def _check_metrics(metrics) -> dict:
    metrics = dict(metrics or {})
    for name, func in metrics.items():
        if not isinstance(name, str) or not name or "/" in name:
            raise SweepSpecError(f"metric name {name!r}: a non-empty text without '/'")
        if not callable(func):
            raise SweepSpecError(f"metric '{name}' is not callable "
                                 "(a metric is f(Result) -> float)")
    return metrics


def run_study(study: Study, *, workers: int | None = None, scheduler=None,
              store: str | os.PathLike | None = None, resume: bool = False,
              batch_size: int | None = None, progress: bool | None = None,
              on_batch: Callable[[StudyProgress], None] | None = None,
              as_xarray: bool = True):
    """Run every run of `study` and return the results as an xarray Dataset (as_xarray=False:
    as a `table.StudyTable` of numpy arrays, without importing xarray; `.to_xarray()` gives
    the Dataset; a finished study resumed from its file is read with xarray).

    scheduler: None runs a local process pool of `workers` processes (default: every core);
      "inline" runs in this process; "tcp://HOST:PORT" or a `distributed.Client` uses an
      existing Dask cluster (batches of `batch_size` runs per task, default up to 50).
    store: the NetCDF file to write. Finished runs go to `<store>.partial` after every batch;
      resume=True keeps the finished runs of an interrupted study and runs only the rest (the
      final file is the same as an uninterrupted study's, wall times apart). Without resume
      an old `.partial` is discarded.
    progress: a bar on stderr (None: only when stderr is a terminal).
    on_batch: called after every batch is checkpointed, with a StudyProgress.
    A failing run never stops the study: it is recorded with its error text and NaN metrics.
    Ctrl-C keeps what finished in the checkpoint and re-raises KeyboardInterrupt."""
    if resume and store is None:
        raise SweepSpecError("resume needs the output file of the interrupted study "
                             "(store=..., -o FILE)")
    if store is not None:  # before any work: a study that cannot be saved is not started
        store = Path(store)
        check_store(store)
    require_studies()
    plan = _plan(study)
    records: dict[int, dict] = {}
    checkpoint = None
    if store is not None:
        if resume and store.exists() and not partial_path(store).exists():
            return _complete_study(store, plan.fingerprint)
        checkpoint = Checkpoint(partial_path(store), plan.fingerprint, study.design.runs,
                                study.design.seed)
        if resume:
            records = checkpoint.load()
        checkpoint.open(records)
    _refuse_out_of_range(study, records, checkpoint)
    _run_missing(plan, records, checkpoint, workers, scheduler, batch_size, progress, on_batch)
    table = build_table(records, study.design, static_metrics=plan.static,
                        user_metrics=list(plan.config.metrics), output_names=plan.outputs,
                        time_grid=plan.config.time_grid, attrs=plan.attrs,
                        describe=plan.describe, parameter_units=plan.parameter_units)
    if store is not None:
        write_dataset(table, store)
        # the checkpoint goes once the file is in place (inside `output.all_or_none`, at the
        # end of the block: if a later output fails, the runs stay resumable)
        checkpoint.close()
        when_written(checkpoint.remove)
    return table.to_xarray() if as_xarray else table


@dataclasses.dataclass(frozen=True)
class _Plan:
    """What a study's execution needs, derived once from the Study."""

    ref: ModuleRef
    design: Design
    config: RunConfig
    static: list
    outputs: tuple[str, ...]
    fingerprint: str
    attrs: dict
    describe: Callable[[str], dict]  # a metric's units and long_name
    parameter_units: tuple[str, ...] | None


def _plan(study: Study) -> _Plan:
    """Load and check the module and the design; the run configuration, the metric names,
    the fingerprint of everything that decides the numbers, the file's attributes."""
    ref = ModuleRef.from_path(study.module_path)
    module = load_module(ref)
    design = study.design
    names = tuple(module.PARAMETERS)
    if tuple(design.parameter_names) != names:
        raise ValueError("the design's parameter names are not the module's PARAMETERS")
    if design.matrix.shape != (design.runs, len(names)):
        raise ValueError(f"the run matrix has shape {design.matrix.shape}, "
                         f"expected (runs, {len(names)})")
    metrics = _check_metrics(study.metrics)
    _check_settings(study, module)
    grid = _time_grid(study, module)
    config = RunConfig(t_end=study.t_end, dt_out=_output_interval(study, module, metrics, grid),
                       tol=study.tol, metrics=metrics, builtin=study.builtin_metrics,
                       time_grid=grid, simulate=study.simulate)
    static = static_metric_names(module, metrics, study.builtin_metrics)
    settings = {"t_end": study.t_end, "dt_out": study.dt_out, "tol": study.tol,
                "builtin_metrics": study.builtin_metrics}
    fp = fingerprint(ref.sha256, names, design.matrix, settings, static, grid)
    units = getattr(module, "PARAMETER_UNITS", None)
    return _Plan(ref, design, config, static, tuple(getattr(module, "OUTPUTS", ())), fp,
                 _attributes(study, module, ref, fp),
                 functools.partial(metric_attributes, module=module, metrics=metrics),
                 tuple(units) if units is not None and len(units) == len(names) else None)


def _output_interval(study: Study, module: ModuleType, metrics: dict,
                     grid: np.ndarray | None) -> float | None:
    """The runs' dt_out. The built-in metrics read only the last output row (events and peak
    loads are measured at every step), so a study without metrics of its own, without a time
    grid and without a dt_out asks each run for its end alone: the same steps and metrics,
    without sampling and recording 1,400 rows that nothing reads (a tenth of INTELSAT V's
    run time). The one difference: a plain run's peak loads also see its output times, between
    steps, so they can be slightly higher than the study's, which are the steps' alone."""
    if study.dt_out is not None or metrics or grid is not None:
        return study.dt_out
    t_end = study.t_end if study.t_end is not None else getattr(module, "T_END", None)
    return None if t_end is None else float(t_end)


def _check_settings(study: Study, module: ModuleType) -> None:
    """SweepSpecError for a t_end, dt_out or tol that every run would fail on (they are the
    same for all runs): a study of failures is not started."""
    def setting(value, name):
        return float(value) if value is not None else getattr(module, name, None)

    t_end, dt_out = setting(study.t_end, "T_END"), setting(study.dt_out, "DT_OUT")
    tol = setting(study.tol, "TOL")
    for name, value in (("t_end", t_end), ("dt_out", dt_out)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise SweepSpecError(f"{name} must be a positive number of seconds, got {value}")
    if tol is not None and not 0 < tol < 1:
        raise SweepSpecError(f"tol must lie between 0 and 1, got {tol}")
    if t_end is not None and dt_out is not None:
        try:
            check_output_rows(t_end, dt_out)
        except ValueError as exc:
            raise SweepSpecError(str(exc)) from None


def _attributes(study: Study, module: ModuleType, ref: ModuleRef, fp: str) -> dict:
    """The NetCDF file's global attributes."""
    design = study.design

    def setting(value, name):
        return float(value if value is not None else getattr(module, name, np.nan))

    return {
        "title": f"depsim parameter study of {getattr(module, 'MODEL_NAME', '?')}",
        "model": str(getattr(module, "MODEL_NAME", "")),
        "source_file": str(getattr(module, "SOURCE_FILE", "")),
        "source_sha256": str(getattr(module, "SOURCE_SHA256", "")),
        "module_sha256": ref.sha256,
        "depsim_version": _version(),
        "generated_by_depsim": str(getattr(module, "DEPSIM_VERSION", "")),
        "target": "c" if Path(ref.path).suffix in (".so", ".dylib", ".dll") else "numpy",
        "study_kind": design.kind,
        "spec": design.spec,
        "seed": design.seed,
        "runs": design.runs,
        "varied": ", ".join(design.varied),
        "t_end": setting(study.t_end, "T_END"),
        "tol": setting(study.tol, "TOL"),
        "dt_out": setting(study.dt_out, "DT_OUT"),
        "fingerprint": fp,
    }


def _complete_study(store: Path, fp: str):
    """The finished study in `store` (resume without a checkpoint); CheckpointError when the
    file is not a readable study or holds another study: resuming refuses to rerun every run
    over a file it cannot account for."""
    try:
        existing = open_study(store)
    except Exception as exc:
        raise CheckpointError(
            f"{store} is not a readable study file (truncated?): {type(exc).__name__}: "
            f"{str(exc).strip() or 'unreadable'}. There is no checkpoint "
            f"{partial_path(store).name} to resume from either; nothing was run or changed: "
            "delete the file, or run without resume (--resume) to start the study over"
        ) from None
    if existing.attrs.get("fingerprint") != fp:
        raise CheckpointError(
            f"{store} holds a different study (model, parameters, settings or metrics "
            f"changed), and there is no checkpoint {partial_path(store).name} to resume from; "
            "nothing was run or changed: run without resume (--resume) to replace it, or "
            "write to another file")
    return existing


def _refuse_out_of_range(study: Study, records: dict, checkpoint) -> None:
    """Record every run whose parameters break a range of the model (`study.check`) as
    failed, with the ranges it breaks, without running it: a negative friction or length
    gives no answer worth having (a run may well complete with it)."""
    if study.check is None:
        return
    refused = []
    for index in range(study.design.runs):
        if index in records:
            continue
        problems = study.check(study.design.matrix[index])
        if problems:
            refused.append({"run": index, "failed": True, "values": {}, "wall": math.nan,
                            "series": None,
                            "error": f"{OUT_OF_RANGE}: {'; '.join(problems)}"})
    if checkpoint is not None and refused:
        checkpoint.append(refused)
    records.update((r["run"], r) for r in refused)


def _run_missing(plan: _Plan, records: dict, checkpoint, workers, scheduler, batch_size,
                 progress, on_batch) -> None:
    """Run every run not in `records`, adding them there (and to the checkpoint) batch by
    batch. On Ctrl-C or a stopped study the checkpoint keeps what finished."""
    design = plan.design
    todo = [i for i in range(design.runs) if i not in records]
    failed = sum(1 for r in records.values() if r["failed"])
    bar = ProgressBar(design.runs, len(records), failed, enabled=progress)
    t0 = time.perf_counter()
    try:
        if todo:
            # closing(): stop the workers at once when this loop ends by an exception
            # (Ctrl-C, on_batch raising), not when the generator is garbage-collected.
            batches = contextlib.closing(_execute(plan.ref, plan.config, design.matrix, todo,
                                                  workers, scheduler, batch_size))
            with batches as finished:
                for batch_records in finished:
                    fresh = [r for r in batch_records if r["run"] not in records]
                    if checkpoint is not None:
                        checkpoint.append(fresh)
                    for r in fresh:
                        records[r["run"]] = r
                        failed += bool(r["failed"])
                    bar.update(len(records), failed)
                    if on_batch is not None:
                        on_batch(StudyProgress(len(records), design.runs, failed,
                                               time.perf_counter() - t0))
    except BaseException as exc:
        bar.close()
        if checkpoint is not None:
            checkpoint.close()
            if isinstance(exc, (KeyboardInterrupt, StudyError)):
                print(f"depsim: {len(records)} of {design.runs} run{'s' * (design.runs != 1)} "
                      f"kept in {checkpoint.path}; run again with resume (--resume) to finish",
                      file=sys.stderr)
        raise
    bar.close()


STUDY_PACKAGES = ("xarray", "h5netcdf", "h5py")  # the `studies` extra (dask: its schedulers)


def require_studies() -> None:
    """SweepSpecError naming what to install when the `studies` extra is missing."""
    missing = [name for name in STUDY_PACKAGES if importlib.util.find_spec(name) is None]
    if missing:
        raise SweepSpecError(f"parameter studies need {', '.join(missing)}, which this "
                             "installation lacks: pip install 'depsim[studies]'")


def _execute(ref, config, matrix, todo, workers, scheduler, batch_size):
    if scheduler is None or scheduler in ("local", "processes", "pool"):
        workers = workers or backends.default_workers()
        # batches of up to 25 runs: a batch is the unit that an interruption can lose (a third
        # of a second of INTELSAT V's runs), and each costs the pool about a millisecond of
        # the parent's time, which shares the cores with the workers (2,000 INTELSAT V runs on
        # 2 cores: 14.0 s in batches of 5, 13.6 s in batches of 25); shrinking to single runs
        # at the end, so that the workers finish together (guided_batches)
        batches = backends.split_batches(todo, batch_size) if batch_size \
            else backends.guided_batches(todo, workers, 25)
        yield from backends.run_pool(ref, config, matrix, batches, workers)
    elif scheduler in ("inline", "serial", "synchronous"):
        size = batch_size or backends.batch_size_for(len(todo), 1, 20, 20)
        yield from backends.run_inline(ref, config, matrix, backends.split_batches(todo, size))
    else:
        if isinstance(scheduler, str) and "://" not in scheduler:
            raise SweepSpecError(f"scheduler '{scheduler}': use 'tcp://HOST:PORT', a "
                             "distributed.Client, 'inline' or None (local processes)")
        slots = workers
        if slots is None:
            slots = _dask_slots(scheduler)
        size = batch_size or backends.batch_size_for(len(todo), slots, 4, 50)
        yield from backends.run_dask(ref, config, matrix, backends.split_batches(todo, size),
                                     scheduler)


def _dask_slots(scheduler) -> int:
    try:
        from distributed import Client

        if isinstance(scheduler, Client):
            return max(1, sum(scheduler.nthreads().values()))
    except Exception:
        pass
    return 8


def sweep(module: ModuleType | str | os.PathLike, *, grid=None, samples=None,
          runs: int | None = None, seed: int | None = None,
          metrics: Mapping[str, Metric] | None = None, t_end: float | None = None,
          dt_out: float | None = None, tol: float | None = None, time_grid=None,
          workers: int | None = None, scheduler=None, out: str | os.PathLike | None = None,
          resume: bool = False, progress: bool | None = None, batch_size: int | None = None,
          quantity: Callable[[str, str], float] | None = None,
          defaults: np.ndarray | None = None, simulate: Callable | None = None,
          on_batch: Callable[[StudyProgress], None] | None = None,
          check: Callable[[np.ndarray], list[str]] | None = None, as_xarray: bool = True):
    """One call: build the design from grid/sample items and run it (see `make_design` and
    `run_study`). `module` is a generated module (with __file__) or its path; `defaults`
    replaces the module's PARAMETER_DEFAULTS as the base vector; `quantity(name, text)`
    converts values with units; `check(p)` lists the ranges a parameter vector breaks (those
    runs are recorded as failed, unrun). Returns the xarray Dataset (also written to `out`;
    as_xarray=False: the StudyTable, see `run_study`)."""
    path = Path(module.__file__) if isinstance(module, ModuleType) else Path(module)
    loaded = module if isinstance(module, ModuleType) else load_module(path)
    base = np.array(loaded.PARAMETER_DEFAULTS if defaults is None else defaults, dtype=float)
    if resume and seed is None and samples and out is not None:
        seed = stored_seed(out)  # the study being resumed drew its seed at random
    design = make_design(tuple(loaded.PARAMETERS), base, grid=grid, samples=samples, runs=runs,
                         seed=seed, quantity=quantity)
    study = Study(path, design, t_end=t_end, dt_out=dt_out, tol=tol, metrics=metrics,
                  time_grid=time_grid, simulate=simulate, check=check)
    return run_study(study, workers=workers, scheduler=scheduler, store=out, resume=resume,
                     batch_size=batch_size, progress=progress, on_batch=on_batch,
                     as_xarray=as_xarray)
