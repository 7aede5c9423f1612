"""Hinge reaction loads from the Lagrange multipliers, and the deployment summary of a run.

Sign conventions (docs/deployment.md, section 5). A generated module's hinge rows are
"<h>.x", "<h>.y" = r_a - r_b (a, b the members in the order the hinge joins them). With
M qdd = f - Phi_q^T lambda, the row's force on member b is +lambda and on member a -lambda, so

    F_h = (lambda_<h>.x, lambda_<h>.y)     force on member b from member a, world frame (N)

A lock row theta_h - c = 0 (rows "<h>.latch", "<h>.stop", "<h>.stick", "<h>.lock") applies the
generalized force -J_h^T lambda, i.e. the torque

    T_h = -lambda_lock                     on member b, positive in the sense of theta_h (N m)

(and -T_h on member a). A compliant latch's spring torque is reported the same way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

LOCK_ROWS = ("latch", "stop", "stick", "lock")  # "<h>.<kind>" rows that hold a hinge angle


@dataclass(frozen=True, slots=True)
class HingeLoad:
    """One hinge's loads at the output times (n,): the force on member b from member a in the
    world frame (N) and its magnitude, and the lock torque on member b (N m, NaN while nothing
    holds the hinge angle)."""

    force_x: np.ndarray
    force_y: np.ndarray
    force: np.ndarray
    torque: np.ndarray


@dataclass(frozen=True, slots=True)
class PeakLoad:
    """Largest hinge force magnitude (N) and lock torque magnitude (N m) over the run, with the
    times (s) they occurred; torque 0 / time NaN when the hinge was never locked."""

    force: float
    t_force: float
    torque: float
    t_torque: float


@dataclass(frozen=True, slots=True)
class LatchRecord:
    """A latch that engaged: hinge, time (s), hinge rate just before (rad/s), the angular
    impulse the latch applied to member b (N m s; None for a compliant latch), the kinetic
    energy the plastic impact removed (J; None for a compliant latch) and whether it is rigid."""

    hinge: str
    t: float
    rate: float
    impulse: float | None
    energy_loss: float | None
    rigid: bool


@dataclass(frozen=True, slots=True)
class Deployment:
    """What a mechanism engineer asks first. `deployed` is None when the model has no latch;
    `time` (s) is when the last latch engaged (None unless deployed); energies in J."""

    latch_hinges: tuple[str, ...]
    latches: tuple[LatchRecord, ...]
    deployed: bool | None
    time: float | None
    friction_energy: float
    impact_energy: float


def reaction_rows(hinges, names) -> list[tuple[int, int]]:
    """Column indices of "<h>.x", "<h>.y" in `names` for each hinge (-1 when absent)."""
    index = {name: i for i, name in enumerate(names)}
    return [(index.get(f"{h}.x", -1), index.get(f"{h}.y", -1)) for h in hinges]


def hinge_forces(hinges, names, lam: np.ndarray) -> np.ndarray:
    """Hinge forces (..., NH, 2) on member b from member a (N) from multipliers lam (..., rows)
    named `names`; NaN where a row is missing or inactive."""
    lam = np.asarray(lam, dtype=float)
    out = np.full(lam.shape[:-1] + (len(hinges), 2), np.nan)
    for k, (ix, iy) in enumerate(reaction_rows(hinges, names)):
        if ix >= 0 and iy >= 0:
            out[..., k, 0] = lam[..., ix]
            out[..., k, 1] = lam[..., iy]
    return out


def lock_torques(hinges, names, lam) -> np.ndarray:
    """Torque T_h = -lambda of each hinge's active lock row (NH,), NaN where none is active.
    `names` and `lam` are the active rows and their multipliers."""
    values = dict(zip(names, lam))
    out = np.full(len(hinges), np.nan)
    for k, h in enumerate(hinges):
        for kind in LOCK_ROWS:
            value = values.get(f"{h}.{kind}")
            if value is not None and np.isfinite(value):
                out[k] = -float(value) if np.isnan(out[k]) else out[k] - float(value)
    return out


class PeakTracker:
    """Running maxima of |F_h| and |T_h| per hinge, fed at output times and at the accepted
    step points (where lambda is exact to the pass tolerance, not interpolated)."""

    def __init__(self, hinges):
        self.hinges = tuple(hinges)
        n = len(self.hinges)
        self.force = np.zeros(n)
        self.t_force = np.full(n, np.nan)
        self.torque = np.zeros(n)
        self.t_torque = np.full(n, np.nan)

    def observe(self, t: float, forces: np.ndarray, torques: np.ndarray) -> None:
        """forces (NH, 2) N and torques (NH,) N m at time t (s); NaN entries are skipped."""
        magnitude = np.hypot(forces[:, 0], forces[:, 1])
        larger = np.isfinite(magnitude) & (magnitude > self.force)
        self.force[larger] = magnitude[larger]
        self.t_force[larger] = t
        size = np.abs(torques)
        larger = np.isfinite(size) & (size > self.torque)
        self.torque[larger] = size[larger]
        self.t_torque[larger] = t

    def peaks(self) -> dict[str, PeakLoad]:
        return {h: PeakLoad(float(self.force[k]), float(self.t_force[k]),
                            float(self.torque[k]), float(self.t_torque[k]))
                for k, h in enumerate(self.hinges)}


def merge_peaks(a: dict[str, PeakLoad], b: dict[str, PeakLoad]) -> dict[str, PeakLoad]:
    """The larger of two peak sets, hinge by hinge."""
    out = {}
    for h, x in a.items():
        y = b.get(h, x)
        force, t_force = (x.force, x.t_force) if x.force >= y.force else (y.force, y.t_force)
        torque, t_torque = ((x.torque, x.t_torque) if x.torque >= y.torque
                            else (y.torque, y.t_torque))
        out[h] = PeakLoad(force, t_force, torque, t_torque)
    return out


def latch_records(events, latch_hinges) -> tuple[LatchRecord, ...]:
    """The first "<h>.latch" event of each latch hinge, in time order."""
    found = {}
    for e in events:
        hinge = e.name[:-len(".latch")] if e.name.endswith(".latch") else None
        if hinge in latch_hinges and hinge not in found:
            d = e.data
            found[hinge] = LatchRecord(hinge, e.t, float(d.get("rate", math.nan)),
                                       d.get("impulse"), d.get("impact_energy_loss"),
                                       bool(d.get("rigid", True)))
    return tuple(sorted(found.values(), key=lambda r: r.t))


def deployment_of(result) -> Deployment:
    """The Deployment summary of a Result: latches from its events, friction energy from the
    dissipated work of the "friction.*" dissipators, impact energy from the events' data."""
    latches = latch_records(result.events, result.latch_hinges)
    deployed = None
    time = None
    if result.latch_hinges:
        deployed = len(latches) == len(result.latch_hinges)
        time = max(r.t for r in latches) if deployed else None
    last = result.dissipated[-1] if len(result.dissipated) else np.zeros(0)
    friction = sum(float(w) for n, w in zip(result.dissipator_names, last)
                   if n.startswith("friction."))
    impacts = float(sum(e.data.get("impact_energy_loss") or 0.0 for e in result.events))
    return Deployment(tuple(result.latch_hinges), latches, deployed, time, friction, impacts)
