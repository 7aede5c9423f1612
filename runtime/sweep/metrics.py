"""Per-run metrics: named functions of a `Result`.

A metric is `name -> f(result) -> float`. The built-in ones (on unless `builtin=False`):

    event.<name>.t      time of the first occurrence of every event (NaN: it never happened)
    event.<name>.<key>  each number the runtime attached to that first occurrence
    deployed            1.0 when every latch event happened by t_end, else 0.0 (only for
                        models with latches)
    peak.<name>         peak loads, when the Result provides them (`result.peaks`, a mapping)
    final.<output>      the last value of every output
    stats.<field>       every numeric run statistic (accepted_steps, rejected_steps,
                        position.total iterations, ...), nested fields joined with dots

User metrics are added by name; a name that collides with a built-in replaces it. A metric that
raises gives NaN for that run and the error text is kept with the run.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable, Mapping

import numpy as np

__all__ = ["Metric", "builtin_metrics", "latch_events", "result_times", "result_output",
           "result_events", "result_stats", "evaluate"]

Metric = Callable[[object], float]


def result_times(result) -> np.ndarray:
    for attr in ("times", "t", "time"):
        value = getattr(result, attr, None)
        if value is not None:
            return np.asarray(value, dtype=float)
    raise AttributeError("the Result has no times")


def result_output(result, name: str) -> np.ndarray:
    """Output `name` over time: `result.output(name)`, or `result.outputs[name]`."""
    if callable(getattr(result, "output", None)):
        return np.asarray(result.output(name), dtype=float)
    outputs = getattr(result, "outputs", None)
    if isinstance(outputs, Mapping):
        return np.asarray(outputs[name], dtype=float)
    names = tuple(getattr(result, "output_names", ()))
    if outputs is not None and name in names:
        return np.asarray(outputs, dtype=float)[:, names.index(name)]
    return np.asarray(result[name], dtype=float)


def result_output_names(result, module=None) -> tuple[str, ...]:
    if module is not None and hasattr(module, "OUTPUTS"):
        return tuple(module.OUTPUTS)
    if getattr(result, "output_names", None) is not None:
        return tuple(result.output_names)
    outputs = getattr(result, "outputs", None)
    return tuple(outputs) if isinstance(outputs, Mapping) else ()


def _event(event) -> tuple[str, float, Mapping]:
    if isinstance(event, Mapping):
        data = {k: v for k, v in event.items() if k not in ("name", "t")}
        return str(event["name"]), float(event["t"]), data
    return str(event.name), float(event.t), getattr(event, "data", None) or {}


def result_events(result) -> list[tuple[str, float]]:
    """(name, t) of every event, in the order they happened."""
    return [_event(e)[:2] for e in getattr(result, "events", None) or ()]


def _is_number(v) -> bool:
    return isinstance(v, (numbers.Real, np.bool_)) and not isinstance(v, str)


def _flatten(prefix: str, value, out: dict[str, float]) -> None:
    if _is_number(value):
        out[prefix] = float(value)
    elif isinstance(value, Mapping):
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), v, out)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for f in dataclasses.fields(value):
            _flatten(f"{prefix}.{f.name}" if prefix else f.name, getattr(value, f.name), out)


def result_stats(result) -> dict[str, float]:
    """Every numeric field of `result.stats` (a mapping or dataclass; nested ones flattened
    with dots, e.g. `position.total`)."""
    stats = getattr(result, "stats", None)
    out: dict[str, float] = {}
    if stats is None:
        return out
    if isinstance(stats, Mapping) or dataclasses.is_dataclass(stats):
        _flatten("", stats, out)
    else:
        for k, v in vars(stats).items():
            if not k.startswith("_"):
                _flatten(k, v, out)
    return out


def latch_events(module, params=None) -> tuple[str, ...] | None:
    """Names of the events that mean 'hinge latched' ("<hinge>.latch"), or None if the module
    does not say which hinges latch.

    From the generated module's `hinge_properties(p)` (NaN where a hinge has no latch) and
    `HINGE_PROPERTIES`, or a plain `LATCHES` tuple of hinge names."""
    latches = getattr(module, "LATCHES", None)
    if latches is None:
        names = tuple(getattr(module, "HINGE_PROPERTIES", ()))
        function = getattr(module, "hinge_properties", None)
        if "latch" not in names or function is None:
            return None
        p = np.asarray(module.PARAMETER_DEFAULTS if params is None else params, dtype=float)
        try:
            table = np.asarray(function(p), dtype=float).reshape(len(module.HINGES), len(names))
        except Exception:
            return None
        column = table[:, names.index("latch")]
        latches = [h for h, value in zip(module.HINGES, column) if np.isfinite(value)]
    return tuple(f"{name}.latch" for name in latches)


def builtin_metrics(result, module) -> dict[str, float]:
    """The built-in metrics of one successful run (see the module docstring)."""
    values: dict[str, float] = {}
    first: dict[str, tuple[float, Mapping]] = {}
    for event in getattr(result, "events", None) or ():
        name, t, data = _event(event)
        first.setdefault(name, (t, data))
    for name in sorted(first):
        t, data = first[name]
        values[f"event.{name}.t"] = t
        for key, value in sorted(data.items()):  # e.g. energy lost at a latch
            if _is_number(value):
                values[f"event.{name}.{key}"] = float(value)
    latches = latch_events(module, getattr(result, "parameters", None))
    if latches:
        values["deployed"] = float(all(name in first for name in latches))
    peaks = getattr(result, "peaks", None)
    if isinstance(peaks, Mapping):
        for name, value in peaks.items():
            values[f"peak.{name}"] = float(value)
    for name in result_output_names(result, module):
        series = result_output(result, name)
        values[f"final.{name}"] = float(series[-1]) if series.size else math.nan
    for name, value in result_stats(result).items():
        values[f"stats.{name}"] = value
    return values


def static_metric_names(module, metrics: Mapping[str, Metric] | None, builtin: bool) -> list[str]:
    """Metric names known before any run (event names are only known from the runs)."""
    names = []
    if builtin:
        if latch_events(module):
            names.append("deployed")
        names += [f"final.{o}" for o in getattr(module, "OUTPUTS", ())]
    names += [n for n in (metrics or {}) if n not in names]
    return names


def evaluate(result, module, metrics: Mapping[str, Metric] | None,
             builtin: bool = True) -> tuple[dict[str, float], list[str]]:
    """All metrics of one run: (name -> value, error texts of metrics that raised)."""
    values = builtin_metrics(result, module) if builtin else {}
    errors = []
    for name, metric in (metrics or {}).items():
        try:
            values[name] = float(metric(result))
        except Exception as exc:  # a user metric failing must not lose the run
            values[name] = math.nan
            errors.append(f"metric '{name}': {type(exc).__name__}: {exc}")
    return values, errors
