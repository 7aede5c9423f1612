"""`depsim.fit`: calibrate a model to a ground test (docs/calibration.md). The facade's part:
the free parameters, their bounds and the noise with units, the measured files read and
checked against the model; the numbers are depsim.runtime.fit's.

    fit = depsim.fit(sim, data="test.csv", free=["h1.friction=0.3:1.2 N*m", "h2.preload"],
                     latch_times="latches.csv")
    print(fit.report()); fit.to_json("fit.json"); fit.plot("fit.png")
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping, Sequence

import numpy as np

from depsim.errors import DataError, UsageError

EVENT_SIGMA = "latch-times"  # the --sigma name of the event times' noise
_NUMBER_AND_UNIT = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*)$")


def fit(sim, data: str | os.PathLike | None = None, free: Sequence[str] | Mapping = (), *,
        latch_times: str | os.PathLike | None = None, set: Mapping | None = None,
        sigma: Mapping[str, float | str] | None = None, tol: float | None = None,
        t_end: float | None = None):
    """Fit the `free` parameters of the compiled model `sim` to a ground test, by weighted
    least squares with the Jacobian from the forward sensitivities; returns a
    depsim.runtime.fit_result.FitResult.

    data: a CSV of time histories (header `t, theta1 [deg], ...`); latch_times: a CSV of rows
    `event,t[,sigma]`; at least one of them. free: names, "NAME=LOW:HIGH" with an optional
    unit ("h1.friction=0.3:1.2 N*m"), or {name: None | (low, high) | "LOW:HIGH unit"}; each
    starts at the model's value with `set` applied. sigma: each column's noise and the event
    times' ("latch-times"), SI or text with a unit; the noise of a kind not given is
    estimated from the residuals at the optimum. tol, t_end: the runs' (default: the
    model's). Raises DataError (a file, with its line), UsageError (an option), FitError (a
    run failed; depsim.runtime.fit)."""
    from depsim.api import _range_check
    from depsim.measurements import dimension, model_events, read_event_times, \
        read_histories
    from depsim.runtime import fit as engine

    if data is None and latch_times is None:
        raise UsageError("fit: give the measured data (--data FILE, --latch-times FILE or "
                         "both)")
    base = sim.parameters(set)
    free = free_parameters(sim, base, free)
    settings = sim.model.ir.simulation
    t_end = float(t_end) if t_end is not None else settings.t_end
    outputs = dict(zip(sim.module.OUTPUTS, sim.module.OUTPUT_UNITS))
    measured = {}
    if data is not None:
        columns, times, values, _ = read_histories(data, outputs, t_end)
        measured.update(columns=columns, units=tuple(outputs[c] for c in columns),
                        times=times, values=values)
    if latch_times is not None:
        events, event_times, event_sigmas, event_lines = read_event_times(
            latch_times, model_events(sim.model.ir), t_end)
        measured.update(events=events, event_times=event_times, event_sigmas=event_sigmas)
    noise = _sigmas(sigma or {}, measured, outputs, dimension)
    measured.update(sigmas=np.array([noise.get(c, math.nan)
                                     for c in measured.get("columns", ())]))
    if "events" in measured and EVENT_SIGMA in noise:
        given = measured["event_sigmas"]
        measured["event_sigmas"] = np.where(np.isnan(given), noise[EVENT_SIGMA], given)
    measurements = engine.Measurements(
        sources=tuple(str(p) for p in (data, latch_times) if p is not None), **measured)
    dt_out = engine.output_interval(measurements.times, t_end, settings.dt_out)
    try:
        return engine.fit(sim.tangent_module(), base, free, measurements,
                          settings=engine.Settings(t_end, dt_out, tol),
                          check=_range_check(sim.model.ir, [f.name for f in free]),
                          model=sim.model.name)
    except engine.MissingEventError as exc:
        raise DataError(latch_times, int(event_lines[exc.index]), str(exc)) from None
    except engine.NoiseError as exc:
        raise UsageError(f"fit: {exc} (--sigma NAME=VALUE)") from None


def free_parameters(sim, base: np.ndarray, free) -> list:
    """The free parameters (depsim.runtime.fit.FreeParameter) of `free` (see `fit`), each
    starting at its value in `base`, checked: a parameter of the model, given once, LOW <
    HIGH in its unit, its start within them."""
    from depsim.api import _parameter_value
    from depsim.runtime.fit import FreeParameter

    items = free.items() if isinstance(free, Mapping) else [_split_free(i) for i in free]
    params = {p.name: p for p in sim.model.ir.params}
    found = []
    for name, bounds in items:
        if name in (f.name for f in found):
            raise UsageError(f"--free {name} is given twice: free each parameter once")
        if name not in params:
            sim.parameters({name: 0.0})  # raises the UsageError that names the mistake
        index = sim.parameter_names.index(name)
        param = params[name]
        low, high = _bounds(name, bounds, lambda text: _parameter_value(param, text))
        start = float(base[index])
        unit = param.unit or ""
        if not low < high:
            raise UsageError(f"--free {name}: the lower bound {low:g} is not below the upper "
                             f"bound {high:g} ({unit or 'SI'})")
        if not low <= start <= high:
            raise UsageError(f"--free {name}: its start value {start:g} {unit} lies outside "
                             f"its bounds {low:g}:{high:g}; move the bounds or start "
                             f"elsewhere (--set {name}=VALUE)")
        found.append(FreeParameter(name, index, start, low, high, unit))
    if not found:
        raise UsageError("fit: free at least one parameter (--free NAME[=LOW:HIGH])")
    return found


def _split_free(item: str) -> tuple[str, str | None]:
    name, sep, bounds = (part.strip() for part in str(item).partition("="))
    if not name or (sep and not bounds):
        raise UsageError(f"--free '{item}': expected NAME or NAME=LOW:HIGH, e.g. --free "
                         "'h1.friction=0.3:1.2 N*m'")
    return name, bounds if sep else None


def _bounds(name: str, bounds, value) -> tuple[float, float]:
    """(low, high) SI of a parameter's bounds: None (none), a pair, or "LOW:HIGH unit" (the
    unit after HIGH holds for LOW too, unless LOW has its own)."""
    if bounds is None:
        return -math.inf, math.inf
    if not isinstance(bounds, str):
        low, high = bounds
        return float(value(low)), float(value(high))
    low, sep, high = (part.strip() for part in bounds.partition(":"))
    if not sep or not low or not high or ":" in high:
        raise UsageError(f"--free {name}={bounds}: expected LOW:HIGH, e.g. 0.3:1.2 N*m")
    low_match, high_match = _NUMBER_AND_UNIT.match(low), _NUMBER_AND_UNIT.match(high)
    if low_match and high_match and not low_match.group(2) and high_match.group(2):
        low = f"{low} {high_match.group(2)}"
    try:
        return value(low), value(high)
    except UsageError as exc:
        raise UsageError(f"--free {name}={bounds}: {exc}") from None


def _sigmas(given: Mapping, measured: dict, outputs: dict, dimension) -> dict[str, float]:
    """{column or "latch-times": SI noise} of `given`, each a measured column (in its
    output's unit) or the event times (s), positive."""
    from depsim.measurements import TIME, unit_scale

    found = {}
    for name, text in given.items():
        if name == EVENT_SIGMA:
            if "events" not in measured:
                raise UsageError(f"--sigma {name}: no --latch-times measured")
            wanted = TIME
        elif name in measured.get("columns", ()):
            wanted = dimension(outputs[name])
        else:
            columns = ", ".join((*measured.get("columns", ()), EVENT_SIGMA))
            raise UsageError(f"--sigma {name}: not a measured column (measured: {columns})")
        found[name] = _quantity(name, text, wanted, unit_scale)
    return found


def _quantity(name: str, text, wanted, unit_scale) -> float:
    if isinstance(text, str):
        match = _NUMBER_AND_UNIT.match(text)
        try:
            if match is None:
                raise ValueError(f"'{text}' is not a number with an optional unit")
            value = float(match.group(1)) * unit_scale(match.group(2), wanted)
        except ValueError as exc:
            raise UsageError(f"--sigma {name}={text}: {exc}") from None
    else:
        value = float(text)
    if not (math.isfinite(value) and value > 0):
        raise UsageError(f"--sigma {name}={text}: the noise must be a positive number")
    return value
