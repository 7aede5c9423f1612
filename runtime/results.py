"""A run's results: arrays at the output times, statistics, events, and their export.

Arrays have one row per output time (n,). Multipliers have one column per constraint row that
was active at any time (`constraint_names`), NaN where the row was not active. Files are
written with `output.atomic_path` (a temporary file in the same folder, then a rename), so a
failure never leaves a half-written file.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field

import numpy as np

from .loads import Deployment, HingeLoad, PeakLoad
from .output import atomic_path

# The most output times a run may record: each costs a row of every array of the Result
# (t, q, qd, lambda, outputs, energies, ...), so t_end / dt_out = 1e10 would ask for tens of
# GiB. `check_output_rows` says so before a run starts.
MAX_OUTPUT_ROWS = 10_000_000


def output_rows(t_end: float, dt_out: float) -> int:
    """How many output times a run records: 0, dt_out, 2 dt_out, ... up to t_end, and t_end
    itself (counted as the integrator core does, runtime/c/run/recording.c). t_end, dt_out > 0, s."""
    count = math.floor(t_end / dt_out * (1 + 1e-12))
    return count + 1 + (t_end - count * dt_out > 1e-9 * dt_out)


def check_output_rows(t_end: float, dt_out: float) -> None:
    """ValueError, saying what to change, when t_end / dt_out asks for more than
    MAX_OUTPUT_ROWS output times."""
    rows = output_rows(t_end, dt_out)
    if rows > MAX_OUTPUT_ROWS:
        raise ValueError(f"t_end = {t_end:g} s with dt_out = {dt_out:g} s asks for {rows:,} "
                         f"output times, more than the limit of {MAX_OUTPUT_ROWS:,}: use "
                         f"dt_out >= {t_end / (MAX_OUTPUT_ROWS - 2):.3g} s or a shorter t_end")


@dataclass(frozen=True, slots=True)
class PassStats:
    """Iterations of (6) per step for one pass: mean, max, total."""

    mean: float = 0.0
    max: int = 0
    total: int = 0


@dataclass(frozen=True, slots=True)
class Stats:
    """Work and accuracy of one run.

    max_v_pos / max_v_vel / max_v_acc are the largest constraint residuals (SI; max over rows)
    at the accepted step points; `failed_steps` counts steps retried because a pass did not
    converge; `factorizations` counts augmented-matrix factorisations (direct solver only).
    """

    accepted_steps: int = 0
    rejected_steps: int = 0
    failed_steps: int = 0
    integrations: int = 0
    rhs_evaluations: int = 0
    position: PassStats = PassStats()
    velocity: PassStats = PassStats()
    acceleration: PassStats = PassStats()
    cg_iterations: int = 0
    factorizations: int = 0
    max_v_pos: float = 0.0
    max_v_vel: float = 0.0
    max_v_acc: float = 0.0
    min_step: float = 0.0
    max_step: float = 0.0
    events: int = 0
    implicit_from: float | None = None  # s: from when the step was linearly implicit
    stiff_rate: float | None = None  # 1/s: the stiff mode's rate that brought it (auto)
    force_steps: int = 0  # accepted steps that prescribed the rows' forces (singular positions)


@dataclass(frozen=True, slots=True)
class EventRecord:
    """An event that fired: its name, time (s) and plain numbers (e.g. energy lost, J). kind:
    "event" (the caller's), a hinge's transition ("latch", "latch.contact",
    "latch.separation", "stop", "stick", "slip"; `hinge` names it) or "assembly"."""

    name: str
    t: float
    data: dict = field(default_factory=dict)
    kind: str = "event"
    hinge: str | None = None


@dataclass(frozen=True)
class Sensitivities:
    """Forward sensitivities of a run (docs/calibration.md): the derivatives of its trajectory
    with respect to the parameters followed, at the output times, computed by the core along
    the run (docs/method.md, 12). Shapes: n output times, k parameters."""

    parameters: tuple[str, ...]  # (k,) the parameters followed, by name
    q: np.ndarray  # (n, k, NQ) d q / d p
    qd: np.ndarray  # (n, k, NQ) d qd / d p
    outputs: np.ndarray  # (n, k, NOUT) d output / d p (SI per SI; NaN: a dissipated work's)
    event_times: np.ndarray  # (n_events, k) d t_event / d p of each event record (0 at t = 0)
    lam: np.ndarray | None = None  # (n, k, NC) d lambda / d p of the model's rows
    output_names: tuple[str, ...] = ()
    constraint_names: tuple[str, ...] = ()  # (NC,) the model's rows, the columns of lam

    def output(self, name: str, parameter: str) -> np.ndarray:
        """d output / d parameter at the output times (n,)."""
        if name not in self.output_names:
            raise KeyError(f"no output '{name}' (outputs: {', '.join(self.output_names)})")
        return self.outputs[:, self._index(parameter), self.output_names.index(name)]

    def _index(self, parameter: str) -> int:
        if parameter not in self.parameters:
            raise KeyError(f"no sensitivity to '{parameter}' (followed: "
                           f"{', '.join(self.parameters)})")
        return self.parameters.index(parameter)

    def event_time(self, index: int, parameter: str) -> float:
        """d t / d parameter of event record `index` (Result.events[index])."""
        return float(self.event_times[index, self._index(parameter)])

    def event_text(self, events) -> str:
        """The events' times' sensitivities as a table (the run's `events`)."""
        lines = ["  event time sensitivities, dt/dp (s per SI unit):"]
        width = max([len(e.name) for e in events] + [5])
        lines.append(f"    {'event':<{width}}  {'t (s)':>10}" + "".join(
            f"  {name:>16}" for name in self.parameters))
        for k, event in enumerate(events):
            lines.append(f"    {event.name:<{width}}  {event.t:10.6g}" + "".join(
                f"  {self.event_times[k, i]:16.6g}" for i in range(len(self.parameters))))
        return "\n".join(lines if events else lines[:1] + ["    (no events)"])

    def columns(self) -> tuple[tuple[str, ...], np.ndarray]:
        """CSV columns "d(OUTPUT)/d(PARAMETER)" and their values (n, k NOUT), parameter by
        parameter."""
        names = tuple(f"d({o})/d({p})" for p in self.parameters for o in self.output_names)
        n = self.outputs.shape[0]
        return names, self.outputs.reshape(n, -1)


@dataclass(frozen=True)
class Result:
    """Everything a run produced. Shapes: n output times, NQ coordinates, rows ever active."""

    model: str
    method: str  # "iterative" or "direct"
    parameter_names: tuple[str, ...]
    parameters: np.ndarray  # (NP,) SI values used
    tol: float
    constraint_tol: float | None  # the passes' iteration tolerance (iterative method only)
    t_end: float
    dt_out: float
    times: np.ndarray  # (n,) s
    coordinate_names: tuple[str, ...]
    q: np.ndarray  # (n, NQ)
    qd: np.ndarray  # (n, NQ)
    constraint_names: tuple[str, ...]
    lam: np.ndarray  # (n, rows), NaN where inactive; lambda by its interpolation over a step
    hinge_names: tuple[str, ...]
    hinge_angles: np.ndarray  # (n, NH) rad
    hinge_rates: np.ndarray  # (n, NH) rad/s
    output_names: tuple[str, ...]
    output_units: tuple[str, ...]
    outputs: np.ndarray  # (n, NOUT) SI
    residual_pos: np.ndarray  # (n,) max |Phi|
    residual_vel: np.ndarray  # (n,) max |Phi_q qd + Phi_t|
    residual_acc: np.ndarray  # (n,) max |gamma - Phi_q qdd| with the interpolated lambda
    energy_names: tuple[str, ...]
    energy: np.ndarray  # (n, NE) J
    dissipator_names: tuple[str, ...]
    dissipated: np.ndarray  # (n, ND) J, work removed since t = 0
    stats: Stats
    events: tuple[EventRecord, ...]
    hinge_force: np.ndarray  # (n, NH, 3) N force on member b from member a, world frame
    # (z 0 in a planar model)
    hinge_torque: np.ndarray  # (n, NH) N m lock torque on member b, NaN if free
    peak_loads: dict[str, PeakLoad]  # largest hinge loads over output times and every step
    deployment: Deployment  # latches, deployed or not, dissipated energy (docs/deployment.md)
    report_text: str  # the run's summary, as report() returns it
    system_names: tuple[str, ...] = ()  # mass, com_x, com_y, momentum_x, momentum_y, ...
    system: np.ndarray | None = None  # (n, NSYS) the whole system's, SI (system_state)
    sensitivities: Sensitivities | None = None  # with simulate(..., sensitivities=[...])

    @property
    def latch_hinges(self) -> tuple[str, ...]:
        """The hinges with a latch (docs/deployment.md)."""
        return self.deployment.latch_hinges

    @property
    def hinge_loads(self) -> dict[str, HingeLoad]:
        """Each hinge's loads at the output times: force on member b from member a (world
        frame, N; the multipliers of its reaction rows), its magnitude, and the lock torque
        (N m, NaN while nothing locks the hinge). docs/deployment.md, section 5."""
        forces = self.hinge_force
        return {h: HingeLoad(forces[:, k, 0], forces[:, k, 1], forces[:, k, 2],
                             np.hypot(np.hypot(forces[:, k, 0], forces[:, k, 1]),
                                      forces[:, k, 2]), self.hinge_torque[:, k])
                for k, h in enumerate(self.hinge_names)}

    def output(self, name: str) -> np.ndarray:
        """The column of output `name` (n,)."""
        if name not in self.output_names:
            raise KeyError(f"no output '{name}' (outputs: {', '.join(self.output_names)})")
        return self.outputs[:, self.output_names.index(name)]

    def total_energy(self) -> np.ndarray:
        """Kinetic + potential energy + energy dissipated so far (n,), J, including the kinetic
        energy plastic impacts removed at events before each output time (their
        `impact_energy_loss`): constant when the model's forces are all accounted for."""
        impacts = np.zeros(len(self.times))
        for e in self.events:
            loss = e.data.get("impact_energy_loss")
            if loss:
                impacts[self.times > e.t] += loss
        return self.energy.sum(axis=1) + self.dissipated.sum(axis=1) + impacts

    def to_csv(self, path) -> None:
        """`t` then one column per output (SI), header names exactly the output names, %.17g;
        with sensitivities, then d(OUTPUT)/d(PARAMETER) for each parameter and output."""
        names, columns = ((), np.empty((len(self.times), 0))) if self.sensitivities is None \
            else self.sensitivities.columns()
        table = np.column_stack((self.times, self.outputs, columns))
        header = ",".join(("t",) + self.output_names + names)
        lines = [header] + [",".join(f"{v:.17g}" for v in row) for row in table]
        _write_atomic(path, "\n".join(lines) + "\n")

    def summary(self, system: bool = False) -> dict:
        """Model, parameters, tolerances, statistics and events as plain JSON-ready data;
        `system`: with the system's momentum and energy balance (system_summary)."""
        found = {
            "model": self.model,
            "method": self.method,
            "parameters": dict(zip(self.parameter_names, map(float, self.parameters))),
            "tolerances": {"tol": self.tol, "constraint_tol": self.constraint_tol,
                           "t_end": self.t_end, "dt_out": self.dt_out},
            "statistics": dataclasses.asdict(self.stats),
            "events": [{"name": e.name, "t": e.t, **e.data, **self._event_sensitivity(k)}
                       for k, e in enumerate(self.events)],
            "deployment": _deployment_summary(self.deployment),
            "peak_hinge_loads": {h: _finite(dataclasses.asdict(p))
                                 for h, p in self.peak_loads.items()},
        }
        if system:
            found["system"] = self.system_summary()
        return found

    def _event_sensitivity(self, k: int) -> dict:
        """{"dt_dp": {parameter: d t / d p}} of event record k, when sensitivities were followed
        (null where the event's time was not followed)."""
        s = self.sensitivities
        if s is None:
            return {}
        return {"dt_dp": _finite({name: float(s.event_times[k, i])
                                  for i, name in enumerate(s.parameters)})}

    def system_summary(self) -> dict:
        """The system's quantities (mass, centre of mass, momentum, angular momentum about the
        centre of mass; then the energy: kinetic + potential and what was dissipated) at the
        start and the end, and their largest change from the start, SI."""
        columns = list(zip(self.system_names, np.asarray(self.system).T)) \
            if self.system is not None and len(self.times) else []
        if len(self.times):  # kinetic + potential, what was dissipated, and their sum
            energy, total = self.energy.sum(axis=1), self.total_energy()
            columns += [("energy", energy), ("dissipated", total - energy),
                        ("energy_balance", total)]
        return {name: {"start": float(values[0]), "end": float(values[-1]),
                       "largest_change": float(np.max(np.abs(values - values[0])))}
                for name, values in columns}

    def system_line(self) -> str:
        """One line for a free-flying mechanism: its momentum and angular momentum about its
        centre of mass at the end, and how far they moved from the start."""
        found = self.system_summary()
        if "momentum_x" not in found:
            return ""
        p = [found[f"momentum_{axis}"] for axis in "xyz" if f"momentum_{axis}" in found]
        h = [found[name] for name in ("angular_momentum", "angular_momentum_x",
                                      "angular_momentum_y", "angular_momentum_z")
             if name in found]
        change = max(value["largest_change"] for value in p)
        turn = max(value["largest_change"] for value in h)
        momentum = ", ".join(f"{value['end']:.6g}" for value in p)
        spin = ", ".join(f"{value['end']:.6g}" for value in h)
        spin = f"({spin})" if len(h) > 1 else spin
        return (f"  system: momentum ({momentum}) N*s, angular momentum about its centre of "
                f"mass {spin} N*m*s; largest change over the run {change:.2g} N*s and "
                f"{turn:.2g} N*m*s")

    def to_json(self, path, system: bool = False) -> None:
        """The `summary(system)` as JSON."""
        _write_atomic(path, json.dumps(self.summary(system), indent=2) + "\n")

    def report(self) -> str:
        """Human-readable lines: deployment first (deployed or not, latches with time, rate and
        impulse, time to full deployment, peak hinge loads, friction energy), then the solver
        (the integrator core writes it, so the standalone C program prints the same)."""
        return self.report_text.rstrip("\n")


@dataclass(frozen=True, slots=True)
class RunEnd:
    """What a run leaves at its end, without its rows (`depsim.runtime.runner.RunEnds`): the
    parameters, the events, the deployment, the peak loads, the statistics, and the outputs and
    dissipated energies at t_end, the same numbers as the run's `Result` has. What a parameter
    study's built-in metrics read (depsim.runtime.sweep.metrics)."""

    model: str
    parameters: np.ndarray  # (NP,) SI values used
    t_end: float
    output_names: tuple[str, ...]
    outputs: np.ndarray  # (1, NOUT) SI, at t_end
    dissipator_names: tuple[str, ...]
    dissipated: np.ndarray  # (1, ND) J, work removed by t_end
    stats: Stats
    events: tuple[EventRecord, ...]
    peak_loads: dict[str, PeakLoad]  # largest hinge loads over every step
    deployment: Deployment

    def output(self, name: str) -> np.ndarray:
        """Output `name` at t_end, a column of one row (1,)."""
        if name not in self.output_names:
            raise KeyError(f"no output '{name}' (outputs: {', '.join(self.output_names)})")
        return self.outputs[:, self.output_names.index(name)]


def _deployment_summary(deployment: Deployment) -> dict:
    return {"deployed": deployment.deployed, "time_to_deploy": deployment.time,
            "latch_hinges": list(deployment.latch_hinges),
            "latches": [_finite(dataclasses.asdict(r)) for r in deployment.latches],
            "friction_energy": deployment.friction_energy,
            "impact_energy": deployment.impact_energy}


def _finite(values: dict) -> dict:
    """NaN -> None, so the JSON stays standard."""
    return {k: (None if isinstance(v, float) and not np.isfinite(v) else v)
            for k, v in values.items()}


def _write_atomic(path, text: str) -> None:
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8", newline="\n") as handle:
            handle.write(text)
