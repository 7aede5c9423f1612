"""`simulate`: the iterative Lagrange-multiplier integrator of the seed paper (section 2.2).

The run: check the initial state, find lambda_0 (acceleration pass), then take steps
(`stepper.Stepper`: lambda linear over the step, DOPRI 5(4) for the motion, three passes of
the iteration (6)), control the step with the ODE and interpolation errors
(`controller`), sample outputs on the dense output, and handle events. See docs/method.md.
Latches, hard stops and stick-slip friction from the module's `hinge_properties` are events
of a `deployment.Mechanism` (docs/deployment.md).
"""

from __future__ import annotations

import numpy as np

from .constraints import ConstraintSet, check_consistency
from .controller import (LambdaHistory, convergence_factor, initial_step,
                         interpolation_error, rms, step_factor, weights)
from .deployment import Mechanism, MechanismSystem
from .errors import SolverError
from .events import EVENT_TIME_TOL, EventHit, EventResponse, EventWatch
from .loads import PeakTracker, hinge_forces, lock_torques
from .multipliers import PassFailure, project_velocity
from .progress import Progress
from .recording import Recorder
from .results import EventRecord, Result
from .stepper import State, Stepper
from .system import System, resolve_settings
from .tally import Tally

REFINE_EVENT = 3  # Newton corrections of an event time on the re-taken step
EVENT_SLOPE_FRACTION = 1e-3  # g' from g at the step end and this fraction of h before it
MAX_FAILURES = 12  # consecutive non-converged steps (h divided by 4 each) before giving up
CAP_RELAX = 1.2


def simulate(module, params: np.ndarray | None = None, t_end: float | None = None,
             dt_out: float | None = None, tol: float | None = None, events=(),
             progress: bool = False, mechanics: bool = True) -> Result:
    """Integrate a generated module with the iterative multiplier method.

    module: a generated module (docs/generated-module.md); params (NP,) SI, default
    PARAMETER_DEFAULTS; t_end, dt_out (s) and tol default to the module's T_END, DT_OUT, TOL;
    events: `Event`s; progress: draw a bar on stderr (only when it is a terminal);
    mechanics: apply the hinges' latches, stops and stick-slip friction from
    `hinge_properties` (docs/deployment.md); False integrates without them.
    Raises SolverError when an iteration does not converge or the state is inconsistent.
    """
    settings = resolve_settings(module, params, t_end, dt_out, tol)
    return IterativeRun(module, settings, events, progress, mechanics=mechanics).run()


class IterativeRun:
    """One run of `simulate`; `velocity_pass` selects the velocity pass (stepper.py)."""

    def __init__(self, module, settings, events=(), progress=False, velocity_pass="project",
                 mechanics=True):
        self.mechanism = Mechanism.for_module(module, settings.params) if mechanics else None
        if self.mechanism is None:
            self.system = System(module, settings.params)
        else:
            self.system = MechanismSystem(module, settings.params, self.mechanism)
            events = tuple(events) + self.mechanism.events
        self.settings = settings
        self.tol = settings.tol
        self.stepper = Stepper(self.system, ConstraintSet(self.system), self.tol, velocity_pass)
        self.recorder = Recorder(self.system, settings, "iterative")
        self.peaks = PeakTracker(module.HINGES)
        if self.mechanism is not None:
            self.mechanism.bind(self.system, self.stepper.constraint_tol)
            self.recorder.hinge_torques = self.mechanism.hinge_torques
        self.watch = EventWatch(events)
        self.tally = Tally()
        self.records: list[EventRecord] = []
        self.progress = Progress(settings.t_end, progress)
        self.h_min = 64 * np.finfo(float).eps * max(1.0, settings.t_end)
        self.h_cap = np.inf  # after a pass failed at h: h/2, relaxed by CAP_RELAX per step

    @property
    def constraints(self) -> ConstraintSet:
        return self.stepper.constraints

    def run(self) -> Result:
        """Integrate from 0 to t_end (or a stopping event) and assemble the Result."""
        t_end = self.settings.t_end
        try:
            q0, qd0 = self.system.module.initial_state(self.system.p)
            q0, qd0 = np.array(q0, dtype=float), np.array(qd0, dtype=float)
            self.state = self._start(q0, qd0)
            self._record_until(0.0, None)
            self.watch.reset(0.0, self.state.q, self.state.qd, lam=self._lam_dict(self.state))
            h = self._first_step()
            while t_end - self.state.t > self.h_min:
                outcome, h = self._advance(h)
                if self._after_step(outcome):
                    break
                self.progress.update(self.state.t)
        finally:
            self.progress.close()
        stats = self.tally.stats(self.stepper.integrations, self.stepper.rhs_evaluations)
        latch_hinges = self.mechanism.latch_hinges if self.mechanism else ()
        return self.recorder.result(stats, self.records, self.stepper.constraint_tol,
                                    latch_hinges=latch_hinges, peaks=self.peaks.peaks())

    def _start(self, q0, qd0) -> State:
        """The initial state, after the mechanism's modes at t = 0 (a hinge starting at rest
        with static friction sticks or slips; one starting at its latch latches)."""
        work = np.zeros(self.system.nd)
        if self.mechanism is None:
            state = self._restart(0.0, q0, qd0, work, "initial state")
        else:
            check_consistency(self.constraints, 0.0, q0, qd0, self.tol, "initial state")
            response = self.mechanism.start(0.0, q0, qd0, self.constraints)
            data: dict = {}
            self._apply(response, State(0.0, q0, qd0, np.zeros_like(q0),
                                        np.zeros(self.constraints.nc), work), data)
            self.records += [EventRecord(name, 0.0, d) for name, d in response.records or ()]
            state = self.state
        self._observe_loads(state)
        return state

    def _lam_dict(self, state: State) -> dict | None:
        if not self.watch.needs_multipliers:
            return None
        return dict(zip(self.constraints.names, map(float, state.lam)))

    def _observe_loads(self, state: State) -> None:
        """Peak hinge forces and lock torques at an accepted state (exact lambda)."""
        cs = self.constraints
        forces = hinge_forces(self.system.module.HINGES, cs.names, state.lam)
        if self.mechanism is not None:
            torques = self.mechanism.hinge_torques(state.q, state.qd, cs.names, state.lam)
        else:
            torques = lock_torques(self.system.module.HINGES, cs.names, state.lam)
        self.peaks.observe(state.t, forces, torques)

    # -- states -------------------------------------------------------------------------------
    def _restart(self, t, q, qd, work, stage: str) -> State:
        """A state to start stepping from: checked for consistency, lambda from pass 3."""
        check_consistency(self.constraints, t, q, qd, self.tol, stage)
        try:
            lam, qdd, report = self.stepper.acceleration(q, qd, t, np.zeros(self.constraints.nc))
        except PassFailure as failure:
            raise self._solver_error(failure, t) from None
        self.tally.observe(report)
        self.history = LambdaHistory(t, lam)
        return State(t, q, qd, qdd, lam, work)

    def _solver_error(self, failure: PassFailure, t: float) -> SolverError:
        joint, row = self.constraints.describe(failure.row)
        if failure.residual <= 1e3 * np.finfo(float).eps * max(1.0, failure.scale):
            hint = ("the residual is at the level of round-off: tol is tighter than double "
                    f"precision reaches here; try tol >= {10 * self.tol:.0e}")
        else:
            hint = (f"Phi_q may be singular here (a dead point, a joint at the end of its "
                    f"travel) or constraints redundant and inconsistent; check {joint} and "
                    f"the joints in its loop, or try a looser tol")
        return SolverError(f"{failure.reason}; residual {failure.residual:.3g}", t=t,
                           stage=failure.stage, row=row, joint=joint,
                           residual=failure.residual, hint=hint)

    # -- steps -------------------------------------------------------------------------------
    def _first_step(self) -> float:
        s, stepper = self.state, self.stepper
        rhs = stepper.motion(s.t, 1.0, s.lam, s.lam)  # lambda held at lambda_0
        y0 = np.concatenate((s.q, s.qd, s.work))
        span = self.settings.t_end - s.t
        return initial_step(rhs, s.t, y0, stepper.derivative(s), self.tol, span)

    def _advance(self, h: float):
        """One accepted step from self.state; returns (outcome, next h)."""
        failures = 0
        while True:
            remaining = self.settings.t_end - self.state.t
            h = min(h, self.h_cap)
            h = remaining if h >= remaining - self.h_min else h
            try:
                outcome = self.stepper.step(self.state, h, self.history.predict(self.state.t + h))
            except PassFailure as failure:
                self.tally.failed += 1
                failures += 1
                if failures >= MAX_FAILURES or h / 4 < self.h_min:
                    raise self._solver_error(failure, self.state.t + h) from None
                self.h_cap = h / 2
                h /= 4
                continue
            err_ode, err_lam = self._errors(outcome, h)
            accepted = err_ode + err_lam <= 1.0
            fac = step_factor(err_lam, err_ode, accepted)
            if accepted:
                self.tally.accept(outcome.reports, h)
                self.h_cap = self.h_cap * CAP_RELAX if self.h_cap < 1e300 else np.inf
                return outcome, h * min(fac, convergence_factor(outcome.reports[0]))
            self.tally.rejected += 1
            h *= fac
            if h < self.h_min:
                raise SolverError(f"step size fell below {self.h_min:.1e} s", t=self.state.t,
                                  stage="step size", hint="the model may be stiff or "
                                  "discontinuous here; try a looser tol")

    def _errors(self, outcome, h: float) -> tuple[float, float]:
        """(err_ode, err_lam) in tolerance units (1 = at tolerance)."""
        rk = outcome.rk
        scale = weights(rk.y0, rk.y1, self.tol)
        err_ode = rms(rk.error, scale)
        nq = self.system.nq
        err_lam = interpolation_error(h, self.history, outcome.state.lam, outcome.jacobian,
                                      self.system.mass, scale[:nq]) * np.sqrt(nq / scale.size)
        if not np.isfinite(err_ode + err_lam):
            return np.inf, 0.0
        return err_ode, err_lam

    def _after_step(self, outcome) -> bool:
        """Record outputs, then look for events; True when the run stops."""
        start, new, nq = self.state, outcome.state, self.system.nq

        def dense(t):
            y = outcome.dense(t)
            return y[:nq], y[nq:2 * nq]

        hit = None
        if self.watch.events:
            hit = self.watch.first_crossing(start.t, new.t, new.q, new.qd, dense,
                                            self._lam_dict(new), self._multipliers_at(start, new))
        self._record_until(new.t if hit is None else hit[1], (start, new, outcome.dense))
        if hit is None:
            self.state = new
            self.history.add(new.t, new.lam)
            self._observe_loads(new)
            return False
        return self._fire(*hit)

    def _multipliers_at(self, start: State, end: State):
        """multipliers(t, q, qd) -> {row: lambda} inside the step start -> end, by the
        acceleration pass from the step's linear lambda (for events that watch multipliers)."""
        if not self.watch.needs_multipliers:
            return None
        names = self.constraints.names

        def multipliers(t, q, qd):
            guess = start.lam + (t - start.t) / (end.t - start.t) * (end.lam - start.lam)
            try:
                lam, _, _ = self.stepper.acceleration(q, qd, t, guess)
            except PassFailure as failure:
                raise self._solver_error(failure, t) from None
            return dict(zip(names, map(float, lam)))

        return multipliers

    def _record_until(self, t_until, step) -> None:
        """Record the output times up to t_until; `step` = (start, end, dense) or None."""
        cs, nq = self.constraints, self.system.nq
        for t in self.recorder.pending(t_until):
            if step is None:
                s = self.state
                self.recorder.record(t, s.q, s.qd, s.lam, s.work, cs)
                continue
            start, end, dense = step
            y = dense(t)
            lam = start.lam + (t - start.t) / (end.t - start.t) * (end.lam - start.lam)
            self.recorder.record(t, y[:nq], y[nq:2 * nq], lam, y[2 * nq:], cs)

    # -- events ------------------------------------------------------------------------------
    def _fire(self, k: int, t_event: float, side: float) -> bool:
        """Re-take the step to the crossing, call the callback, apply its response."""
        prior, event = self.state, self.watch.events[k]
        if t_event - prior.t > self.h_min:
            here, t_event = self._retake(prior, t_event, event)
        else:
            here = prior
        self.watch.hits[k] += 1
        self.tally.events += 1
        hit = EventHit(event.name, t_event, here.q.copy(), here.qd.copy(), here.lam.copy(),
                       self.constraints, self.system.module, self.system.p)
        response = (event.callback(hit) if event.callback else None) or EventResponse()
        stop = event.terminal if response.stop is None else response.stop
        data = dict(response.data)
        self._observe_loads(here)
        if stop:
            self._log(event.name, t_event, data, response)
            self.state = here
            self._record_until(t_event, None)
            if self.recorder.rows[-1][0] != t_event:
                self.recorder.record(t_event, here.q, here.qd, here.lam, here.work,
                                     self.constraints)
            return True
        self._apply(response, here, data)
        self._log(event.name, t_event, data, response)
        self._observe_loads(self.state)
        self.watch.reset(t_event, self.state.q, self.state.qd, fired=k, side=side,
                         lam=self._lam_dict(self.state))
        return False

    def _log(self, name: str, t: float, data: dict, response: EventResponse) -> None:
        """The event's record, or the records its response names instead."""
        if response.records is None:
            self.records.append(EventRecord(name, t, data))
        else:
            self.records += [EventRecord(n, t, d) for n, d in response.records]

    def _retake(self, prior: State, t_event: float, event) -> tuple[State, float]:
        """The step from `prior` re-taken to the crossing. The crossing was located on the
        dense output, which differs from a step's own end by the local error; so g at the
        re-taken end is driven to zero by up to REFINE_EVENT Newton corrections of the end
        time (g' from the re-taken step's interpolant), until they are below
        EVENT_TIME_TOL: the event time is then that of the integrated solution itself."""
        for attempt in range(REFINE_EVENT + 1):
            h = t_event - prior.t
            try:
                outcome = self.stepper.step(prior, h, self.history.predict(t_event))
            except PassFailure as failure:
                raise self._solver_error(failure, t_event) from None
            here = outcome.state
            if attempt == REFINE_EVENT:
                break
            g = self._event_value(event, here.t, here.q, here.qd, here.lam)
            nq, back = self.system.nq, here.t - EVENT_SLOPE_FRACTION * h
            y = outcome.dense(back)
            lam = prior.lam + (back - prior.t) / h * (here.lam - prior.lam)
            slope = (g - self._event_value(event, back, y[:nq], y[nq:2 * nq], lam)) / (
                EVENT_SLOPE_FRACTION * h)
            shift = -g / slope if slope else 0.0
            if not abs(shift) > EVENT_TIME_TOL or not prior.t + self.h_min < t_event + shift:
                break
            t_event += shift
        self.tally.accept(outcome.reports, t_event - prior.t)
        return here, t_event

    def _event_value(self, event, t, q, qd, lam) -> float:
        if event.multipliers:
            return float(event.function(t, q, qd, dict(zip(self.constraints.names, lam))))
        return float(event.function(t, q, qd))

    def _apply(self, response: EventResponse, here: State, data: dict) -> None:
        """New constraint set and state after an event; lambda restarts from pass 3."""
        self.stepper.constraints = self.constraints.without(response.remove).with_rows(
            response.add)
        q = here.q if response.q is None else np.array(response.q, dtype=float)
        qd = here.qd if response.qd is None else np.array(response.qd, dtype=float)
        if response.impact:
            cs, mass = self.constraints, self.system.mass
            try:
                qd_new, _, report = project_velocity(cs.jacobian(q, here.t), mass, qd,
                                                     cs.phi_t(q, here.t),
                                                     self.stepper.constraint_tol)
            except PassFailure as failure:
                raise self._solver_error(failure, here.t) from None
            self.tally.observe(report)
            kinetic = 0.5 * (qd @ (mass.matrix @ qd) - qd_new @ (mass.matrix @ qd_new))
            data["impact_energy_loss"] = float(kinetic)
            qd = qd_new
        self.state = self._restart(here.t, q, qd, here.work, "state after the event")
