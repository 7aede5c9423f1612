"""The active constraint set: the module's rows plus rows added at run time (latches, locks).

Every level of the constraint error is computed here, for whatever rows are active:

    v_pos = -Phi(q, t)                                (m or rad per row)
    v_vel = -Phi_q qd - Phi_t                         (per second)
    v_acc = gamma(q, qd, t) - Phi_q qdd               (per second squared)

A row added at run time is an `AddedConstraint`: anything with `name`, `joint` and the four
functions `phi`, `jacobian`, `phi_t`, `gamma` with the generated module's argument order.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import SolverError

CONSISTENCY = 1e3  # a (re)start state may violate its constraints by this many tolerances


@dataclass(frozen=True)
class LinearConstraint:
    """A row linear in q: Phi = row . q - value, with constant Jacobian `row` (NQ,)."""

    name: str
    joint: str
    row: np.ndarray
    value: float

    def phi(self, q, t, p):
        return float(self.row @ q - self.value)

    def jacobian(self, q, t, p):
        return self.row

    def phi_t(self, q, t, p):
        return 0.0

    def gamma(self, q, qd, t, p):
        return 0.0


@dataclass(frozen=True)
class HingeLock:
    """Hinge `hinge` held at `angle` (rad): Phi = theta_k(q) - angle, Jacobian from the module's
    `hinge_jacobian`, gamma = -(J qd)_q qd from its `hinge_gamma` (zero for rigid bodies in
    absolute coordinates); a module without `hinge_gamma` gets a central difference of the
    Jacobian along qd."""

    module: object
    hinge: str
    angle: float
    name: str = ""
    joint: str = ""
    _index: int = field(default=-1, repr=False)

    def __post_init__(self):
        hinges = tuple(self.module.HINGES)
        if self.hinge not in hinges:
            raise ValueError(f"unknown hinge '{self.hinge}' (hinges: {', '.join(hinges)})")
        object.__setattr__(self, "_index", hinges.index(self.hinge))
        object.__setattr__(self, "name", self.name or f"{self.hinge}.lock")
        object.__setattr__(self, "joint", self.joint or self.hinge)

    def phi(self, q, t, p):
        return float(self.module.hinge_angles(q, p)[self._index] - self.angle)

    def jacobian(self, q, t, p):
        return np.asarray(self.module.hinge_jacobian(q, p), dtype=float)[self._index]

    def phi_t(self, q, t, p):
        return 0.0

    def gamma(self, q, qd, t, p):
        if hasattr(self.module, "hinge_gamma"):
            return float(self.module.hinge_gamma(q, qd, p)[self._index])
        speed = float(np.max(np.abs(qd)))
        if speed == 0.0:
            return 0.0
        eps = 1e-6 / speed
        ahead = self.jacobian(q + eps * qd, t, p)
        behind = self.jacobian(q - eps * qd, t, p)
        return -float((ahead - behind) @ qd) / (2 * eps)


class ConstraintSet:
    """The module's NC rows followed by the added rows, in order.

    `names[i]` is the row name ("h1.x", "pivot.lock"), `joints[i]` its joint.
    """

    def __init__(self, system, added=()):
        self.system = system
        module = system.module
        self.added = tuple(added)
        self.nc_module = int(module.NC)
        self.names = tuple(module.CONSTRAINTS) + tuple(r.name for r in self.added)
        self.joints = tuple(module.CONSTRAINT_JOINTS) + tuple(r.joint for r in self.added)
        self.nc = len(self.names)
        self._rows = np.asarray(module.PHI_Q_ROWS, dtype=int)
        self._cols = np.asarray(module.PHI_Q_COLS, dtype=int)
        duplicate = {n for n in self.names if self.names.count(n) > 1}
        if duplicate:
            raise ValueError(f"constraint rows named twice: {', '.join(sorted(duplicate))}")

    def with_rows(self, rows) -> ConstraintSet:
        """A new set with `rows` appended."""
        return ConstraintSet(self.system, self.added + tuple(rows))

    def without(self, names) -> ConstraintSet:
        """A new set without the added rows named in `names` (module rows stay)."""
        names = set(names)
        return ConstraintSet(self.system, tuple(r for r in self.added if r.name not in names))

    def _extra(self, method, *args):
        p = self.system.p
        return np.array([getattr(r, method)(*args, p) for r in self.added], dtype=float)

    def phi(self, q, t) -> np.ndarray:
        """Phi(q, t), shape (nc,)."""
        base = self.system.module.phi(q, t, self.system.p)
        return np.concatenate((base, self._extra("phi", q, t))) if self.added else base

    def jacobian(self, q, t) -> np.ndarray:
        """Phi_q, dense (nc, NQ)."""
        J = np.zeros((self.nc, self.system.nq))
        J[self._rows, self._cols] = self.system.module.phi_q(q, t, self.system.p)
        for i, r in enumerate(self.added):
            J[self.nc_module + i] = r.jacobian(q, t, self.system.p)
        return J

    def jacobian_transpose_times(self, q, t, lam) -> np.ndarray:
        """Phi_q^T lam (NQ,) without forming Phi_q."""
        values = self.system.module.phi_q(q, t, self.system.p)
        out = np.bincount(self._cols, weights=values * lam[self._rows],
                          minlength=self.system.nq)
        for i, r in enumerate(self.added):
            out += r.jacobian(q, t, self.system.p) * lam[self.nc_module + i]
        return out

    def phi_t(self, q, t) -> np.ndarray:
        """dPhi/dt, shape (nc,)."""
        base = self.system.module.phi_t(q, t, self.system.p)
        return np.concatenate((base, self._extra("phi_t", q, t))) if self.added else base

    def gamma(self, q, qd, t) -> np.ndarray:
        """Right-hand side of (2c), shape (nc,)."""
        base = self.system.module.gamma(q, qd, t, self.system.p)
        return np.concatenate((base, self._extra("gamma", q, qd, t))) if self.added else base

    def v_pos(self, q, t):
        return -self.phi(q, t)

    def v_vel(self, q, qd, t, J=None):
        J = self.jacobian(q, t) if J is None else J
        return -(J @ qd) - self.phi_t(q, t)

    def v_acc(self, q, qd, qdd, t, J=None):
        J = self.jacobian(q, t) if J is None else J
        return self.gamma(q, qd, t) - J @ qdd

    def describe(self, row: int) -> tuple[str, str]:
        """(joint text, row name) for messages, e.g. ("hinge h3", "h3.x")."""
        joint = self.joints[row]
        kind = "lock" if row >= self.nc_module else self.system.joint_kind(joint)
        return f"{kind} {joint}", self.names[row]


def check_consistency(cs: ConstraintSet, t: float, q, qd, tol: float, stage: str) -> None:
    """Raise SolverError naming the worst joint when (q, qd) at t violates (2a) or (2b) by
    more than CONSISTENCY * tol (relative to max|q|, max|qd| when those exceed 1)."""
    J = cs.jacobian(q, t)
    levels = (("position", -cs.phi(q, t), q, "Phi"),
              ("velocity", cs.v_vel(q, qd, t, J), qd, "Phi_q qd + Phi_t"))
    for level, v, values, quantity in levels:
        limit = CONSISTENCY * tol * max(1.0, float(np.max(np.abs(values))))
        if v.size and not np.max(np.abs(v)) <= limit:
            row = int(np.nanargmax(np.abs(v)))
            joint, name = cs.describe(row)
            hint = ("check the initial angles and rates of the joints in this joint's closed "
                    "loop" if stage == "initial state" else
                    "an event callback must leave a state on the new constraints "
                    "(impact=True makes the velocity jump)")
            raise SolverError(f"the {stage} violates the {level} constraint: "
                              f"|{quantity}| = {abs(v[row]):.3g} > {limit:.1g}", t=t,
                              stage=stage, row=name, joint=joint, residual=float(abs(v[row])),
                              hint=hint)
