"""Study storage: the incremental checkpoint (`<out>.partial`, JSON lines) and the final
study (`table.StudyTable`, or an xarray Dataset) and its NetCDF file (h5netcdf: NetCDF-4/HDF5).

The checkpoint's first line identifies the study (a fingerprint of the module file, the run
matrix, the settings and the metric names); each later line is one finished run. Lines are
flushed and fsync'ed after every batch, so a Ctrl-C or a killed process loses at most the batch
in flight. JSON keeps every float exactly (Python writes the shortest repr that round-trips).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np

from ..output import OutputError, atomic_path, check_output, writes_in_place
from .table import Column, StudyTable, write_table

__all__ = ["ENGINE", "Checkpoint", "CheckpointError", "fingerprint", "partial_path", "stored_seed",
           "build_table", "build_dataset", "write_dataset", "open_study", "metric_order", "check_store"]

ENGINE = "h5netcdf"
FORMAT_VERSION = 1


class CheckpointError(RuntimeError):
    """The `.partial` file belongs to another study (or is not a depsim checkpoint)."""


def partial_path(store: str | os.PathLike) -> Path:
    store = Path(store)
    return store.with_name(store.name + ".partial")


def check_store(store: str | os.PathLike) -> None:
    """OutputError unless a study file can be written to `store` and its checkpoint beside
    it (`output.check_output`); a study is a file, never a pipe or a device."""
    check_output(store)
    if writes_in_place(store):
        raise OutputError(f"cannot write {store}: a study is written to a file, with its "
                          "checkpoint beside it; not to a pipe or a device")
    check_output(partial_path(store))


def fingerprint(module_sha256: str, parameter_names: Sequence[str], matrix: np.ndarray,
                settings: Mapping[str, object], metric_names: Sequence[str],
                time_grid: np.ndarray | None) -> str:
    """SHA-256 over everything that decides a study's numbers (not how it is executed)."""
    h = hashlib.sha256()
    h.update(json.dumps({"format": FORMAT_VERSION, "module": module_sha256,
                         "parameters": list(parameter_names), "settings": dict(settings),
                         "metrics": list(metric_names)}, sort_keys=True).encode())
    h.update(np.ascontiguousarray(matrix, dtype="<f8").tobytes())
    if time_grid is not None:
        h.update(b"time")
        h.update(np.ascontiguousarray(time_grid, dtype="<f8").tobytes())
    return h.hexdigest()


class Checkpoint:
    """Append-only record of finished runs next to the output file."""

    def __init__(self, path: str | os.PathLike, fingerprint: str, runs: int,
                 seed: int | None = None):
        self.path = Path(path)
        self.fingerprint = fingerprint
        self.runs = runs
        self.seed = seed
        self._file = None

    def _header(self) -> str:
        return json.dumps({"depsim_sweep_partial": FORMAT_VERSION,
                           "fingerprint": self.fingerprint, "runs": self.runs,
                           "seed": self.seed})

    def load(self) -> dict[int, dict]:
        """Finished runs from an existing checkpoint ({} if there is none). A torn last line
        (the process died mid-write) is ignored."""
        if not self.path.exists():
            return {}
        lines = self.path.read_text(encoding="utf-8").splitlines()
        try:
            header = json.loads(lines[0]) if lines else {}
        except json.JSONDecodeError:
            header = {}
        if not isinstance(header, dict) or "depsim_sweep_partial" not in header:
            raise CheckpointError(f"{self.path} is not a depsim sweep checkpoint")
        if header.get("fingerprint") != self.fingerprint:
            raise CheckpointError(
                f"{self.path} belongs to a different study (model, parameters, settings or "
                "metrics changed); delete it, or run without resume to start over")
        records: dict[int, dict] = {}
        for line in lines[1:]:
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                continue
            index = record.get("run")
            if isinstance(index, int) and 0 <= index < self.runs:
                records.setdefault(index, record)
        return records

    def open(self, kept: Mapping[int, dict]) -> None:
        """Rewrite the file cleanly with `kept` (dropping any torn line), then append."""
        tmp = self.path.with_name(self.path.name + ".tmp")
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(self._header() + "\n")
            for index in sorted(kept):
                f.write(_line(kept[index]))
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.path)
        self._file = open(self.path, "a", encoding="utf-8")

    def append(self, records: Iterable[dict]) -> None:
        self._file.write("".join(_line(r) for r in records))
        self._file.flush()
        os.fsync(self._file.fileno())

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def remove(self) -> None:
        self.close()
        self.path.unlink(missing_ok=True)


def stored_seed(store: str | os.PathLike) -> int | None:
    """The seed of the study in `<store>.partial` (or in `store`), for resuming a Monte Carlo
    study whose seed was drawn at random; None if there is none."""
    partial = partial_path(store)
    try:
        if partial.exists():
            with open(partial, encoding="utf-8") as f:
                seed = json.loads(f.readline()).get("seed")
            return int(seed) if seed is not None else None
        if Path(store).exists():
            seed = open_study(store).attrs.get("seed")
            return int(seed) if seed is not None else None
    except (OSError, ValueError, TypeError, AttributeError):
        return None
    return None


def _line(record: dict) -> str:
    return json.dumps(record, allow_nan=True, separators=(",", ":")) + "\n"


METRIC_GROUPS = ("deployed", "time_to_deploy", "event.", "peak.", "dissipated.", "final.",
                 "stats.")  # the order of the built-in metrics in a study


def metric_order(records: Iterable[dict], static: Sequence[str],
                 user: Sequence[str]) -> list[str]:
    """Every metric name in a stable order: deployed, time to deploy, events, peak loads,
    dissipated energies (each sorted by name), final outputs, run statistics (first-seen
    order), then user metrics in the order given."""
    seen: dict[str, None] = {}
    for name in static:
        seen.setdefault(name, None)
    for record in records:
        for name in record.get("values", {}):
            seen.setdefault(name, None)
    user = [n for n in user if n in seen]
    rest = [n for n in seen if n not in user]

    def group(name: str) -> int:
        for rank, prefix in enumerate(METRIC_GROUPS):
            if name == prefix or (prefix.endswith(".") and name.startswith(prefix)):
                return rank
        return len(METRIC_GROUPS)

    ordered = []
    for rank, prefix in enumerate(METRIC_GROUPS):
        members = [n for n in rest if group(n) == rank]
        natural = prefix in ("event.", "peak.", "dissipated.")
        ordered += sorted(members, key=_natural) if natural else members
    return ordered + [n for n in rest if group(n) == len(METRIC_GROUPS)] + user


def _natural(name: str) -> list:
    """A sort key taking numbers as numbers: h2 before h10, panel[9] before panel[10]."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", name)]


def build_table(records: Mapping[int, dict], design, *, static_metrics: Sequence[str],
                user_metrics: Sequence[str], output_names: Sequence[str],
                time_grid: np.ndarray | None, attrs: Mapping[str, object],
                describe: Callable[[str], dict] | None = None,
                parameter_units: Sequence[str] | None = None) -> StudyTable:
    """The study as plain arrays (dims `run`, `parameter`, and `time` with a time grid).
    describe(name): a metric's attributes (`units`, `long_name`); parameter_units: the SI
    unit of each parameter, in `design.parameter_names` order."""
    runs = design.runs
    ordered = [records[i] for i in range(runs)]
    names = metric_order(ordered, static_metrics, user_metrics)
    reserved = {"run", "time", "parameter", "failed", "error", "wall_time",
                "parameter_values", *names, *(f"output.{o}" for o in output_names)}
    clash = [p for p in design.varied if p in reserved]
    if clash:
        raise ValueError(f"parameter name(s) {clash} clash with study variable names")
    data = {name: Column(("run",), column, describe(name) if describe else {})
            for name, column in _metric_columns(ordered, names).items()}
    data["failed"] = Column(("run",), np.array([bool(r["failed"]) for r in ordered]),
                            {"description": "the simulation raised (its metrics are NaN)"})
    data["error"] = Column(("run",), np.array([str(r.get("error") or "") for r in ordered],
                                              dtype=str),
                           {"description": "error text of a failed run or metric; empty when "
                                           "none"})
    data["wall_time"] = Column(("run",),
                               np.array([float(r.get("wall", math.nan)) for r in ordered]),
                               {"units": "s", "description": "wall time inside simulate"})
    data["parameter_values"] = Column(
        ("run", "parameter"), np.array(design.matrix, dtype=float),
        {"description": "the full parameter vector of each run (SI)"})
    coords = {"run": Column(("run",), np.arange(runs)),
              "parameter": Column(("parameter",), np.array(design.parameter_names, dtype=str))}
    units = dict(zip(design.parameter_names, parameter_units or ()))
    if parameter_units is not None:
        coords["parameter_unit"] = Column(("parameter",), np.array(parameter_units, dtype=str),
                                          {"description": "SI unit of each parameter"})
    for name in design.varied:
        coords[name] = Column(("run",), design.values(name).copy(),
                              {"units": units[name]} if units.get(name) else {})
    if time_grid is not None:
        coords["time"] = Column(("time",), np.asarray(time_grid, dtype=float), {"units": "s"})
        for k, out in enumerate(output_names):
            block = np.full((runs, len(time_grid)), math.nan)
            for i, record in enumerate(ordered):
                series = record.get("series")
                if series is not None and k < len(series):
                    block[i] = series[k]
            data[f"output.{out}"] = Column(("run", "time"), block)
    return StudyTable(data, coords, {k: v for k, v in attrs.items() if v is not None})


def _metric_columns(ordered: Sequence[dict], names: Sequence[str]) -> dict[str, np.ndarray]:
    """Each metric's values over the runs (NaN where a run has none)."""
    columns = {name: np.full(len(ordered), math.nan) for name in names}
    for i, record in enumerate(ordered):
        for name, value in record.get("values", {}).items():
            column = columns.get(name)
            if column is not None and value is not None:
                column[i] = value
    return columns


def build_dataset(records: Mapping[int, dict], design, **settings):
    """The study as an xarray Dataset (`build_table`'s arguments; imports xarray)."""
    return build_table(records, design, **settings).to_xarray()


def write_dataset(ds, path: str | os.PathLike) -> Path:
    """Write a StudyTable (`table.write_table`, without xarray) or an xarray Dataset (with the
    pinned engine) through `output.atomic_path` (a temporary file, then a rename: never a
    half-written file)."""
    if isinstance(ds, StudyTable):
        return write_table(ds, path)
    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, engine=ENGINE)
    return Path(path)


def open_study(path: str | os.PathLike):
    """Load a study file into memory (the file is closed on return)."""
    import xarray as xr

    return xr.load_dataset(path, engine=ENGINE)
