"""Natural frequencies and mode shapes of the constrained mechanism, linearised at a state.

    from depsim.runtime.modes import modes_at
    found = modes_at(module, p, "deployed")      # or "t=12.5", a time in s
    print(found.table())

At a configuration q with the constraint rows A(q) (the model's rows Phi_q and a lock row
J_h, d theta_h / dq, for each hinge a latch, a stop, stick or a hold-down holds), the motion
near q obeys

    M dq'' + C dq' + K dq = 0,     A dq = 0,
    K = -d/dq (f(q) - A(q)^T lambda),   C = -d f / d qd,

lambda the multipliers that balance the applied forces, A^T lambda = f, so that the
constraint forces' own stiffness (a pendulum's, whose restoring force is its pivot's
reaction) is in K. A compliant latch in contact adds its stiffness k J_h^T J_h. With N a
basis of the null space of A (the motions the constraints allow), the undamped natural
frequencies and modes solve N^T K N v = omega^2 N^T M N v; a mode's coordinates are N v.
K and C come from central differences of the model's `force` and `phi_q_transpose_times`
(docs/modes.md); M is the model's constant mass matrix. Rigid motions of a free mechanism
have omega = 0; a negative frequency in the table is an unstable mode (omega^2 < 0, its
growth rate / 2 pi).

At "deployed" the run goes to its end, every hinge whose latch engaged is locked at its
latch angle (a compliant latch becomes a spring of its latch_stiffness about it), and the
configuration is the static equilibrium nearest the final state (Newton on f - A^T lambda = 0,
Phi = 0), the frequencies those of the deployed structure's small vibrations. At "t=T" the
configuration, the locks and the compliant contacts are the run's at T, and lambda balances
the forces there in the least-squares sense (`residual` says how far from an equilibrium the
state is: the frequencies of a mechanism in motion are those of its configuration frozen).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .interface import dense
from .output import atomic_path

FD_STEP = 1e-6  # central differences: step FD_STEP * max(1, |q_j|)
LOCK_KINDS = ("latch", "stop", "stick", "hold", "lock")  # the rows that lock a hinge
EQUILIBRIUM_STEPS = 30


@dataclass(frozen=True)
class Linearization:
    """What the frequencies are computed from: the configuration q, the hinges locked (by
    index, at their angles) and those sprung by a compliant latch (index, stiffness N*m/rad,
    angle rad), the time t (s) the loads are taken at."""

    q: np.ndarray
    t: float
    locks: tuple[tuple[int, float], ...] = ()
    springs: tuple[tuple[int, float, float], ...] = ()


@dataclass(frozen=True)
class Modes:
    """The natural frequencies (Hz, ascending; 0 for a rigid motion of a free mechanism,
    negative for an unstable mode) and mode shapes of a model at a state. `shapes` (n, NQ):
    each mode's coordinates, scaled so that its largest point displacement (a body's or
    particle's centre, a beam node) is 1 m, or its largest angle 1 rad when no point moves;
    `hinge_motion` (n, NH): the hinge angles' motion in that mode (rad)."""

    model: str
    at: str
    t: float
    q: np.ndarray
    frequencies: np.ndarray
    shapes: np.ndarray
    hinge_motion: np.ndarray
    coordinate_names: tuple[str, ...]
    hinge_names: tuple[str, ...]
    locked: tuple[str, ...]
    compliant: tuple[str, ...]
    degrees_of_freedom: int
    residual: float  # the largest out-of-balance generalized force at q (N or N*m)

    def table(self, count: int | None = None) -> str:
        """Lines for a terminal: the state, what is locked, and each mode's frequency with
        the hinges and points that move most in it."""
        lines = [f"{self.model}: natural frequencies at {self.at}",
                 f"  {self.degrees_of_freedom} degrees of freedom; locked: "
                 f"{', '.join(self.locked) or 'none'}"
                 + (f"; compliant latches as springs: {', '.join(self.compliant)}"
                    if self.compliant else ""),
                 f"  out-of-balance force at the state: {self.residual:.3g} (N or N*m)"]
        shown = range(len(self.frequencies) if count is None
                      else min(count, len(self.frequencies)))
        if not len(self.frequencies):
            lines.append("  no mode: the constraints hold every coordinate")
        for k in shown:
            lines.append(f"  mode {k + 1:>3}  {self.frequencies[k]:>12.6g} Hz   "
                         + _describe(self, k))
        return "\n".join(lines)

    def summary(self) -> dict:
        """JSON-ready: the state, the frequencies, each mode's hinge motion and coordinates."""
        return {"model": self.model, "at": self.at, "t": self.t,
                "degrees_of_freedom": self.degrees_of_freedom, "residual": self.residual,
                "locked": list(self.locked), "compliant": list(self.compliant),
                "frequencies_hz": [float(f) for f in self.frequencies],
                "modes": [{"frequency_hz": float(f),
                           "hinges_rad": dict(zip(self.hinge_names,
                                                  map(float, self.hinge_motion[k]))),
                           "coordinates": dict(zip(self.coordinate_names,
                                                   map(float, self.shapes[k])))}
                          for k, f in enumerate(self.frequencies)]}

    def to_json(self, path) -> None:
        with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8") as handle:
            handle.write(json.dumps(self.summary(), indent=2) + "\n")


def _describe(found: Modes, k: int) -> str:
    """"h2 12.3 deg, boom.n4 1 m": the hinges and the point that move most in mode k."""
    parts = []
    motion = found.hinge_motion[k]
    for i in np.argsort(-np.abs(motion))[:3]:
        if abs(motion[i]) > 1e-3 * max(1e-300, float(np.max(np.abs(motion)))) and \
                abs(motion[i]) > 1e-9:
            parts.append(f"{found.hinge_names[i]} {math.degrees(motion[i]):+.3g} deg")
    points = _point_motion(found.coordinate_names, found.shapes[k])
    if points:
        name, size = max(points.items(), key=lambda item: item[1])
        parts.append(f"{name} {size:.3g} m")
    return ", ".join(parts)


def _points(names: tuple[str, ...]) -> dict[str, tuple[int, int]]:
    """The coordinates (x, y) of each point that moves: a body's or particle's centre, a beam
    node (not a beam's slope coordinates)."""
    index = {name: i for i, name in enumerate(names)}
    found = {}
    for name, i in index.items():
        member, _, field = name.rpartition(".")
        if field == "x" and f"{member}.y" in index:
            found[member] = (i, index[f"{member}.y"])
    return found


def _point_motion(names, shape) -> dict[str, float]:
    return {member: float(math.hypot(shape[i], shape[j]))
            for member, (i, j) in _points(names).items()}


# ---- the linearisation ------------------------------------------------------------------------

class _System:
    """The model at parameters p, time t, with the locks and compliant springs of a
    Linearization: its constraint rows and the forces they balance."""

    def __init__(self, module, p, t: float, locks, springs):
        self.module, self.p, self.t = module, np.asarray(p, dtype=float), t
        self.locks, self.springs = tuple(locks), tuple(springs)
        self.nq, self.nc = module.NQ, module.NC
        self.mass = dense(module, "mass_matrix", self.p)

    def rows(self, q) -> np.ndarray:
        """A(q): the model's rows, then a lock row per locked hinge."""
        A = dense(self.module, "phi_q", q, self.t, self.p)
        if self.locks:
            J = dense(self.module, "hinge_jacobian", q, self.p)
            A = np.vstack([A, J[[k for k, _ in self.locks]]])
        return A

    def residuals(self, q) -> np.ndarray:
        """Phi(q) and each lock's theta - angle."""
        phi = np.asarray(self.module.phi(q, self.t, self.p), dtype=float)
        if not self.locks:
            return phi
        theta = np.asarray(self.module.hinge_angles(q, self.p), dtype=float)
        return np.concatenate([phi, [theta[k] - angle for k, angle in self.locks]])

    def applied(self, q, qd=None) -> np.ndarray:
        """f(q, qd) with the compliant latches' spring torques."""
        qd = np.zeros(self.nq) if qd is None else qd
        f = np.asarray(self.module.force(q, qd, self.t, self.p), dtype=float).copy()
        if self.springs:
            theta = np.asarray(self.module.hinge_angles(q, self.p), dtype=float)
            J = dense(self.module, "hinge_jacobian", q, self.p)
            for k, stiffness, angle in self.springs:
                f -= stiffness * (theta[k] - angle) * J[k]
        return f

    def balance(self, q, lam) -> np.ndarray:
        """f(q) - A(q)^T lambda: the out-of-balance generalized force."""
        model = np.asarray(self.module.phi_q_transpose_times(q, self.t, self.p, lam[:self.nc]),
                           dtype=float)
        out = self.applied(q) - model
        if self.locks:
            J = dense(self.module, "hinge_jacobian", q, self.p)
            out -= J[[k for k, _ in self.locks]].T @ lam[self.nc:]
        return out

    def multipliers(self, q) -> np.ndarray:
        """lambda with A^T lambda = f in the least-squares sense."""
        return np.linalg.lstsq(self.rows(q).T, self.applied(q), rcond=None)[0]

    def stiffness(self, q, lam) -> np.ndarray:
        """K = -d (f - A^T lambda) / dq at fixed lambda, by central differences."""
        return -_jacobian(lambda x: self.balance(x, lam), q)

    def damping(self, q) -> np.ndarray:
        """C = -d f / d qd at qd = 0."""
        return -_jacobian(lambda v: self.applied(q, v), np.zeros(self.nq))

    def equilibrium(self, q) -> tuple[np.ndarray, np.ndarray, bool]:
        """(q, lambda, converged): Newton on f - A^T lambda = 0, Phi = 0 from q, each step the
        least-squares solution (a free mechanism's rigid motions leave it singular)."""
        q = np.asarray(q, dtype=float).copy()
        lam = self.multipliers(q)
        scale = max(1.0, float(np.max(np.abs(self.applied(q)), initial=0.0)))
        for _ in range(EQUILIBRIUM_STEPS):
            balance, open_rows = self.balance(q, lam), self.residuals(q)
            if np.max(np.abs(balance), initial=0.0) <= 1e-10 * scale and \
                    np.max(np.abs(open_rows), initial=0.0) <= 1e-12:
                return q, lam, True
            A = self.rows(q)
            m = len(A)
            matrix = np.block([[-self.stiffness(q, lam), -A.T], [A, np.zeros((m, m))]])
            step = np.linalg.lstsq(matrix, -np.concatenate([balance, open_rows]), rcond=None)[0]
            q, lam = q + step[:self.nq], lam + step[self.nq:]
        return q, lam, False


def _jacobian(function, x) -> np.ndarray:
    """d function / d x by central differences, step FD_STEP max(1, |x_j|)."""
    x = np.asarray(x, dtype=float)
    columns = []
    for j in range(len(x)):
        step = FD_STEP * max(1.0, abs(x[j]))
        e = np.zeros_like(x)
        e[j] = step
        columns.append((function(x + e) - function(x - e)) / (2 * step))
    return np.array(columns).T if columns else np.zeros((0, 0))


def linearized_modes(module, p, state: Linearization, equilibrium: bool = False
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, int]:
    """(frequencies Hz, shapes (n, NQ), q, out-of-balance residual, degrees of freedom) of
    the module at `state`; `equilibrium`: first move q to the static equilibrium nearby."""
    system = _System(module, p, state.t, state.locks, state.springs)
    q = np.asarray(state.q, dtype=float)
    if equilibrium:
        found, lam, converged = system.equilibrium(q)
        q = found if converged else q
        lam = lam if converged else system.multipliers(q)
    else:
        lam = system.multipliers(q)
    residual = float(np.max(np.abs(system.balance(q, lam)), initial=0.0))
    A = system.rows(q)
    basis = scipy.linalg.null_space(A, rcond=1e-10) if len(A) else np.eye(system.nq)
    if basis.shape[1] == 0:
        return np.zeros(0), np.zeros((0, system.nq)), q, residual, 0
    K = system.stiffness(q, lam)
    Kr = basis.T @ K @ basis
    Kr = (Kr + Kr.T) / 2
    Mr = basis.T @ system.mass @ basis
    omega2, vectors = scipy.linalg.eigh(Kr, (Mr + Mr.T) / 2)
    scale = max(float(np.max(np.abs(omega2), initial=0.0)), 1e-300)
    omega2[np.abs(omega2) < 1e-11 * scale] = 0.0  # a rigid motion: the differences' noise
    frequencies = np.sign(omega2) * np.sqrt(np.abs(omega2)) / (2 * math.pi)
    shapes = (basis @ vectors).T
    return frequencies, _normalized(module, shapes), q, residual, basis.shape[1]


def _normalized(module, shapes: np.ndarray) -> np.ndarray:
    """Each shape scaled to a largest point displacement of 1 (else a largest coordinate of
    1), its largest coordinate positive."""
    points = list(_points(tuple(module.COORDINATES)).values())
    out = []
    for shape in shapes:
        sizes = [math.hypot(shape[i], shape[j]) for i, j in points]
        size = max(sizes, default=0.0)
        if size < 1e-9 * max(1e-300, float(np.max(np.abs(shape)))):
            size = float(np.max(np.abs(shape)))
        shape = shape / size if size > 0 else shape
        out.append(shape if shape[np.argmax(np.abs(shape))] >= 0 else -shape)
    return np.array(out).reshape(len(shapes), module.NQ)


def modes(module, p, state: Linearization, at: str, equilibrium: bool = False,
          count: int | None = None) -> Modes:
    """The Modes of `module` at `state` (described as `at`), the first `count` of them."""
    frequencies, shapes, q, residual, dof = linearized_modes(module, p, state, equilibrium)
    if count is not None:
        frequencies, shapes = frequencies[:count], shapes[:count]
    J = dense(module, "hinge_jacobian", q, np.asarray(p, dtype=float))
    hinges = tuple(module.HINGES)
    return Modes(str(module.MODEL_NAME), at, state.t, q, frequencies, shapes, shapes @ J.T,
                 tuple(module.COORDINATES), hinges,
                 tuple(hinges[k] for k, _ in state.locks),
                 tuple(hinges[k] for k, _, _ in state.springs), dof, residual)


# ---- the state of a run -----------------------------------------------------------------------

def state_of(result, module, row: int, compliant_engaged: bool = False) -> Linearization:
    """The configuration, locks and compliant contacts of `result` at output row `row`:
    each hinge an active lock row holds is locked at its angle there; a compliant latch in
    contact (its lock torque finite without a lock row), or every compliant latch that
    engaged when `compliant_engaged`, is a spring of its latch_stiffness about its latch."""
    hinges = tuple(module.HINGES)
    p = result.parameters
    q = result.q[row]
    theta = np.asarray(module.hinge_angles(q, p), dtype=float)
    locked = []
    for name, value in zip(result.constraint_names, result.lam[row]):
        hinge, _, kind = name.rpartition(".")
        if kind in LOCK_KINDS and hinge in hinges and np.isfinite(value) and \
                name not in module.CONSTRAINTS:
            k = hinges.index(hinge)
            if k not in [i for i, _ in locked]:
                locked.append((k, float(theta[k])))
    columns = tuple(module.HINGE_PROPERTIES)
    properties = np.asarray(module.hinge_properties(p), dtype=float).reshape(len(hinges),
                                                                             len(columns))
    engaged = {e.hinge for e in result.events if e.kind == "latch" and e.t <= result.times[row]}
    springs = []
    for k, hinge in enumerate(hinges):
        stiffness = properties[k, columns.index("latch_stiffness")]
        if not np.isfinite(stiffness) or k in [i for i, _ in locked]:
            continue
        in_contact = np.isfinite(result.hinge_torque[row, k])
        if in_contact or (compliant_engaged and hinge in engaged):
            springs.append((k, float(stiffness), float(properties[k, columns.index("latch")])))
    return Linearization(q, float(result.times[row]), tuple(sorted(locked)), tuple(springs))


def deployed_state(result, module) -> Linearization:
    """The deployed state: the final configuration with every hinge whose latch engaged
    locked at its latch angle (a compliant one sprung about it), other locks as at the end."""
    last = len(result.times) - 1
    state = state_of(result, module, last, compliant_engaged=True)
    hinges = tuple(module.HINGES)
    columns = tuple(module.HINGE_PROPERTIES)
    properties = np.asarray(module.hinge_properties(result.parameters),
                            dtype=float).reshape(len(hinges), len(columns))
    column = columns.index("latch")
    latched = {hinges.index(e.hinge) for e in result.events if e.kind == "latch"}
    sprung = {k for k, _, _ in state.springs}
    locks = [(k, float(properties[k, column]) if k in latched else angle)
             for k, angle in state.locks if k not in sprung]
    return Linearization(state.q, state.t, tuple(locks), state.springs)
