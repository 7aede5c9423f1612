"""The C integrator from Python: `simulate(module, ...)` with `depsim.runtime.simulate`'s
signature and `Result`, run by the C library of a C target folder (runtime/c, depsim.h).

    from depsim.codegen.c_emit import compile_c
    from depsim.runtime.ctarget import load_folder
    from depsim.runtime import clib
    module = load_folder(compile_c(model, folder))     # builds once (cached), loads
    result = clib.simulate(module, params, t_end=5.0)  # no recompilation per parameter set

Errors come back as the Python runtime raises them: `SolverError` with the same message and
attributes, `ValueError` for bad settings; an exception raised inside an event function or
callback is re-raised as is. ctypes is the standard library's: no extra dependency."""

from __future__ import annotations

import ctypes
from ctypes import POINTER, Structure, c_char, c_char_p, c_double, c_int, c_longlong, c_void_p

import numpy as np

from .constraints import ConstraintSet, HingeLock, LinearConstraint
from .ctarget import CModel, CModule
from .errors import SolverError
from .events import EventHit, EventResponse
from .loads import PeakLoad
from .results import EventRecord, PassStats, Result, Stats
from .system import System

NAME_MAX, MAX_ADDED, MAX_DATA = 128, 64, 8  # depsim.h
DEP_OK, DEP_SOLVER_ERROR, DEP_SETTINGS_ERROR, DEP_CALLBACK_ERROR = 0, 3, 4, 5
ROW_HINGE_LOCK, ROW_LINEAR = 1, 2
_P = POINTER(c_double)


class Settings(Structure):
    _fields_ = [("t_end", c_double), ("dt_out", c_double), ("tol", c_double),
                ("mechanics", c_int)]


class Error(Structure):
    _fields_ = [("code", c_int), ("has_t", c_int), ("t", c_double), ("stage", c_char * 32),
                ("row", c_char * NAME_MAX), ("joint", c_char * (NAME_MAX + 8)),
                ("has_residual", c_int), ("residual", c_double), ("what", c_char * 512),
                ("hint", c_char * 512), ("message", c_char * 1600)]


class Row(Structure):
    _fields_ = [("kind", c_int), ("name", c_char * NAME_MAX), ("joint", c_char * NAME_MAX),
                ("hinge", c_int), ("angle", c_double), ("row", _P), ("value", c_double)]


class EventHitC(Structure):
    _fields_ = [("name", c_char_p), ("t", c_double), ("q", _P), ("qd", _P), ("lam", _P),
                ("nc", c_int), ("row_names", POINTER(c_char_p)), ("p", _P),
                ("n_added", c_int), ("added", POINTER(Row))]


class ActiveRows(Structure):
    _fields_ = [("nc", c_int), ("names", POINTER(c_char_p)), ("lam", _P)]


class Response(Structure):
    _fields_ = [("stop", c_int), ("q", _P), ("qd", _P), ("n_add", c_int),
                ("add", Row * MAX_ADDED), ("n_remove", c_int),
                ("remove", (c_char * NAME_MAX) * MAX_ADDED), ("impact", c_int),
                ("n_data", c_int), ("data_names", (c_char * NAME_MAX) * MAX_DATA),
                ("data_values", c_double * MAX_DATA)]


EVENT_FUNCTION = ctypes.CFUNCTYPE(c_int, c_void_p, c_double, _P, _P, POINTER(ActiveRows), _P)
EVENT_CALLBACK = ctypes.CFUNCTYPE(c_int, c_void_p, POINTER(EventHitC), POINTER(Response))


class EventC(Structure):
    _fields_ = [("name", c_char_p), ("function", EVENT_FUNCTION), ("direction", c_int),
                ("callback", EVENT_CALLBACK), ("context", c_void_p), ("terminal", c_int),
                ("max_hits", c_int), ("multipliers", c_int)]


class PassStatsC(Structure):
    _fields_ = [("mean", c_double), ("max", c_longlong), ("total", c_longlong)]


class StatsC(Structure):
    _fields_ = ([(name, c_longlong) for name in ("accepted_steps", "rejected_steps",
                                                 "failed_steps", "integrations",
                                                 "rhs_evaluations")]
                + [(name, PassStatsC) for name in ("position", "velocity", "acceleration")]
                + [("cg_iterations", c_longlong), ("factorizations", c_longlong)]
                + [(name, c_double) for name in ("max_v_pos", "max_v_vel", "max_v_acc",
                                                 "min_step", "max_step")]
                + [("events", c_longlong)])


DEP_NUMBER, DEP_TEXT, DEP_BOOL, DEP_NONE = 0, 1, 2, 3


class Datum(Structure):
    _fields_ = [("key", c_char * NAME_MAX), ("member", c_char * NAME_MAX), ("kind", c_int),
                ("number", c_double), ("text", c_char * NAME_MAX)]


class EventRecordC(Structure):
    _fields_ = [("name", c_char * NAME_MAX), ("t", c_double), ("n_data", c_int),
                ("data", POINTER(Datum))]


class PeakC(Structure):
    _fields_ = [("force", c_double), ("t_force", c_double), ("torque", c_double),
                ("t_torque", c_double)]


class ResultC(Structure):
    _fields_ = ([("n", c_int), ("nq", c_int), ("nh", c_int), ("nout", c_int), ("ne", c_int),
                 ("nd", c_int), ("n_rows", c_int), ("row_names", POINTER(c_char_p))]
                + [(name, c_double) for name in ("tol", "constraint_tol", "t_end", "dt_out")]
                + [(name, _P) for name in ("params", "times", "q", "qd", "lam", "hinge_angles",
                                           "hinge_rates", "outputs", "residual_pos",
                                           "residual_vel", "residual_acc", "energy",
                                           "dissipated")]
                + [("energy_names", POINTER(c_char_p)), ("dissipator_names", POINTER(c_char_p)),
                   ("hinge_torque", _P), ("n_latch_hinges", c_int),
                   ("latch_hinges", POINTER(c_int)), ("peaks", POINTER(PeakC)),
                   ("stats", StatsC), ("n_events", c_int), ("events", POINTER(EventRecordC))])


def _bind(library: ctypes.CDLL) -> None:
    """Declare the integrator's entry points of a loaded library (once)."""
    if getattr(library, "_depsim_bound", False):
        return
    library.dep_simulate.argtypes = [POINTER(CModel), _P, POINTER(Settings), POINTER(EventC),
                                     c_int, POINTER(ResultC), POINTER(Error)]
    library.dep_simulate.restype = c_int
    library.dep_result_free.argtypes = [POINTER(ResultC)]
    library.dep_result_free.restype = None
    library._depsim_bound = True


def resolve_parameters(module: CModule, params) -> np.ndarray:
    """The parameter vector (NP,), checked as `system.resolve_settings` checks it."""
    p = np.array(module.PARAMETER_DEFAULTS if params is None else params, dtype=float)
    if p.shape != (module.NP,):
        raise ValueError(f"params must have shape ({module.NP},) for model "
                         f"'{module.MODEL_NAME}' ({', '.join(module.PARAMETERS)}); "
                         f"got shape {p.shape}")
    return p


def simulate(module: CModule, params: np.ndarray | None = None, t_end: float | None = None,
             dt_out: float | None = None, tol: float | None = None, events=(),
             progress: bool = False, mechanics: bool = True) -> Result:
    """`depsim.runtime.simulate` run by the C integrator of `module` (a `CModule` whose
    library holds the integrator: `ctarget.load_folder`). Same arguments, same `Result`, same
    errors. `progress` is accepted and ignored (the C integrator draws no bar)."""
    del progress
    library = module.library
    _bind(library)
    p = resolve_parameters(module, params)
    settings = Settings(*(float(default if value is None else value) for value, default in
                          ((t_end, module.T_END), (dt_out, module.DT_OUT), (tol, module.TOL))),
                        int(bool(mechanics)))
    bridge = EventBridge(module, p, events)
    result, error = ResultC(), Error()
    status = library.dep_simulate(ctypes.byref(module.model), p.ctypes.data_as(_P),
                                  ctypes.byref(settings), bridge.array, len(bridge.events),
                                  ctypes.byref(result), ctypes.byref(error))
    if status != DEP_OK:
        raise _exception(error, bridge)
    try:
        return _result(module, result)
    finally:
        library.dep_result_free(ctypes.byref(result))


def _text(value: bytes) -> str:
    return value.decode("utf-8", errors="replace")


def _exception(error: Error, bridge: EventBridge) -> Exception:
    """The Python exception of a failed C run."""
    if bridge.exception is not None:
        return bridge.exception
    if error.code == DEP_SOLVER_ERROR:
        return SolverError(_text(error.what), t=error.t if error.has_t else None,
                           stage=_text(error.stage) or None, row=_text(error.row) or None,
                           joint=_text(error.joint) or None,
                           residual=error.residual if error.has_residual else None,
                           hint=_text(error.hint) or None)
    if error.code == DEP_SETTINGS_ERROR:
        return ValueError(_text(error.message))
    if error.code == DEP_CALLBACK_ERROR:
        return RuntimeError(_text(error.message))
    return MemoryError(_text(error.message))


def _array(pointer, rows: int, width: int | None = None) -> np.ndarray:
    shape = (rows,) if width is None else (rows, width)
    size = rows * (1 if width is None else width)
    if size == 0:
        return np.zeros(shape)
    return np.ctypeslib.as_array(pointer, shape=(size,)).reshape(shape).copy()


def _stats(s: StatsC) -> Stats:
    def passes(p: PassStatsC) -> PassStats:
        return PassStats(float(p.mean), int(p.max), int(p.total))

    return Stats(accepted_steps=s.accepted_steps, rejected_steps=s.rejected_steps,
                 failed_steps=s.failed_steps, integrations=s.integrations,
                 rhs_evaluations=s.rhs_evaluations, position=passes(s.position),
                 velocity=passes(s.velocity), acceleration=passes(s.acceleration),
                 cg_iterations=s.cg_iterations, factorizations=s.factorizations,
                 max_v_pos=s.max_v_pos, max_v_vel=s.max_v_vel, max_v_acc=s.max_v_acc,
                 min_step=s.min_step, max_step=s.max_step, events=s.events)


def _value(d: Datum):
    if d.kind == DEP_TEXT:
        return _text(d.text)
    if d.kind == DEP_BOOL:
        return bool(d.number)
    if d.kind == DEP_NONE:
        return None
    return float(d.number)


def _data(record: EventRecordC) -> dict:
    """A record's data as the Python runtime writes it: members form a dict under their key."""
    data: dict = {}
    for i in range(record.n_data):
        d = record.data[i]
        key, member = _text(d.key), _text(d.member)
        if member:
            data.setdefault(key, {})[member] = _value(d)
        else:
            data[key] = _value(d)
    return data


def _records(r: ResultC) -> tuple[EventRecord, ...]:
    return tuple(EventRecord(_text(r.events[k].name), float(r.events[k].t),
                             _data(r.events[k])) for k in range(r.n_events))


def _peaks(module: CModule, r: ResultC) -> dict:
    return {h: PeakLoad(float(r.peaks[k].force), float(r.peaks[k].t_force),
                        float(r.peaks[k].torque), float(r.peaks[k].t_torque))
            for k, h in enumerate(module.HINGES)}


def _names(pointer, count: int) -> tuple[str, ...]:
    return tuple(_text(pointer[i]) for i in range(count))


def _result(module: CModule, r: ResultC) -> Result:
    n = r.n
    return Result(
        model=module.MODEL_NAME, method="iterative",
        parameter_names=tuple(module.PARAMETERS), parameters=_array(r.params, module.NP),
        tol=r.tol, constraint_tol=r.constraint_tol, t_end=r.t_end, dt_out=r.dt_out,
        times=_array(r.times, n), coordinate_names=tuple(module.COORDINATES),
        q=_array(r.q, n, r.nq), qd=_array(r.qd, n, r.nq),
        constraint_names=_names(r.row_names, r.n_rows),
        lam=_array(r.lam, n, r.n_rows), hinge_names=tuple(module.HINGES),
        hinge_angles=_array(r.hinge_angles, n, r.nh), hinge_rates=_array(r.hinge_rates, n, r.nh),
        output_names=tuple(module.OUTPUTS), output_units=tuple(module.OUTPUT_UNITS),
        outputs=_array(r.outputs, n, r.nout), residual_pos=_array(r.residual_pos, n),
        residual_vel=_array(r.residual_vel, n), residual_acc=_array(r.residual_acc, n),
        energy_names=_names(r.energy_names, r.ne), energy=_array(r.energy, n, r.ne),
        dissipator_names=_names(r.dissipator_names, r.nd),
        dissipated=_array(r.dissipated, n, r.nd), stats=_stats(r.stats), events=_records(r),
        hinge_torque=_array(r.hinge_torque, n, r.nh),
        latch_hinges=tuple(module.HINGES[r.latch_hinges[i]] for i in range(r.n_latch_hinges)),
        step_peaks=_peaks(module, r))


class EventBridge:
    """Python `Event`s as C `dep_event`s. A callback sees an `EventHit` whose `constraints` is
    a Python `ConstraintSet` of the rows active in C (the model's, then the added `HingeLock`
    and `LinearConstraint` rows) and whose `module` is the CModule; its `EventResponse` may add
    such rows. `records` and `work` in a response are the mechanism's own (not taken here)."""

    def __init__(self, module: CModule, p: np.ndarray, events):
        self.module, self.p, self.events = module, p, tuple(events)
        self.exception: BaseException | None = None
        self.keep: list = []  # arrays the C side reads until the next callback
        self.system = System(module, p) if self.events else None
        self.functions = [EVENT_FUNCTION(self._function(e)) for e in self.events]
        self.callbacks = [EVENT_CALLBACK(self._callback(e)) for e in self.events]
        self.names = [e.name.encode("utf-8") for e in self.events]
        array = (EventC * max(1, len(self.events)))()
        for k, e in enumerate(self.events):
            array[k] = EventC(self.names[k], self.functions[k], int(e.direction),
                              self.callbacks[k], None, int(bool(e.terminal)),
                              -1 if e.max_hits is None else int(e.max_hits),
                              int(bool(getattr(e, "multipliers", False))))
        self.array = array

    def _guard(self, work) -> int:
        if self.exception is not None:
            return 1
        try:
            work()
            return 0
        except BaseException as exc:  # re-raised by simulate()
            self.exception = exc
            return 1

    def _function(self, event):
        nq = self.module.NQ
        watches = bool(getattr(event, "multipliers", False))

        def function(_context, t, q, qd, rows, out):
            def work():
                q_arr, qd_arr = (np.ctypeslib.as_array(x, shape=(nq,)).copy() for x in (q, qd))
                if watches:
                    r = rows.contents
                    lam = {_text(r.names[i]): float(r.lam[i]) for i in range(r.nc)}
                    out[0] = float(event.function(t, q_arr, qd_arr, lam))
                else:
                    out[0] = float(event.function(t, q_arr, qd_arr))
            return self._guard(work)

        return function

    def _callback(self, event):
        def callback(_context, hit, response):
            return self._guard(lambda: self._respond(event, hit.contents, response.contents))

        return callback

    def _constraints(self, hit: EventHitC) -> ConstraintSet:
        """The active rows as a Python ConstraintSet."""
        rows = []
        for i in range(hit.n_added):
            r = hit.added[i]
            name, joint = _text(r.name), _text(r.joint)
            if r.kind == ROW_HINGE_LOCK:
                rows.append(HingeLock(self.module, self.module.HINGES[r.hinge], float(r.angle),
                                      name=name, joint=joint))
            else:
                row = np.ctypeslib.as_array(r.row, shape=(self.module.NQ,)).copy()
                rows.append(LinearConstraint(name, joint, row, float(r.value)))
        return ConstraintSet(self.system, rows)

    def _respond(self, event, hit: EventHitC, out: Response) -> None:
        nq = self.module.NQ
        q, qd = (np.ctypeslib.as_array(x, shape=(nq,)).copy() for x in (hit.q, hit.qd))
        lam = _array(hit.lam, hit.nc)
        info = EventHit(event.name, hit.t, q, qd, lam, self._constraints(hit), self.module,
                        self.p.copy())
        response = (event.callback(info) if event.callback else None) or EventResponse()
        if getattr(response, "records", None) is not None or getattr(response, "work", None):
            raise TypeError(f"event '{event.name}': the C integrator takes `records` and `work` "
                            "only from its own latches, stops and stick-slip mechanism")
        self._fill(response, out)

    def _fill(self, response: EventResponse, out: Response) -> None:
        self.keep = []
        out.stop = -1 if response.stop is None else int(bool(response.stop))
        for name in ("q", "qd"):
            value = getattr(response, name)
            if value is not None:
                array = np.ascontiguousarray(value, dtype=float)
                self.keep.append(array)
                setattr(out, name, array.ctypes.data_as(_P))
        if len(response.add) > MAX_ADDED or len(response.remove) > MAX_ADDED:
            raise ValueError(f"an event may add or remove at most {MAX_ADDED} rows")
        for i, row in enumerate(response.add):
            out.add[i] = self._row(row)
        out.n_add = len(response.add)
        for i, name in enumerate(response.remove):
            out.remove[i].value = name.encode("utf-8")[:NAME_MAX - 1]
        out.n_remove = len(response.remove)
        out.impact = int(bool(response.impact))
        data = list(response.data.items())[:MAX_DATA]
        for i, (key, value) in enumerate(data):
            out.data_names[i].value = str(key).encode("utf-8")[:NAME_MAX - 1]
            out.data_values[i] = float(value)
        out.n_data = len(data)

    def _row(self, row) -> Row:
        name, joint = row.name.encode("utf-8"), row.joint.encode("utf-8")
        if isinstance(row, HingeLock):
            return Row(ROW_HINGE_LOCK, name, joint, self.module.HINGES.index(row.hinge),
                       float(row.angle), None, 0.0)
        if isinstance(row, LinearConstraint):
            array = np.ascontiguousarray(row.row, dtype=float)
            self.keep.append(array)
            return Row(ROW_LINEAR, name, joint, -1, 0.0, array.ctypes.data_as(_P),
                       float(row.value))
        raise TypeError(f"the C integrator takes HingeLock and LinearConstraint rows, not "
                        f"{type(row).__name__}")
