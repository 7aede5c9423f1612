"""An independent reference for the tests and benchmarks: a conventional DAE solver.

Every evaluation factorises the augmented system (LU, numpy.linalg.solve)

    [ M      Phi_q^T ] [ qdd    ]   [ f + J_h^T tau                              ]
    [ Phi_q  0       ] [ lambda ] = [ gamma - 2 a (Phi_q qd + Phi_t) - b^2 Phi   ]

with Baumgarte stabilisation (a = b = BAUMGARTE, 1/s), and scipy's DOP853 (or, for stiff
models such as fine beams, the implicit Radau IIA of order 5) integrates the index-1 equations. It shares nothing with the integrator core but the generated model
functions: tau is each hinge's friction by the regularised law -friction tanh(rate /
slip_rate), written here again from docs/deployment.md (no latches, stops or stick-slip).
Events are located by solve_ivp; a callback may add rows and ask for a plastic impact
(solved here by the factorised system M qd+ + J^T mu = M qd, J qd+ = -Phi_t).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from depsim.runtime import ConstraintSet, EventHit, EventResponse
from depsim.runtime.interface import dense
from depsim.runtime.interface import initial_state

BAUMGARTE = 10.0  # 1/s
MUTE = 1e-9  # s: a fired event is not re-detected this soon after its crossing


@dataclass
class DirectEvent:
    name: str
    t: float
    data: dict


@dataclass
class DirectSolution:
    """The reference solution at the output times (the core's: 0, dt_out, ..., t_end)."""

    times: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    lam: np.ndarray  # the model's rows only
    outputs: np.ndarray
    events: list[DirectEvent] = field(default_factory=list)
    evaluations: int = 0
    steps: int = 0


def output_times(t_end: float, dt_out: float) -> np.ndarray:
    """0, dt_out, 2 dt_out, ... up to t_end, with t_end itself always last (s)."""
    count = int(np.floor(t_end / dt_out * (1 + 1e-12)))
    times = np.arange(count + 1) * dt_out
    if t_end - times[-1] > 1e-9 * dt_out:
        return np.append(times, t_end)
    times[-1] = t_end
    return times


class DirectSolver:
    """One run of the reference solver (see the module docstring)."""

    def __init__(self, module, params=None, tol=None):
        self.module = module
        self.p = np.array(module.PARAMETER_DEFAULTS if params is None else params, dtype=float)
        self.tol = float(module.TOL if tol is None else tol)
        self.mass = dense(module, "mass_matrix", self.p)
        self.constraints = ConstraintSet(module, self.p)
        table = np.asarray(module.hinge_properties(self.p), dtype=float).reshape(
            len(module.HINGES), len(module.HINGE_PROPERTIES))
        column = list(module.HINGE_PROPERTIES)
        self.friction = np.nan_to_num(table[:, column.index("friction")])
        self.slip_rate = table[:, column.index("slip_rate")]
        self.evaluations = 0

    def force(self, q, qd, t) -> np.ndarray:
        f = np.asarray(self.module.force(q, qd, t, self.p), dtype=float)
        if not np.any(self.friction):
            return f
        rates = np.asarray(self.module.hinge_rates(q, qd, self.p), dtype=float)
        tau = -self.friction * np.tanh(rates / np.where(self.friction > 0, self.slip_rate, 1))
        return f + dense(self.module, "hinge_jacobian", q, self.p).T @ tau

    def augmented(self, q, t) -> tuple[np.ndarray, np.ndarray]:
        cs, nq = self.constraints, len(q)
        J = cs.jacobian(q, t)
        K = np.zeros((nq + cs.nc, nq + cs.nc))
        K[:nq, :nq], K[:nq, nq:], K[nq:, :nq] = self.mass, J.T, J
        return K, J

    def solve(self, q, qd, t) -> tuple[np.ndarray, np.ndarray]:
        """(qdd, lambda) from the factorised augmented system."""
        cs, nq = self.constraints, len(q)
        self.evaluations += 1
        K, J = self.augmented(q, t)
        drift = J @ qd + cs.phi_t(q, t)
        b = np.concatenate((self.force(q, qd, t), cs.gamma(q, qd, t)
                            - 2 * BAUMGARTE * drift - BAUMGARTE ** 2 * cs.phi(q, t)))
        x = np.linalg.solve(K, b)
        return x[:nq], x[nq:]

    def impact(self, q, qd, t) -> np.ndarray:
        K, _ = self.augmented(q, t)
        b = np.concatenate((self.mass @ qd, -self.constraints.phi_t(q, t)))
        return np.linalg.solve(K, b)[:len(q)]


def solve_direct(module, params=None, t_end=None, dt_out=None, tol=None, events=(),
                 method="DOP853", rate_tol=None) -> DirectSolution:
    """The reference solution of `module` (see the module docstring); rate_tol: the absolute
    tolerance of the velocities, if not tol."""
    solver = DirectSolver(module, params, tol)
    t_end = float(module.T_END if t_end is None else t_end)
    times = output_times(t_end, float(module.DT_OUT if dt_out is None else dt_out))
    nq, events = int(module.NQ), tuple(events)
    q, qd = (np.array(v, dtype=float) for v in initial_state(module, solver.p))
    rows, found, hits, steps = [], [], [0] * len(events), 0
    t, y, muted = 0.0, np.concatenate((q, qd)), (None, 0.0, 0.0)

    def rhs(time, state):
        qdd, _ = solver.solve(state[:nq], state[nq:], time)
        return np.concatenate((state[nq:], qdd))

    while True:
        armed = [k for k, e in enumerate(events) if e.max_hits is None or hits[k] < e.max_hits]
        functions = [_event_function(events[k], k, muted, nq) for k in armed]
        atol = np.concatenate((np.full(nq, solver.tol), np.full(nq, rate_tol or solver.tol)))
        sol = solve_ivp(rhs, (t, t_end), y, method=method, rtol=solver.tol, atol=atol,
                        dense_output=True, events=functions or None)
        steps += len(sol.t) - 1
        while len(rows) < len(times) and times[len(rows)] <= sol.t[-1] + 1e-12 * t_end:
            time = times[len(rows)]
            state = sol.sol(time)
            rows.append((time, state, solver.solve(state[:nq], state[nq:], time)[1]))
        if sol.status != 1:
            break
        k = armed[next(i for i, hit in enumerate(sol.t_events) if len(hit))]
        t, y = float(sol.t[-1]), sol.y[:, -1].copy()
        g_before = events[k].function(sol.t[-2], sol.y[:nq, -2], sol.y[nq:, -2])
        hits[k] += 1
        stop, y, data = _fire(solver, events[k], t, y)
        found.append(DirectEvent(events[k].name, t, data))
        if stop:
            break
        muted = (k, t, -float(np.sign(g_before)))
    n_model = int(module.NC)
    return DirectSolution(
        times=np.array([r[0] for r in rows]), q=np.array([r[1][:nq] for r in rows]),
        qd=np.array([r[1][nq:] for r in rows]), lam=np.array([r[2][:n_model] for r in rows]),
        outputs=np.array([module.outputs(r[1][:nq], r[1][nq:], r[0], solver.p, r[2][:n_model],
                                          np.zeros(len(module.RUN_VALUES))) for r in rows]),
        events=found, evaluations=solver.evaluations, steps=steps)


def _event_function(event, k, muted, nq):
    mute_k, t_mute, side = muted

    def g(t, y):
        if k == mute_k and t <= t_mute + MUTE:
            return side
        return float(event.function(t, y[:nq], y[nq:]))

    g.terminal = True
    g.direction = event.direction
    return g


def _fire(solver: DirectSolver, event, t, y):
    """Call the event's callback at (t, y): (stop, new y, record data)."""
    nq = len(y) // 2
    q, qd = y[:nq].copy(), y[nq:].copy()
    _, lam = solver.solve(q, qd, t)
    hit = EventHit(event.name, t, q, qd, lam, solver.constraints, solver.module, solver.p)
    response = (event.callback(hit) if event.callback else None) or EventResponse()
    stop = event.terminal if response.stop is None else response.stop
    data = dict(response.data)
    if not stop:
        solver.constraints = solver.constraints.without(response.remove).with_rows(response.add)
        q = q if response.q is None else np.array(response.q, dtype=float)
        qd = qd if response.qd is None else np.array(response.qd, dtype=float)
        if response.impact:
            after = solver.impact(q, qd, t)
            data["impact_energy_loss"] = float(0.5 * (qd @ solver.mass @ qd
                                                      - after @ solver.mass @ after))
            qd = after
        y = np.concatenate((q, qd))
    return stop, y, data
