"""A run's `dep_result` (runtime/c/include/depsim.h) read into Python: the whole `Result`
(`read_result`), or the run's end alone (`read_end`: what a parameter study's metrics read).

Every number is copied out of the C result, which the caller then frees.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .core import core, ffi
from .loads import Deployment, LatchRecord, PeakLoad
from .results import EventRecord, PassStats, Result, RunEnd, Sensitivities, Stats


def text(value) -> str:
    """A C string as Python text."""
    return ffi().string(value).decode("utf-8", errors="replace")


def doubles(pointer, rows: int, *widths: int) -> np.ndarray:
    """A copy of the C array of doubles at `pointer`, of shape (rows, *widths)."""
    shape = (rows, *widths)
    size = math.prod(shape)  # (np.prod: a ufunc reduction, 5 us a call)
    if size == 0:
        return np.zeros(shape)
    return np.frombuffer(ffi().buffer(pointer, 8 * size), dtype=float).reshape(shape).copy()


def _names(pointer, count: int) -> tuple[str, ...]:
    return tuple(text(pointer[i]) for i in range(count))


def _stats(s) -> Stats:
    def passes(p) -> PassStats:
        return PassStats(float(p.mean), int(p.max), int(p.total))

    return Stats(accepted_steps=s.accepted_steps, rejected_steps=s.rejected_steps,
                 failed_steps=s.failed_steps, integrations=s.integrations,
                 rhs_evaluations=s.rhs_evaluations, position=passes(s.position),
                 velocity=passes(s.velocity), acceleration=passes(s.acceleration),
                 cg_iterations=s.cg_iterations, factorizations=s.factorizations,
                 max_v_pos=s.max_v_pos, max_v_vel=s.max_v_vel, max_v_acc=s.max_v_acc,
                 min_step=s.min_step, max_step=s.max_step, events=s.events,
                 implicit_from=_number(s.implicit_from), stiff_rate=_number(s.stiff_rate),
                 force_steps=s.force_steps)


def _number(value: float) -> float | None:
    """A statistic the core leaves nan when it does not apply, as None."""
    return None if math.isnan(value) else float(value)


@functools.cache
def _datum_kinds() -> tuple[int, int, int]:
    """enum dep_datum_kind's DEP_TEXT, DEP_BOOL and DEP_NONE (depsim.h), read once: an
    attribute of the cffi library is a lookup each time."""
    library = core()
    return library.DEP_TEXT, library.DEP_BOOL, library.DEP_NONE


def _value(d, kinds: tuple[int, int, int]):
    kind = d.kind
    if kind == kinds[0]:
        return text(d.text)
    if kind == kinds[1]:
        return bool(d.number)
    if kind == kinds[2]:
        return None
    return float(d.number)


def _data(record) -> dict:
    """A record's data: entries with a member form a dict under their key."""
    data: dict = {}
    kinds, string = _datum_kinds(), ffi().string
    entries = record.data
    for i in range(record.n_data):
        d = entries[i]
        key, member = string(d.key).decode("utf-8", "replace"), string(d.member)
        if member:
            data.setdefault(key, {})[member.decode("utf-8", "replace")] = _value(d, kinds)
        else:
            data[key] = _value(d, kinds)
    return data


@functools.cache
def _record_kinds() -> dict[int, str]:
    """enum dep_record_kind (depsim.h) as EventRecord.kind: DEP_RECORD_LATCH_CONTACT is
    "latch.contact"."""
    elements = ffi().typeof("enum dep_record_kind").elements
    return {value: name.removeprefix("DEP_RECORD_").lower().replace("_", ".")
            for value, name in elements.items()}


def _records(module, r) -> tuple[EventRecord, ...]:
    kinds, hinges = _record_kinds(), module.HINGES
    return tuple(EventRecord(text(e.name), float(e.t), _data(e), kinds[e.kind],
                             hinges[e.hinge] if e.hinge >= 0 else None)
                 for e in (r.events[k] for k in range(r.n_events)))


def _peaks(module, r) -> dict:
    """Each hinge's peak loads; a slider's entry (docs/language.md, slider) has its lock force
    along its axis as its force (the core tracks it as a hinge's lock torque) and no torque."""
    sliders = set(getattr(module, "SLIDERS", ()))
    found = {}
    for k, h in enumerate(module.HINGES):
        peak = r.peak_loads[k]
        values = (peak.force, peak.t_force, peak.torque, peak.t_torque) if h not in sliders \
            else (peak.torque, peak.t_torque, 0.0, math.nan)
        found[h] = PeakLoad(*map(float, values), bool(peak.unique))
    return found


def _optional(value: float) -> float | None:
    return None if np.isnan(value) else float(value)


def _deployment(module, d) -> Deployment:
    hinges = module.HINGES
    latches = tuple(LatchRecord(hinges[s.hinge], float(s.t), float(s.rate),
                                _optional(s.impulse), _optional(s.energy_loss), bool(s.rigid))
                    for s in (d.latches[k] for k in range(d.n_latches)))
    return Deployment(tuple(hinges[d.latch_hinges[k]] for k in range(d.n_latch_hinges)),
                      latches, None if d.deployed < 0 else bool(d.deployed),
                      _optional(d.time), float(d.friction_energy), float(d.impact_energy))




def read_result(module, r) -> Result:
    """The whole run: every array at its n output times."""
    n = r.n
    q, qd, p = doubles(r.q, n, r.nq), doubles(r.qd, n, r.nq), doubles(r.params, module.NP)
    return Result(
        model=module.MODEL_NAME, method="iterative",
        parameter_names=tuple(module.PARAMETERS), parameters=p,
        tol=r.tol, constraint_tol=r.constraint_tol, t_end=r.t_end, dt_out=r.dt_out,
        times=doubles(r.times, n), coordinate_names=tuple(module.COORDINATES), q=q, qd=qd,
        constraint_names=_names(r.row_names, r.n_rows),
        lam=doubles(r.lam, n, r.n_rows), hinge_names=tuple(module.HINGES),
        hinge_angles=doubles(r.hinge_angles, n, r.nh), hinge_rates=doubles(r.hinge_rates, n, r.nh),
        output_names=tuple(module.OUTPUTS), output_units=tuple(module.OUTPUT_UNITS),
        outputs=doubles(r.outputs, n, r.nout), residual_pos=doubles(r.residual_pos, n),
        residual_vel=doubles(r.residual_vel, n), residual_acc=doubles(r.residual_acc, n),
        energy_names=_names(r.energy_names, r.ne), energy=doubles(r.energy, n, r.ne),
        dissipator_names=_names(r.dissipator_names, r.nd),
        dissipated=doubles(r.dissipated, n, r.nd), stats=_stats(r.stats),
        events=_records(module, r),
        hinge_force=doubles(r.hinge_force, n, r.nh, 3),
        hinge_torque=doubles(r.hinge_torque, n, r.nh), peak_loads=_peaks(module, r),
        deployment=_deployment(module, r.deployment), report_text=text(r.report),
        system_names=tuple(getattr(module, "SYSTEM_STATE", ())),
        system=doubles(r.system_state, n, r.nsys), sensitivities=_sensitivities(module, r))


def _sensitivities(module, r) -> Sensitivities | None:
    """The sensitivities the run followed (dep_result.sensitivity_*), or None."""
    k = r.n_sensitivities
    if k == 0:
        return None
    n, nq, nout = r.n, r.nq, r.nout
    state = doubles(r.sensitivity_state, n, k, 2 * nq)
    return Sensitivities(
        parameters=tuple(module.PARAMETERS[r.sensitivity_params[i]] for i in range(k)),
        q=state[:, :, :nq], qd=state[:, :, nq:], outputs=doubles(r.sensitivity_outputs, n, k, nout),
        event_times=doubles(r.sensitivity_events, r.n_events, k),
        lam=doubles(r.sensitivity_lam, n, k, int(module.NC)),
        output_names=tuple(module.OUTPUTS), constraint_names=tuple(module.CONSTRAINTS))


def read_end(module, r) -> RunEnd:
    """The run's end alone: no output row but the last one's outputs and dissipated work."""
    return RunEnd(model=module.MODEL_NAME, parameters=doubles(r.params, module.NP),
                  t_end=r.t_end, output_names=tuple(module.OUTPUTS),
                  outputs=_last_row(r.outputs, r.n, r.nout),
                  dissipator_names=_names(r.dissipator_names, r.nd),
                  dissipated=_last_row(r.dissipated, r.n, r.nd), stats=_stats(r.stats),
                  events=_records(module, r), peak_loads=_peaks(module, r),
                  deployment=_deployment(module, r.deployment))


def _last_row(pointer, rows: int, width: int) -> np.ndarray:
    """The last of `rows` rows of `width` doubles, as an array (1, width); (0, width) when
    there is none."""
    return doubles(pointer + (rows - 1) * width, 1, width) if rows else np.zeros((0, width))


__all__ = ["read_result", "read_end", "text", "doubles"]
