"""Constraint rows an event callback may add (`HingeLock`, `LinearConstraint`), and the set of
active rows it sees (`ConstraintSet`): the module's rows, then the added ones.

The integrator core holds and applies the rows (runtime/c); these classes describe them to
it and let a callback evaluate them: Phi, Phi_q, Phi_t and gamma (the right side of
Phi_q qdd = gamma) with the generated module's argument order.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .interface import dense


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
    absolute coordinates)."""

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
        return dense(self.module, "hinge_jacobian", q, p)[self._index]

    def phi_t(self, q, t, p):
        return 0.0

    def gamma(self, q, qd, t, p):
        return float(self.module.hinge_gamma(q, qd, p)[self._index])


class ConstraintSet:
    """The module's NC rows followed by the added rows, in order, for parameters p: what an
    event callback sees as `hit.constraints`.

    `names[i]` is the row name ("h1.x", "pivot.lock"), `joints[i]` its joint.
    """

    def __init__(self, module, p, added=()):
        self.module = module
        self.p = np.asarray(p, dtype=float)
        self.added = tuple(added)
        self.nq = int(module.NQ)
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
        return ConstraintSet(self.module, self.p, self.added + tuple(rows))

    def without(self, names) -> ConstraintSet:
        """A new set without the added rows named in `names` (module rows stay)."""
        names = set(names)
        return ConstraintSet(self.module, self.p,
                             tuple(r for r in self.added if r.name not in names))

    def _extra(self, method, *args):
        return np.array([getattr(r, method)(*args, self.p) for r in self.added], dtype=float)

    def phi(self, q, t) -> np.ndarray:
        """Phi(q, t), shape (nc,)."""
        base = self.module.phi(q, t, self.p)
        return np.concatenate((base, self._extra("phi", q, t))) if self.added else base

    def jacobian(self, q, t) -> np.ndarray:
        """Phi_q, dense (nc, NQ)."""
        J = np.zeros((self.nc, self.nq))
        J[self._rows, self._cols] = self.module.phi_q(q, t, self.p)
        for i, r in enumerate(self.added):
            J[self.nc_module + i] = r.jacobian(q, t, self.p)
        return J

    def phi_t(self, q, t) -> np.ndarray:
        """dPhi/dt, shape (nc,)."""
        base = self.module.phi_t(q, t, self.p)
        return np.concatenate((base, self._extra("phi_t", q, t))) if self.added else base

    def gamma(self, q, qd, t) -> np.ndarray:
        """Right-hand side of (2c), shape (nc,)."""
        base = self.module.gamma(q, qd, t, self.p)
        return np.concatenate((base, self._extra("gamma", q, qd, t))) if self.added else base

    def describe(self, row: int) -> tuple[str, str]:
        """(joint text, row name) for messages, e.g. ("hinge h3", "h3.x")."""
        joint = self.joints[row]
        if row >= self.nc_module:
            kind = "lock"
        else:
            kind = ("slider" if joint in self.module.SLIDERS else  # (some also in HINGES)
                    "hinge" if joint in self.module.HINGES else "joint")
        return f"{kind} {joint}", self.names[row]
