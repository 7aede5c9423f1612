"""Per-run metrics: named functions of a `Result`, each with its unit.

A metric is `name -> f(result) -> float`. The built-in ones (on unless `builtin=False`), read
from what the run reports (`Result.deployment`, `Result.peak_loads`, `Result.events`,
`Result.dissipated`; docs/deployment.md), never recomputed:

    deployed             1 when every latch engaged by t_end, else 0 (models with latches)
    time_to_deploy       s: when the last latch engaged (NaN: not deployed)
    event.<name>.t       s: the first occurrence of every event (NaN: it never happened)
    event.<name>.<key>   each number the runtime attached to that first occurrence: for a
                         latch `rate` (rad/s, just before), `impulse` (N*m*s),
                         `impact_energy_loss` (J), `angle` (rad), `rigid`
    peak.<hinge>.force   N: the largest hinge force; `.t_force` its time (s)
    peak.<hinge>.torque  N*m: the largest lock torque; `.t_torque` its time (s)
    dissipated.<kind>    J: energy dissipated by friction, damping, latch dampers, inputs
                         (`friction`, `damping`, `latch`, `input`) and impacts (`impact`)
    final.<output>       the last value of every output, in its unit
    stats.<field>        every numeric run statistic (accepted_steps, rejected_steps,
                         position.total iterations, ...), nested fields joined with dots

`metric_attributes(name, module, metrics)` gives each its unit and a description. User metrics
are added by name (a function's `units` attribute, if any, is its unit); a name that collides
with a built-in replaces it. A metric that raises gives NaN for that run and the error text is
kept with the run.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
from collections.abc import Callable, Mapping

import numpy as np

__all__ = ["Metric", "builtin_metrics", "latch_events", "result_times", "result_output",
           "result_events", "result_stats", "evaluate", "metric_attributes", "known_metric"]

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
    if type(v) in (float, int, bool):  # most values: without the ABC's isinstance
        return True
    return isinstance(v, (numbers.Real, np.bool_)) and not isinstance(v, str)


def _flatten(prefix: str, value, out: dict[str, float]) -> None:
    if _is_number(value):
        out[prefix] = float(value)
    elif isinstance(value, Mapping):
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), v, out)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for name in _field_names(type(value)):
            _flatten(f"{prefix}.{name}" if prefix else name, getattr(value, name), out)


@functools.cache
def _field_names(kind: type) -> tuple[str, ...]:
    """A dataclass's field names, found once a class (`dataclasses.fields` each time took a
    fifth of a run's metrics)."""
    return tuple(f.name for f in dataclasses.fields(kind))


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
    values.update(_deployment(result, module, first))
    for name in sorted(first):
        t, data = first[name]
        values[f"event.{name}.t"] = t
        for key, value in sorted(data.items()):  # e.g. a latch's rate and impulse
            if _is_number(value):
                values[f"event.{name}.{key}"] = float(value)
    for hinge, peak in (getattr(result, "peak_loads", None) or {}).items():
        for field in PEAK_FIELDS:
            values[f"peak.{hinge}.{field}"] = float(getattr(peak, field))
    values.update(_dissipated(result))
    for name in result_output_names(result, module):
        series = result_output(result, name)
        values[f"final.{name}"] = float(series[-1]) if series.size else math.nan
    for name, value in result_stats(result).items():
        values[f"stats.{name}"] = value
    return values


def _deployment(result, module, first: Mapping[str, tuple]) -> dict[str, float]:
    """deployed and time_to_deploy from the run's deployment summary; from its latch events
    for a Result without one (another runtime)."""
    deployment = getattr(result, "deployment", None)
    if deployment is not None:
        if deployment.deployed is None:  # no latch
            return {}
        time = deployment.time if deployment.time is not None else math.nan
        return {"deployed": float(deployment.deployed), "time_to_deploy": float(time)}
    latches = latch_events(module, getattr(result, "parameters", None))
    if not latches:
        return {}
    deployed = all(name in first for name in latches)
    return {"deployed": float(deployed),
            "time_to_deploy": max(first[n][0] for n in latches) if deployed else math.nan}


def _dissipated(result) -> dict[str, float]:
    """Energy dissipated by the end of the run, by kind: the dissipators' prefixes
    (friction.<h>, damping.<h>, latch.<h>, input.<u>) and the impacts."""
    names = tuple(getattr(result, "dissipator_names", ()) or ())
    dissipated = getattr(result, "dissipated", None)
    out: dict[str, float] = {}
    if names and dissipated is not None and len(dissipated):
        for name, value in zip(names, np.asarray(dissipated, dtype=float)[-1]):
            kind = f"dissipated.{name.split('.', 1)[0]}"
            out[kind] = out.get(kind, 0.0) + float(value)
    deployment = getattr(result, "deployment", None)
    if deployment is not None:
        out["dissipated.impact"] = float(deployment.impact_energy)
    return out


def static_metric_names(module, metrics: Mapping[str, Metric] | None, builtin: bool) -> list[str]:
    """Metric names known before any run (event names are only known from the runs)."""
    names = []
    if builtin:
        if latch_events(module):
            names += ["deployed", "time_to_deploy"]
        names += [f"final.{o}" for o in getattr(module, "OUTPUTS", ())]
    names += [n for n in (metrics or {}) if n not in names]
    return names


# --- units and descriptions -------------------------------------------------------------------

PEAK_FIELDS = ("force", "t_force", "torque", "t_torque")  # runtime.loads.PeakLoad
_PEAKS = {"force": ("N", "peak hinge force"), "t_force": ("s", "time of the peak hinge force"),
          "torque": ("N*m", "peak lock torque"), "t_torque": ("s", "time of the peak lock torque")}
# the numbers the integrator core records with a hinge's events (docs/deployment.md, 1)
_EVENT_DATA = {"t": ("s", "time"), "rate": ("rad/s", "rate just before"),
               "impulse": ("N*m*s", "angular impulse"),
               "impact_energy_loss": ("J", "energy lost in the impact"),
               "angle": ("rad", "angle"), "torque": ("N*m", "holding torque"),
               "position": ("m", "position"), "force": ("N", "holding force"),
               "direction": ("1", "direction"), "rigid": ("1", "rigid (1) or compliant (0)")}
# a slider's (its entry among the hinges moves along its axis: docs/language.md, slider)
_SLIDER_EVENT_DATA = {**_EVENT_DATA, "rate": ("m/s", "rate just before"),
                      "impulse": ("N*s", "impulse")}
_HINGE_EVENTS = ("latch", "latch.contact", "latch.separation", "stop", "stick", "slip")
_DISSIPATED = {"friction": "hinge friction", "damping": "dampers", "latch": "latch dampers",
               "input": "inputs (negative: work done)", "impact": "impacts (latches, stops)"}
_STATS = {"min_step": "s", "max_step": "s", "implicit_from": "s", "stiff_rate": "1/s",
          "max_v_pos": "", "max_v_vel": "", "max_v_acc": ""}  # residuals mix m and rad


def metric_attributes(name: str, module, metrics: Mapping[str, Metric] | None = None) -> dict:
    """The unit (`units`, SI text; "1" for a pure number, absent when unknown) and a
    `long_name` of metric `name` of a study of `module`."""
    unit, text = _describe(name, module, metrics or {})
    return {"units": unit, "long_name": text} if unit else {"long_name": text}


def _describe(name: str, module, metrics: Mapping[str, Metric]) -> tuple[str, str]:
    if name in metrics:
        return str(getattr(metrics[name], "units", "") or ""), name
    if name == "deployed":
        return "1", "deployed (1) or not (0) by t_end"
    if name == "time_to_deploy":
        return "s", "time to full deployment (the last latch)"
    group, _, rest = name.partition(".")
    if group == "event":
        event, _, key = rest.rpartition(".")
        hinge, _, kind = event.partition(".")
        table = _SLIDER_EVENT_DATA if hinge in getattr(module, "SLIDERS", ()) else _EVENT_DATA
        unit, text = table.get(key, ("", key))
        mechanism = hinge in getattr(module, "HINGES", ()) and kind in _HINGE_EVENTS
        return (unit if mechanism or key == "t" else ""), f"{event}: {text}"
    if group == "peak":
        hinge, _, field = rest.rpartition(".")
        unit, text = _PEAKS.get(field, ("", field))
        if hinge in getattr(module, "SLIDERS", ()) and field in ("force", "t_force"):
            text = text.replace("hinge force", "lock force along the axis")
        return unit, f"{text} at {hinge}"
    if group == "dissipated":
        return "J", f"energy dissipated by {_DISSIPATED.get(rest, rest)}"
    if group == "final":
        outputs = tuple(getattr(module, "OUTPUTS", ()))
        units = tuple(getattr(module, "OUTPUT_UNITS", ()))
        unit = units[outputs.index(rest)] if rest in outputs and len(units) == len(outputs) \
            else ""
        return unit, f"{rest} at the end of the run"
    if group == "stats":
        return _STATS.get(rest, "1"), f"run statistic {rest}"
    return "", name


def known_metric(name: str, module) -> bool:
    """Whether `name` is a built-in metric a study of `module` may have (events and run
    statistics: any name of their form; they are only known once runs are done)."""
    group, _, rest = name.partition(".")
    if name in ("deployed", "time_to_deploy"):
        return True
    if group in ("event", "stats", "dissipated"):
        return bool(rest)
    if group == "peak":
        hinge, _, field = rest.rpartition(".")
        return hinge in getattr(module, "HINGES", ()) and field in PEAK_FIELDS
    return group == "final" and rest in getattr(module, "OUTPUTS", ())


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
