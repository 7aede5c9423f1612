"""Reading what a ground test measured (`depsim fit`, docs/calibration.md): time histories of
model outputs and event times from CSV files, with units, checked against the model.

Time histories: a header `t, OUTPUT, ...` (each name may carry a unit in brackets,
`theta1 [deg]`, `t [s]`; without one, SI), then one row of numbers per sample, times
non-decreasing within the run [0, t_end]. Event times: rows `event,t[,sigma]` (s, or the
header's units), the event a record name of the model (`h1.latch`). Both skip blank lines
and `#` comments. Every problem is a DataError naming the file and line.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from depsim.dsl import ir, parse_quantity
from depsim.errors import DataError
from depsim.runtime.tables import content_lines, parse_number

_HEADER_FIELD = re.compile(r"^([A-Za-z_][A-Za-z0-9_.]*)\s*(?:\[([^\]]*)\])?$")
TIME = ir.Dim(time=1)


def read_histories(path, outputs: dict[str, str], t_end: float):
    """The time histories in `path`: (columns, times (n,) s, values (n, m) SI, line numbers
    (n,)). `outputs`: the model's outputs and their SI units; t_end: the run's end (s)."""
    lines = _lines(path)
    if not lines:
        raise DataError(path, 1, "the file is empty: expected a header 't, OUTPUT, ...' "
                                 "(units in brackets: 'theta1 [deg]') and rows of numbers")
    number, header = lines[0]
    names, scales = _header(path, number, header, outputs)
    width = len(names)
    rows = np.empty((len(lines) - 1, width))
    for k, (number, content) in enumerate(lines[1:]):
        fields = [f.strip() for f in content.split(",")]
        if len(fields) != width:
            raise DataError(path, number, f"{len(fields)} values, the header names {width} "
                                          f"columns ({', '.join(names)})")
        for j, text in enumerate(fields):
            rows[k, j] = _value(path, number, text, names[j]) * scales[j]
    if not len(rows):
        raise DataError(path, number, "no rows of numbers after the header")
    line_numbers = np.array([n for n, _ in lines[1:]])
    _check_times(path, rows[:, 0], line_numbers, t_end)
    return tuple(names[1:]), rows[:, 0], rows[:, 1:], line_numbers


def read_event_times(path, events: set[str], t_end: float):
    """The event times in `path`: (names, times (e,) s, sigmas (e,) s with NaN where none is
    given, line numbers (e,)). `events`: the record names the model can make."""
    lines = _lines(path)
    if not lines:
        raise DataError(path, 1, "the file is empty: expected rows 'event,t[,sigma]' "
                                 "(e.g. h1.latch,50.6)")
    scales = [1.0, 1.0]
    first = [f.strip() for f in lines[0][1].split(",")]
    if len(first) > 1 and parse_number(first[1]) is None:  # a header naming the columns
        scales = _event_header(path, lines[0][0], first)
        lines = lines[1:]
    names, times, sigmas, numbers = [], [], [], []
    for number, content in lines:
        fields = [f.strip() for f in content.split(",")]
        if len(fields) not in (2, 3):
            raise DataError(path, number, f"expected 'event,t[,sigma]', got '{content}'")
        if fields[0] not in events:
            known = ", ".join(sorted(events)) or "none"
            raise DataError(path, number, f"'{fields[0]}' is not an event of this model "
                                          f"(its events: {known})")
        names.append(fields[0])
        times.append(_value(path, number, fields[1], "t") * scales[0])
        sigma = _value(path, number, fields[2], "sigma") * scales[1] \
            if len(fields) == 3 else math.nan
        if not sigma > 0 and len(fields) == 3:
            raise DataError(path, number, f"sigma {fields[2]} must be positive")
        sigmas.append(sigma)
        numbers.append(number)
    if not names:
        raise DataError(path, lines[0][0] if lines else 1, "no rows 'event,t[,sigma]'")
    times, numbers = np.array(times), np.array(numbers)
    outside = np.flatnonzero((times < 0) | (times > t_end))
    if len(outside):
        k = outside[0]
        raise DataError(path, numbers[k], f"time {times[k]:g} s is outside the run, 0 to "
                                          f"{t_end:g} s (--t-end sets its end)")
    return tuple(names), times, np.array(sigmas), numbers


def model_events(model: ir.Model) -> set[str]:
    """The event record names whose times a run of `model` can report with sensitivities:
    `<joint>.latch`, `<joint>.stop`, `<joint>.release` of the hinges and sliders that have a
    latch, a stop or a hold-down (docs/deployment.md, 1)."""
    found = set()
    for joint in (*model.hinges, *model.sliders):
        if getattr(joint, "latch", None) is not None:
            found.add(f"{joint.name}.latch")
        if getattr(joint, "stop_min", None) is not None or \
                getattr(joint, "stop_max", None) is not None:
            found.add(f"{joint.name}.stop")
        if getattr(joint, "release", None) is not None:
            found.add(f"{joint.name}.release")
    return found


def unit_scale(text: str, wanted: ir.Dim) -> float:
    """The SI value of one `text` (a unit: "deg", "ms"; "": SI, "1": a plain number),
    ValueError unless its dimension is `wanted`."""
    if not text.strip():
        return 1.0
    if text.strip() == "1":
        scale, dim = 1.0, ir.Dim()
    else:
        scale, dim = parse_quantity(f"1 {text}")
    if dim != wanted:
        raise ValueError(f"'{text}' is not a unit of {_describe(wanted)}")
    return scale


def dimension(unit: str) -> ir.Dim:
    """The dimension of an SI unit as the model's outputs name it ("rad", "N*m", "1")."""
    return ir.Dim() if unit.strip() in ("", "1") else parse_quantity(f"1 {unit}")[1]


def _describe(dim: ir.Dim) -> str:
    from depsim.dsl.units import describe

    return describe(dim)


def _lines(path) -> list[tuple[int, str]]:

    try:
        return content_lines(path)
    except ValueError as exc:  # a missing, unreadable or oversized file
        raise DataError(path, 1, str(exc).split(": ", 1)[-1]) from None


def _header(path, number: int, header: str, outputs: dict[str, str]):
    """The names of the header's columns and each one's scale to SI."""
    names, scales = [], []
    for text in (f.strip() for f in header.split(",")):
        match = _HEADER_FIELD.match(text)
        if match is None:
            raise DataError(path, number, f"'{text}' is not a column name with an optional "
                                          "[unit] (e.g. 'theta1 [deg]')")
        name, unit = match.group(1), match.group(2) or ""
        first = not names
        if first and name != "t":
            raise DataError(path, number, f"the first column is the time 't' (s), not "
                                          f"'{name}'")
        if not first and name not in outputs:
            raise DataError(path, number, f"'{name}' is not an output of the model (its "
                                          f"outputs: {', '.join(outputs)})")
        if name in names:
            raise DataError(path, number, f"column '{name}' is given twice")
        wanted = TIME if first else dimension(outputs[name])
        try:
            scales.append(unit_scale(unit, wanted))
        except ValueError as exc:
            what = "the time" if first else f"output {name} (in {outputs[name]})"
            raise DataError(path, number, f"column '{name}': {exc}, which {what} needs") \
                from None
        names.append(name)
    if len(names) < 2:
        raise DataError(path, number, "no output column after 't': name the measured "
                                      f"outputs (the model's: {', '.join(outputs)})")
    return names, scales


def _event_header(path, number: int, fields: list[str]) -> list[float]:
    """The scales to SI of the time and sigma columns a header 'event, t [s], sigma [s]'
    names."""
    expected = ["event", "t", "sigma"][:len(fields)]
    scales = []
    for k, text in enumerate(fields):
        match = _HEADER_FIELD.match(text)
        if match is None or match.group(1) != expected[k] or len(fields) > 3:
            raise DataError(path, number, f"a header names the columns 'event, t, sigma' "
                                          f"(units in brackets); got '{', '.join(fields)}'")
        if k:
            try:
                scales.append(unit_scale(match.group(2) or "", TIME))
            except ValueError as exc:
                raise DataError(path, number, f"column '{expected[k]}': {exc}, a time") \
                    from None
    return scales + [1.0] * (2 - len(scales))


def _value(path, number: int, text: str, column: str) -> float:
    value = parse_number(text)
    if value is None:
        raise DataError(path, number, f"'{text}' in column '{column}' is not a number")
    if not math.isfinite(value):
        raise DataError(path, number, f"'{text}' in column '{column}': every value must be a "
                                      "finite number")
    return value


def _check_times(path, times: np.ndarray, numbers: np.ndarray, t_end: float) -> None:
    back = np.flatnonzero(np.diff(times) < 0)
    if len(back):
        k = back[0] + 1
        raise DataError(path, numbers[k], f"time {times[k]:g} s is before the line above "
                                          f"({times[k - 1]:g} s): times must not decrease")
    outside = np.flatnonzero((times < 0) | (times > t_end * (1 + 1e-12)))
    if len(outside):
        k = outside[0]
        raise DataError(path, numbers[k], f"time {times[k]:g} s is outside the run, 0 to "
                                          f"{t_end:g} s (--t-end sets its end)")
