"""`simulate`: run a model through the integrator core and return its `Result`.

    from depsim.runtime import simulate
    result = simulate(module)                     # a generated NumPy module or a CModule
    result = simulate(module, p, t_end=5.0, events=[...])

The core (runtime/c, docs/method.md) does everything of the method: steps, passes,
multipliers, step control, events, latches, stops, stick-slip, impacts, loads, recording and
the deployment summary. This module only converts: settings and Python `Event`s in, the
`dep_result` out, C errors to Python exceptions (`SolverError` with its parts, `ValueError`
for bad settings, an exception raised by an event function, callback or NumPy model function
re-raised as it was).
"""

from __future__ import annotations

import numpy as np

from .binding import bind
from .constraints import ConstraintSet, HingeLock, LinearConstraint
from .core import core, ffi
from .errors import SolverError
from .events import EventHit, EventResponse
from .progress import Progress
from .reading import doubles, read_end, read_result, text
from .results import Result, RunEnd


def simulate(module, params: np.ndarray | None = None, t_end: float | None = None,
             dt_out: float | None = None, tol: float | None = None, events=(),
             progress: bool = False, mechanics: bool = True,
             max_steps: float | None = None, inputs=None, stepping: str = "auto",
             sensitivities=()) -> Result:
    """Integrate a model with the iterative multiplier method (docs/method.md).

    module: a generated NumPy module (docs/generated-module.md) or a compiled C model
    (`depsim.runtime.binding.load_folder`); params (NP,) SI, default PARAMETER_DEFAULTS;
    t_end, dt_out (s) and tol default to the module's T_END, DT_OUT, TOL; events: `Event`s;
    progress: draw a bar on stderr (only when it is a terminal); mechanics: apply the hinges'
    latches, stops and stick-slip friction (docs/deployment.md); False integrates without;
    max_steps: the most steps, the rejected and retried ones counted (default 1e6); a stiff
    run that would need more stops as soon as the stiffness shows (docs/method.md, 6);
    inputs: {input name: time table}, a table being rows (t, u) in s and SI, u linear in
    between (a repeated t is a jump) and held beyond the ends, or one number (a constant); an
    input not given keeps its parameters (docs/language.md, Inputs); stepping: the ODE method
    under the multiplier iteration, "auto" (DOPRI 5(4), and for a model with beams the
    linearly implicit step once a stiff mode holds DOPRI's step at its stability bound),
    "explicit" or "implicit" (docs/method.md, 10); sensitivities: names of parameters whose
    forward sensitivities the core follows along the run (Result.sensitivities; the module
    needs its tangent functions, docs/calibration.md).
    Raises SolverError when the integration cannot go on, ValueError for bad settings.
    """
    binding = bind(module)
    model = binding.module
    p = resolve_parameters(model, params)
    view = ffi()
    settings = _settings(model, t_end, dt_out, tol, mechanics, max_steps, stepping)
    tables = input_tables(model, inputs)
    table_array = view.new("dep_input_table[]", max(len(tables), 1))
    for entry, (index, times, values) in zip(table_array, tables):
        entry.input, entry.n = index, len(times)
        entry.t = view.from_buffer("double[]", times)
        entry.u = view.from_buffer("double[]", values)
    settings.tables, settings.n_tables = table_array, len(tables)
    followed = view.new("int[]", sensitivity_indices(model, sensitivities, binding.tangents)
                        or [0])
    settings.sensitivities, settings.n_sensitivities = followed, len(sensitivities)
    bridge = EventBridge(model, p, events)
    bar = Progress(settings.t_end, progress)

    def report(_context, t):
        bar.update(t)
        return int(bridge.exception is not None or binding.failure is not None)

    # A Python exception in a callback (Ctrl-C during a long C run arrives at the first one
    # called) stops the run: recorded, the callback answers "stop", simulate raises it.
    settings.progress = progress_callback = view.callback(
        "int(*)(void *, double)", report, error=1, onerror=bridge.record)
    result, error = view.new("dep_result *"), view.new("dep_error *")
    try:
        _run_core(binding, p, settings, bridge, result, error)
        try:
            return read_result(model, result)
        finally:
            core().dep_result_free(result)
    finally:
        bar.close()
        del progress_callback


def _settings(model, t_end, dt_out, tol, mechanics=True, max_steps=None, stepping="auto"):
    """A run's dep_settings (SI; None: the model's own), without inputs or progress."""
    return ffi().new("dep_settings *", {
        "t_end": _setting(t_end, model.T_END), "dt_out": _setting(dt_out, model.DT_OUT),
        "tol": _setting(tol, model.TOL), "mechanics": int(bool(mechanics)),
        "max_steps": _setting(max_steps, 0.0), "stepping": _stepping(stepping)})


def _run_core(binding, p: np.ndarray, settings, bridge: EventBridge, result, error) -> None:
    """One dep_simulate into `result`, which the caller reads and frees. Raises what stopped
    the run: an exception of an event's function or callback or of a NumPy model's function
    (or Ctrl-C in a callback) as it was raised, else the C error's; `result` then holds
    nothing."""
    library = core()
    with binding.running():
        status = library.dep_simulate(binding.pointer, ffi().from_buffer("double[]", p),
                                      settings, bridge.array, len(bridge.events), result, error)
        failure = bridge.exception or binding.failure
    if failure is not None:
        if status == library.DEP_OK:
            library.dep_result_free(result)
        raise failure
    if status != library.DEP_OK:
        raise _exception(error)


class RunEnds:
    """Runs of one model with the same settings, each read at its end alone (a `RunEnd`): a
    parameter study's runs when nothing but its built-in metrics reads them. Each run is the
    dep_simulate call that `simulate(module, p, t_end=..., dt_out=..., tol=...)` makes, so it
    takes the same steps and gives the same numbers; the settings, the check that stops a
    run (a NumPy model's function raised, Ctrl-C) and the result's structs are made once, and
    no output row is read. One thread at a time."""

    def __init__(self, module, t_end: float | None = None, dt_out: float | None = None,
                 tol: float | None = None):
        self.binding = binding = bind(module)
        self.model = binding.module
        self.bridge = bridge = EventBridge(self.model, resolve_parameters(self.model, None), ())
        self.settings = _settings(self.model, t_end, dt_out, tol)

        def check(_context, _t):
            return int(bridge.exception is not None or binding.failure is not None)

        self.settings.progress = self._check = ffi().callback(
            "int(*)(void *, double)", check, error=1, onerror=bridge.record)
        self._result, self._error = ffi().new("dep_result *"), ffi().new("dep_error *")

    def run(self, params: np.ndarray | None = None) -> RunEnd:
        """One run with parameters `params` (NP,) SI (None: the defaults): its `RunEnd`.
        Raises as `simulate` does."""
        p = resolve_parameters(self.model, params)
        self.bridge.exception = None
        _run_core(self.binding, p, self.settings, self.bridge, self._result, self._error)
        try:
            return read_end(self.model, self._result)
        finally:
            core().dep_result_free(self._result)


def sensitivity_indices(module, names, tangents: bool) -> list[int]:
    """The parameter indices of `names`; ValueError for a name that is not a parameter, a
    repeated one, or a module without tangent functions."""
    names = list(names)
    if not names:
        return []
    if not tangents:
        raise ValueError(f"model '{module.MODEL_NAME}' was compiled without its tangent "
                         "functions, which sensitivities need: compile it with "
                         "tangents=True")
    known = tuple(module.PARAMETERS)
    for name in names:
        if name not in known:
            raise ValueError(f"sensitivity to '{name}': not a parameter of the model "
                             f"(parameters: {', '.join(known)})")
    if len(set(names)) != len(names):
        raise ValueError("sensitivities: each parameter once")
    return [known.index(name) for name in names]


STEPPINGS = ("auto", "explicit", "implicit")  # dep_settings.stepping, in its enum's order


def _stepping(name: str) -> int:
    if name not in STEPPINGS:
        raise ValueError(f"stepping must be one of {', '.join(STEPPINGS)}, got {name!r}")
    return STEPPINGS.index(name)


def input_tables(module, inputs) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """(input index, times, values) of each table in `inputs`; ValueError for an unknown
    input or a table that is not rows of (t, u). The core checks the numbers."""
    names = tuple(module.INPUTS)
    tables = []
    for name, table in (inputs or {}).items():
        if name not in names:
            known = ", ".join(names) if names else "none: the model has no `input` statement"
            raise ValueError(f"unknown input '{name}'; the model's inputs: {known}")
        rows = np.array([[0.0, table]] if np.ndim(table) == 0 else table, dtype=float)
        if rows.ndim != 2 or rows.shape[1] != 2 or rows.shape[0] < 1:
            raise ValueError(f"the time table of input '{name}' must be rows of (t, value), "
                             f"got an array of shape {rows.shape}")
        tables.append((names.index(name), np.ascontiguousarray(rows[:, 0]),
                       np.ascontiguousarray(rows[:, 1])))
    return tables


def _setting(value, default) -> float:
    return float(default if value is None else value)


def resolve_parameters(module, params) -> np.ndarray:
    """The parameter vector (NP,) as a fresh float array; ValueError for a wrong shape."""
    p = np.array(module.PARAMETER_DEFAULTS if params is None else params, dtype=float)
    if p.shape != (module.NP,):
        raise ValueError(f"params must have shape ({module.NP},) for model "
                         f"'{module.MODEL_NAME}' ({', '.join(module.PARAMETERS)}); "
                         f"got shape {p.shape}")
    return np.ascontiguousarray(p)


def _exception(error) -> Exception:
    """The Python exception of a failed C run."""
    library = core()
    if error.code == library.DEP_SOLVER_ERROR:
        return SolverError(text(error.what), t=error.t if error.has_t else None,
                           stage=text(error.stage) or None, row=text(error.row) or None,
                           joint=text(error.joint) or None,
                           residual=error.residual if error.has_residual else None,
                           hint=text(error.hint) or None)
    if error.code == library.DEP_SETTINGS_ERROR:
        return ValueError(text(error.message))
    if error.code == library.DEP_MEMORY_ERROR:
        return MemoryError(text(error.message))
    return RuntimeError(text(error.message))


# ---- Python events -------------------------------------------------------------------------------

class EventBridge:
    """Python `Event`s as C `dep_event`s. A callback sees an `EventHit` whose `constraints` is a
    `ConstraintSet` of the rows active in C (the model's, then the added `HingeLock` and
    `LinearConstraint` rows); its `EventResponse` may add and remove such rows, replace the
    state, ask for an impact and attach numbers. `records` are the mechanism's own."""

    def __init__(self, module, p: np.ndarray, events):
        view = ffi()
        self.module, self.p, self.events = module, p, tuple(events)
        names = [e.name for e in self.events]
        if len(set(names)) != len(names):
            raise ValueError("event names must be distinct")
        self.exception: BaseException | None = None
        self.keep: list = []  # what the C side reads until the next callback
        self.array = view.new("dep_event[]", max(1, len(self.events)))
        self.callbacks = []
        for k, event in enumerate(self.events):
            name = view.new("char[]", event.name.encode("utf-8"))
            function = view.callback("int(*)(void *, double, const double *, const double *, "
                                     "const dep_active_rows *, double *)",
                                     self._function(event), error=1, onerror=self.record)
            callback = view.callback("int(*)(void *, const dep_event_hit *, "
                                     "dep_event_response *)", self._callback(event), error=1,
                                     onerror=self.record)
            self.callbacks += [name, function, callback]
            c = self.array[k]
            c.name, c.function, c.callback = name, function, callback
            c.direction = int(event.direction)
            c.terminal = int(bool(event.terminal))
            c.max_hits = -1 if event.max_hits is None else int(event.max_hits)
            c.multipliers = int(bool(event.multipliers))

    def record(self, _kind, exc: BaseException, _trace) -> None:
        """cffi's onerror: an exception that escaped a callback (re-raised by simulate)."""
        if self.exception is None:
            self.exception = exc

    def _guard(self, work) -> int:
        if self.exception is not None:
            return 1
        try:
            work()
            return 0
        except BaseException as exc:  # re-raised by simulate()
            self.exception = exc
            return 1

    def _vector(self, pointer) -> np.ndarray:
        return doubles(pointer, self.module.NQ)

    def _function(self, event):
        def function(_context, t, q, qd, rows, out):
            def work():
                q_arr, qd_arr = self._vector(q), self._vector(qd)
                if event.multipliers:
                    r = rows[0]
                    lam = {text(r.names[i]): float(r.lam[i]) for i in range(r.nc)}
                    out[0] = float(event.function(t, q_arr, qd_arr, lam))
                else:
                    out[0] = float(event.function(t, q_arr, qd_arr))
            return self._guard(work)

        return function

    def _callback(self, event):
        def callback(_context, hit, response):
            return self._guard(lambda: self._respond(event, hit[0], response[0]))

        return callback

    def _constraints(self, hit) -> ConstraintSet:
        """The active rows as a ConstraintSet."""
        library, rows = core(), []
        for i in range(hit.n_added):
            r = hit.added[i]
            name, joint = text(r.name), text(r.joint)
            if r.kind == library.DEP_ROW_HINGE_LOCK:
                rows.append(HingeLock(self.module, self.module.HINGES[r.hinge], float(r.angle),
                                      name=name, joint=joint))
            else:
                rows.append(LinearConstraint(name, joint, self._vector(r.row), float(r.value)))
        return ConstraintSet(self.module, self.p, rows)

    def _respond(self, event, hit, out) -> None:
        info = EventHit(event.name, hit.t, self._vector(hit.q), self._vector(hit.qd),
                        doubles(hit.lam, hit.nc), self._constraints(hit), self.module,
                        self.p.copy())
        response = (event.callback(info) if event.callback else None) or EventResponse()
        if response.records is not None:
            raise TypeError(f"event '{event.name}': `records` belong to the integrator's own "
                            "latches, stops and stick-slip mechanism")
        self._fill(response, out)

    def _fill(self, response: EventResponse, out) -> None:
        view, library = ffi(), core()
        self.keep = []
        out.stop = -1 if response.stop is None else int(bool(response.stop))
        for name in ("q", "qd"):
            value = getattr(response, name)
            if value is not None:
                array = np.ascontiguousarray(value, dtype=float).ravel()
                if array.size != self.module.NQ:
                    raise ValueError(f"EventResponse.{name} needs {self.module.NQ} values, "
                                     f"got {array.size}")
                self.keep.append(array)
                setattr(out, name, view.from_buffer("double[]", array))
        limit = library.DEP_MAX_ADDED
        if len(response.add) > limit or len(response.remove) > limit:
            raise ValueError(f"an event may add or remove at most {limit} rows")
        for i, row in enumerate(response.add):
            self._row(row, out.add[i])
        out.n_add = len(response.add)
        for i, name in enumerate(response.remove):
            out.remove[i] = _bounded(name)
        out.n_remove = len(response.remove)
        out.impact = int(bool(response.impact))
        data = list(response.data.items())[:library.DEP_MAX_DATA]
        for i, (key, value) in enumerate(data):
            out.data_names[i] = _bounded(str(key))
            out.data_values[i] = float(value)
        out.n_data = len(data)

    def _row(self, row, c) -> None:
        view, library = ffi(), core()
        c.name, c.joint = _bounded(row.name), _bounded(row.joint)
        if isinstance(row, HingeLock):
            c.kind = library.DEP_ROW_HINGE_LOCK
            c.hinge = self.module.HINGES.index(row.hinge)
            c.angle = float(row.angle)
        elif isinstance(row, LinearConstraint):
            array = np.ascontiguousarray(row.row, dtype=float).ravel()
            self.keep.append(array)
            c.kind = library.DEP_ROW_LINEAR
            c.hinge = -1
            c.row = view.from_buffer("double[]", array)
            c.value = float(row.value)
        else:
            raise TypeError(f"an event adds HingeLock and LinearConstraint rows, not "
                            f"{type(row).__name__}")


def _bounded(name: str) -> bytes:
    """A name as the C side stores it (DEP_NAME_MAX - 1 bytes at most)."""
    return name.encode("utf-8")[:core().DEP_NAME_MAX - 1]


__all__ = ["simulate", "RunEnds", "resolve_parameters", "EventBridge"]
