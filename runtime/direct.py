"""`simulate_direct`: a conventional solver, kept only as an independent cross-check.

Every evaluation factorises the augmented system (LU, numpy.linalg.solve)

    [ M      Phi_q^T ] [ qdd    ]   [ f                                          ]
    [ Phi_q  0       ] [ lambda ] = [ gamma - 2 a (Phi_q qd + Phi_t) - b^2 Phi   ]

with Baumgarte stabilisation (a = b = BAUMGARTE, 1/s), and scipy's DOP853 integrates the
index-1 equations. Nothing here is shared with the iterative method except the generated
module, the constraint rows and the result assembly. Events are located by solve_ivp.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from .constraints import ConstraintSet, check_consistency
from .errors import SolverError
from .events import EventHit, EventResponse
from .progress import Progress
from .recording import Recorder
from .results import EventRecord, Result
from .system import System, resolve_settings
from .tally import Tally

BAUMGARTE = 10.0  # 1/s
MUTE = 1e-9  # s: a fired event is not re-detected this soon after its crossing


def simulate_direct(module, params: np.ndarray | None = None, t_end: float | None = None,
                    dt_out: float | None = None, tol: float | None = None, events=(),
                    progress: bool = False) -> Result:
    """Same interface and Result as `simulate`, solved by factorising the augmented system
    at every evaluation (see module docstring). For cross-checks and benchmarks."""
    settings = resolve_settings(module, params, t_end, dt_out, tol)
    return DirectRun(module, settings, events, progress).run()


class DirectRun:
    def __init__(self, module, settings, events=(), progress=False):
        self.system = System(module, settings.params)
        self.settings = settings
        self.constraints = ConstraintSet(self.system)
        self.recorder = Recorder(self.system, settings, "direct")
        self.events = tuple(events)
        self.hits = [0] * len(self.events)
        self.tally = Tally()
        self.records: list[EventRecord] = []
        self.progress = Progress(settings.t_end, progress)
        self.evaluations = 0

    def solve(self, q, qd, t):
        """(qdd (NQ,), lambda (nc,)) from the factorised augmented system."""
        cs, system = self.constraints, self.system
        nq, nc = system.nq, cs.nc
        J = cs.jacobian(q, t)
        drift = J @ qd + cs.phi_t(q, t)
        K = np.zeros((nq + nc, nq + nc))
        K[:nq, :nq] = system.mass.matrix
        K[:nq, nq:] = J.T
        K[nq:, :nq] = J
        b = np.concatenate((system.force(q, qd, t), cs.gamma(q, qd, t)
                            - 2 * BAUMGARTE * drift - BAUMGARTE ** 2 * cs.phi(q, t)))
        self.tally.factorizations += 1
        try:
            x = np.linalg.solve(K, b)
        except np.linalg.LinAlgError:
            raise SolverError("the augmented matrix [[M, Phi_q^T], [Phi_q, 0]] is singular",
                              t=t, stage="direct solve", hint="Phi_q has dependent rows "
                              "(a redundant joint or a singular configuration)") from None
        return x[:nq], x[nq:]

    def rhs(self, t, y):
        nq = self.system.nq
        self.evaluations += 1
        q, qd = y[:nq], y[nq:2 * nq]
        qdd, _ = self.solve(q, qd, t)
        return np.concatenate((qd, qdd, self.system.dissipation(q, qd, t)))

    def run(self) -> Result:
        system, nq, tol = self.system, self.system.nq, self.settings.tol
        q, qd = (np.array(v, dtype=float) for v in system.module.initial_state(system.p))
        check_consistency(self.constraints, 0.0, q, qd, tol, "initial state")
        t, y = 0.0, np.concatenate((q, qd, np.zeros(system.nd)))
        muted = (None, 0.0, 0.0)
        try:
            while True:
                sol = self._segment(t, y, muted)
                self._record(sol)
                if sol.status != 1:
                    break
                k = next(i for i, times in enumerate(sol.t_events) if len(times))
                t, y = float(sol.t[-1]), sol.y[:, -1].copy()
                g_before = self.events[k].function(sol.t[-2], sol.y[:nq, -2],
                                                   sol.y[nq:2 * nq, -2])
                stop, y = self._fire(k, t, y)
                if stop:
                    if self.recorder.rows[-1][0] != t:
                        self._record_row(t, y)
                    break
                muted = (k, t, -float(np.sign(g_before)))
                self.progress.update(t)
        finally:
            self.progress.close()
        stats = self.tally.stats(0, self.evaluations)
        return self.recorder.result(stats, self.records)

    def _segment(self, t, y, muted):
        """Integrate from (t, y) to t_end or the first armed event."""
        functions = [self._event_function(k, muted) for k, e in enumerate(self.events)
                     if e.max_hits is None or self.hits[k] < e.max_hits]
        sol = solve_ivp(self.rhs, (t, self.settings.t_end), y, method="DOP853",
                        rtol=self.settings.tol, atol=self.settings.tol, dense_output=True,
                        events=functions or None)
        if sol.status == -1:
            raise SolverError(f"scipy solve_ivp failed: {sol.message}", t=float(sol.t[-1]),
                              stage="direct solve")
        if functions:  # map the armed events' roots back to all events
            armed = [k for k, e in enumerate(self.events)
                     if e.max_hits is None or self.hits[k] < e.max_hits]
            roots = [np.empty(0)] * len(self.events)
            for k, times in zip(armed, sol.t_events):
                roots[k] = times
            sol.t_events = roots
        else:
            sol.t_events = [np.empty(0)] * len(self.events)
        self._observe_steps(sol)
        return sol

    def _event_function(self, k, muted):
        event, nq = self.events[k], self.system.nq
        mute_k, t_mute, side = muted

        def g(t, y):
            if k == mute_k and t <= t_mute + MUTE:
                return side
            return float(event.function(t, y[:nq], y[nq:2 * nq]))

        g.terminal = True
        g.direction = event.direction
        return g

    def _observe_steps(self, sol) -> None:
        """Count steps and the constraint residuals at the step points."""
        cs, nq = self.constraints, self.system.nq
        for j in range(1, len(sol.t)):
            t, q, qd = sol.t[j], sol.y[:nq, j], sol.y[nq:2 * nq, j]
            qdd, _ = self.solve(q, qd, t)
            J = cs.jacobian(q, t)
            self.tally.residuals["position"] = max(self.tally.residuals["position"],
                                                   float(np.max(np.abs(cs.phi(q, t)), initial=0)))
            for level, v in (("velocity", cs.v_vel(q, qd, t, J)),
                             ("acceleration", cs.v_acc(q, qd, qdd, t, J))):
                self.tally.residuals[level] = max(self.tally.residuals[level],
                                                  float(np.max(np.abs(v), initial=0.0)))
            self.tally.accepted += 1
            h = sol.t[j] - sol.t[j - 1]
            self.tally.min_step = min(self.tally.min_step, h)
            self.tally.max_step = max(self.tally.max_step, h)

    def _record(self, sol) -> None:
        for t in self.recorder.pending(float(sol.t[-1])):
            self._record_row(t, sol.sol(t))

    def _record_row(self, t, y) -> None:
        nq = self.system.nq
        q, qd = y[:nq], y[nq:2 * nq]
        _, lam = self.solve(q, qd, t)
        self.recorder.record(t, q, qd, lam, y[2 * nq:], self.constraints)

    def _fire(self, k, t, y):
        """Call event k's callback at (t, y); returns (stop, new y)."""
        event, system, nq = self.events[k], self.system, self.system.nq
        self.hits[k] += 1
        self.tally.events += 1
        q, qd = y[:nq].copy(), y[nq:2 * nq].copy()
        _, lam = self.solve(q, qd, t)
        hit = EventHit(event.name, t, q, qd, lam, self.constraints, system.module, system.p)
        response = (event.callback(hit) if event.callback else None) or EventResponse()
        stop = event.terminal if response.stop is None else response.stop
        data = dict(response.data)
        if not stop:
            self.constraints = self.constraints.without(response.remove).with_rows(response.add)
            q = q if response.q is None else np.array(response.q, dtype=float)
            qd = qd if response.qd is None else np.array(response.qd, dtype=float)
            if response.impact:
                qd_new = self._impact(q, qd, t)
                M = system.mass.matrix
                data["impact_energy_loss"] = float(0.5 * (qd @ M @ qd - qd_new @ M @ qd_new))
                qd = qd_new
            check_consistency(self.constraints, t, q, qd, self.settings.tol,
                              "state after the event")
            y = np.concatenate((q, qd, y[2 * nq:]))
        self.records.append(EventRecord(event.name, t, data))
        return stop, y

    def _impact(self, q, qd, t):
        """Plastic impact by the factorised system: M qd+ + J^T mu = M qd, J qd+ = -Phi_t."""
        cs, system = self.constraints, self.system
        nq, nc = system.nq, cs.nc
        J = cs.jacobian(q, t)
        K = np.zeros((nq + nc, nq + nc))
        K[:nq, :nq] = system.mass.matrix
        K[:nq, nq:] = J.T
        K[nq:, :nq] = J
        b = np.concatenate((system.mass.matrix @ qd, -cs.phi_t(q, t)))
        self.tally.factorizations += 1
        return np.linalg.solve(K, b)[:nq]
