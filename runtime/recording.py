"""Samples the solution at the requested output times and assembles the `Result`."""

from __future__ import annotations

import math

import numpy as np

from .loads import lock_torques
from .results import EventRecord, Result, Stats


def output_times(t_end: float, dt_out: float) -> np.ndarray:
    """0, dt_out, 2 dt_out, ... up to t_end, with t_end itself always last (s)."""
    count = math.floor(t_end / dt_out * (1 + 1e-12))
    times = np.arange(count + 1) * dt_out
    if t_end - times[-1] > 1e-9 * dt_out:
        times = np.append(times, t_end)
    else:
        times[-1] = t_end
    return times


class Recorder:
    """Collects one row per output time from states (t, q, qd, lam, work) of a system.

    Energies and dissipators are the system's (`energy_names`, `energy`, `dissipator_names`
    when it has them, e.g. a MechanismSystem), else the module's. `hinge_torques(q, qd, names,
    lam) -> (NH,)` gives each hinge's lock torque (default: -lambda of its lock row)."""

    def __init__(self, system, settings, method: str):
        self.system = system
        self.settings = settings
        self.method = method
        self.times = output_times(settings.t_end, settings.dt_out)
        self.next_index = 0
        self.rows: list[tuple] = []
        self.row_names: list[str] = []
        module = system.module
        self.energy_names = tuple(getattr(system, "energy_names", module.ENERGIES))
        self.dissipator_names = tuple(getattr(system, "dissipator_names", module.DISSIPATORS))
        self.hinge_torques = None

    def _energy(self, q, qd, t) -> np.ndarray:
        if hasattr(self.system, "energy"):
            return np.asarray(self.system.energy(q, qd, t), dtype=float)
        return np.asarray(self.system.module.energy(q, qd, t, self.system.p), dtype=float)

    def _torques(self, q, qd, names, lam) -> np.ndarray:
        if self.hinge_torques is not None:
            return np.asarray(self.hinge_torques(q, qd, names, lam), dtype=float)
        return lock_torques(self.system.module.HINGES, names, lam)

    def pending(self, t_until: float) -> list[float]:
        """Output times not yet recorded that are <= t_until (s); marks them recorded."""
        start = self.next_index
        slack = 1e-12 * max(1.0, abs(t_until))
        while self.next_index < len(self.times) and self.times[self.next_index] <= t_until + slack:
            self.next_index += 1
        return list(self.times[start:self.next_index])

    def record(self, t, q, qd, lam, work, constraints) -> None:
        """Store the row for time t (s) with the multipliers lam of `constraints`' rows."""
        module, p = self.system.module, self.system.p
        for name in constraints.names:
            if name not in self.row_names:
                self.row_names.append(name)
        f = self.system.force(q, qd, t)
        J = constraints.jacobian(q, t)
        qdd = self.system.mass.solve(f - J.T @ lam)
        residuals = (np.max(np.abs(constraints.phi(q, t)), initial=0.0),
                     np.max(np.abs(constraints.v_vel(q, qd, t, J)), initial=0.0),
                     np.max(np.abs(constraints.v_acc(q, qd, qdd, t, J)), initial=0.0))
        self.rows.append((t, q.copy(), qd.copy(), dict(zip(constraints.names, lam)),
                          np.asarray(module.hinge_angles(q, p), dtype=float),
                          np.asarray(module.hinge_rates(q, qd, p), dtype=float),
                          np.asarray(module.outputs(q, qd, t, p), dtype=float),
                          residuals, self._energy(q, qd, t), np.array(work, dtype=float),
                          self._torques(q, qd, constraints.names, lam)))

    def result(self, stats: Stats, events: list[EventRecord],
               constraint_tol: float | None = None, latch_hinges=(), peaks=None) -> Result:
        """The assembled Result; `latch_hinges` the hinges with a latch, `peaks` the hinge
        load maxima found at the step points ({hinge: PeakLoad})."""
        module, nq = self.system.module, self.system.nq
        columns = list(zip(*self.rows)) if self.rows else [[]] * 11
        lam = np.array([[row.get(n, np.nan) for n in self.row_names] for row in columns[3]])
        residuals = np.array(columns[7]).reshape(-1, 3)

        def stack(values, width):
            return np.array(values, dtype=float).reshape(len(self.rows), width)

        return Result(
            model=self.system.name, method=self.method,
            parameter_names=tuple(module.PARAMETERS), parameters=self.system.p.copy(),
            tol=self.settings.tol, constraint_tol=constraint_tol, t_end=self.settings.t_end, dt_out=self.settings.dt_out,
            times=np.array(columns[0], dtype=float), coordinate_names=tuple(module.COORDINATES),
            q=stack(columns[1], nq), qd=stack(columns[2], nq),
            constraint_names=tuple(self.row_names),
            lam=lam.reshape(len(self.rows), len(self.row_names)),
            hinge_names=tuple(module.HINGES),
            hinge_angles=stack(columns[4], len(module.HINGES)),
            hinge_rates=stack(columns[5], len(module.HINGES)),
            output_names=tuple(module.OUTPUTS), output_units=tuple(module.OUTPUT_UNITS),
            outputs=stack(columns[6], len(module.OUTPUTS)),
            residual_pos=residuals[:, 0], residual_vel=residuals[:, 1],
            residual_acc=residuals[:, 2],
            energy_names=self.energy_names, energy=stack(columns[8], len(self.energy_names)),
            dissipator_names=self.dissipator_names,
            dissipated=stack(columns[9], len(self.dissipator_names)),
            stats=stats, events=tuple(events),
            hinge_torque=stack(columns[10], len(module.HINGES)),
            latch_hinges=tuple(latch_hinges), step_peaks=peaks)
