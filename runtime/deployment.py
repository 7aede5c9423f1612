"""Deployment mechanics: latches, hard stops and stick-slip friction of a module's hinges.

`Mechanism.for_module(module, p)` reads `hinge_properties(p)` and, when any hinge has a
`latch`, `stop_min`/`stop_max` or `static_friction`, keeps each such hinge's mode and provides

* one `Event` per (hinge, kind) - kinds "latch", "stop_min", "stop_max", "stick" - whose
  g is positive while the hinge's current mode holds and falls through zero when the mode
  must change (section 1 of docs/deployment.md lists every g);
* `respond(hit)`: the callback of all of them. It applies the transition of the event that
  fired, then every other transition whose g is already negative at that state (hinges that
  latch at the same instant), with a plastic impact when a rigid latch or a stop engages, and
  returns the new rows, the state and the records;
* the runtime's extra forces (`MechanismSystem`): compliant latch contact torques and the
  exact kinetic friction of stick-slip hinges, with their energies and dissipated powers.

The transitions live in `transitions.py`. Sign conventions and formulas: docs/deployment.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import friction, latches
from .events import Event
from .loads import lock_torques
from .system import System
from .transitions import settle

PROPERTY_NAMES = ("latch", "latch_stiffness", "latch_damping", "stop_min", "stop_max",
                  "friction", "static_friction", "slip_rate")
KINDS = ("latch", "stop_min", "stop_max", "stick")


def _given(value) -> float | None:
    value = float(value)
    return None if math.isnan(value) else value


@dataclass
class HingeMechanics:
    """One hinge's mechanism properties (SI) and its mode during a run.

    latch_state: "open" (not yet reached), "latched" (rigid lock row "<h>.latch"), "contact" /
    "apart" (compliant latch pushing / not touching); stop: None, "min" or "max" (lock row
    "<h>.stop"); stuck: lock row "<h>.stick"; direction: the slip direction s (+-1)."""

    index: int
    name: str
    latch: float | None = None
    latch_stiffness: float | None = None
    latch_damping: float = 0.0
    stop_min: float | None = None
    stop_max: float | None = None
    kinetic: float = 0.0
    static: float | None = None
    slip_rate: float = 1e-3
    latch_side: float = 1.0
    latch_state: str = "open"
    stop: str | None = None
    stuck: bool = False
    direction: float = 1.0

    @property
    def compliant(self) -> bool:
        return self.latch is not None and self.latch_stiffness is not None

    @property
    def locked(self) -> bool:
        """Held rigidly by a latch or a stop (no stick-slip then)."""
        return self.latch_state == "latched" or self.stop is not None

    @property
    def sliding(self) -> bool:
        return self.static is not None and not self.locked and not self.stuck

    @property
    def owns_friction(self) -> bool:
        """The runtime replaces the module's tanh friction of this hinge: always with static
        friction (stick-slip), and while a latch or stop locks it (the tanh law would act as a
        stiff damper of slope friction / slip_rate against the lock row)."""
        return self.kinetic > 0 and (self.static is not None or self.locked)

    def kinds(self) -> tuple[str, ...]:
        present = {"latch": self.latch is not None, "stop_min": self.stop_min is not None,
                   "stop_max": self.stop_max is not None, "stick": self.static is not None}
        return tuple(k for k in KINDS if present[k])


class Mechanism:
    """The hinges with latches, stops or stick-slip friction of one run (module docstring)."""

    def __init__(self, module, p, hinges: list[HingeMechanics]):
        self.module = module
        self.p = p
        self.hinges = hinges
        self.hinge_names = tuple(module.HINGES)
        self.latch_hinges = tuple(h.name for h in hinges if h.latch is not None)
        self.system = None
        self.tol = None
        self._events = {}
        for hinge in hinges:
            for kind in hinge.kinds():
                self._events[f"{hinge.name}.{kind}"] = (hinge, kind)
        self.events = tuple(self._event(hinge, kind) for hinge, kind in self._events.values())

    @classmethod
    def for_module(cls, module, p) -> Mechanism | None:
        """The mechanism of `module` with parameters p, or None when no hinge has a latch, a
        stop or static friction (or the module has no `hinge_properties`)."""
        if not hasattr(module, "hinge_properties"):
            return None
        names = tuple(getattr(module, "HINGE_PROPERTIES", PROPERTY_NAMES))
        table = np.asarray(module.hinge_properties(p), dtype=float).reshape(
            len(module.HINGES), len(names))
        hinges = []
        for k, name in enumerate(module.HINGES):
            row = {n: _given(v) for n, v in zip(names, table[k])}
            hinge = HingeMechanics(
                k, name, latch=row.get("latch"), latch_stiffness=row.get("latch_stiffness"),
                latch_damping=row.get("latch_damping") or 0.0, stop_min=row.get("stop_min"),
                stop_max=row.get("stop_max"), kinetic=row.get("friction") or 0.0,
                static=row.get("static_friction"), slip_rate=row.get("slip_rate") or 1e-3)
            if hinge.kinds():
                hinges.append(hinge)
        return cls(module, p, hinges) if hinges else None

    def bind(self, system, tol: float) -> None:
        """The system it acts in (for its mass matrix and forces) and the pass tolerance."""
        self.system = system
        self.tol = tol

    # -- kinematics -----------------------------------------------------------------------
    def angle(self, hinge: HingeMechanics, q) -> float:
        return float(self.module.hinge_angles(q, self.p)[hinge.index])

    def rate(self, hinge: HingeMechanics, q, qd) -> float:
        return float(self.module.hinge_rates(q, qd, self.p)[hinge.index])

    # -- events -----------------------------------------------------------------------------
    def _event(self, hinge: HingeMechanics, kind: str) -> Event:
        name = f"{hinge.name}.{kind}"
        if kind == "latch":
            return Event(name, lambda t, q, qd: self.latch_g(hinge, q), -1, self.respond)
        if kind == "stick":
            return Event(name, lambda t, q, qd, lam: self.stick_g(hinge, q, qd, lam), -1,
                         self.respond, multipliers=True)
        limit = kind[len("stop_"):]
        return Event(name, lambda t, q, qd, lam: self.stop_g(hinge, limit, q, lam), -1,
                     self.respond, multipliers=True)

    def latch_g(self, hinge: HingeMechanics, q) -> float:
        """open / apart: side (lock - theta); contact: side (theta - lock); latched or stuck
        (a stuck hinge does not move): 1."""
        if hinge.latch_state == "latched" or hinge.stuck:
            return 1.0
        gap = latches.latch_gap(self.angle(hinge, q), hinge.latch, hinge.latch_side)
        return -gap if hinge.latch_state == "contact" else gap

    def stop_g(self, hinge: HingeMechanics, limit: str, q, lam) -> float:
        """free: stop_max - theta or theta - stop_min; at this stop: the pushing multiplier
        (+lambda at stop_max, -lambda at stop_min); latched or stuck: 1."""
        if hinge.latch_state == "latched" or hinge.stuck:
            return 1.0
        sign = 1.0 if limit == "max" else -1.0
        if hinge.stop == limit:
            return sign * lam[f"{hinge.name}.stop"]
        limit_angle = hinge.stop_max if limit == "max" else hinge.stop_min
        return sign * (limit_angle - self.angle(hinge, q))

    def stick_g(self, hinge: HingeMechanics, q, qd, lam) -> float:
        """slipping: s rate; stuck: static_friction - |lambda_stick|; locked: 1."""
        if hinge.locked:
            return 1.0
        if hinge.stuck:
            return hinge.static - abs(lam[f"{hinge.name}.stick"])
        return hinge.direction * self.rate(hinge, q, qd)

    def event_of(self, name: str) -> tuple[HingeMechanics, str]:
        return self._events[name]

    def respond(self, hit):
        """The callback of every mechanism event (see transitions.settle)."""
        return settle(self, hit.t, hit.q, hit.qd, hit.constraints, [hit.name])

    def start(self, t, q, qd, constraints):
        """Modes at the start, as an EventResponse: latch sides, and the transitions due at
        once (a hinge starting at its latch or stop, stick-or-slip of resting friction
        hinges)."""
        due = []
        for hinge in self.hinges:
            theta, rate = self.angle(hinge, q), self.rate(hinge, q, qd)
            if hinge.latch is not None:
                hinge.latch_side = latches.approach_side(theta, rate, hinge.latch)
                if theta == hinge.latch:
                    due.append(f"{hinge.name}.latch")
            if hinge.stop_max is not None and theta >= hinge.stop_max:
                due.append(f"{hinge.name}.stop_max")
            if hinge.stop_min is not None and theta <= hinge.stop_min:
                due.append(f"{hinge.name}.stop_min")
            if hinge.static is not None:
                hinge.direction = friction.slip_direction(rate)
                if rate == 0.0:
                    due.append(f"{hinge.name}.stick")
        return settle(self, t, q, qd, constraints, due)

    # -- forces -----------------------------------------------------------------------------
    @property
    def forcing(self) -> bool:
        """Whether any hinge has a runtime torque now (stick-slip, compliant contact, the
        cancelled friction of a locked hinge)."""
        return any(h.owns_friction or h.latch_state == "contact" for h in self.hinges)

    def _overshoot(self, hinge, angles, rates) -> tuple[float, float]:
        side = hinge.latch_side
        return (side * (angles[hinge.index] - hinge.latch), side * rates[hinge.index])

    def torques(self, q, qd) -> np.ndarray:
        """The runtime torques on the hinge angles (NH,), N m: to add as J^T tau to force."""
        tau = np.zeros(len(self.hinge_names))
        rates = np.asarray(self.module.hinge_rates(q, qd, self.p), dtype=float)
        angles = None
        for h in self.hinges:
            if h.owns_friction:
                tau[h.index] += friction.friction_torque(rates[h.index], h.kinetic, h.slip_rate,
                                                         h.direction, h.sliding)
            if h.latch_state == "contact":
                if angles is None:
                    angles = np.asarray(self.module.hinge_angles(q, self.p), dtype=float)
                delta, delta_rate = self._overshoot(h, angles, rates)
                tau[h.index] -= h.latch_side * latches.contact_torque(
                    delta, delta_rate, h.latch_stiffness, h.latch_damping)
        return tau

    @property
    def extra_dissipators(self) -> tuple[str, ...]:
        return tuple(f"latch.{h.name}" for h in self.hinges if h.compliant)

    @property
    def extra_energies(self) -> tuple[str, ...]:
        return tuple(f"latch.{h.name}" for h in self.hinges if h.compliant)

    def friction_powers(self, q, qd) -> dict[str, float]:
        """Power of the friction of each hinge whose friction the runtime owns
        ({"friction.<h>": W}), replacing the module's tanh-law entry."""
        owned = [h for h in self.hinges if h.owns_friction]
        if not owned:
            return {}
        rates = self.module.hinge_rates(q, qd, self.p)
        return {f"friction.{h.name}": friction.friction_power(
            float(rates[h.index]), h.kinetic, h.direction, h.sliding) for h in owned}

    def latch_powers_and_energies(self, q, qd) -> tuple[list[float], list[float]]:
        """Compliant latches' dissipated powers (W) and spring energies (J)."""
        compliant = [h for h in self.hinges if h.compliant]
        if not compliant:
            return [], []
        angles = self.module.hinge_angles(q, self.p)
        rates = self.module.hinge_rates(q, qd, self.p)
        powers, energies = [], []
        for h in compliant:
            if h.latch_state != "contact":
                powers.append(0.0)
                energies.append(0.0)
                continue
            delta, delta_rate = self._overshoot(h, angles, rates)
            powers.append(latches.contact_power(delta, delta_rate, h.latch_stiffness,
                                                h.latch_damping))
            energies.append(latches.contact_energy(delta, h.latch_stiffness))
        return powers, energies

    def hinge_torques(self, q, qd, names, lam) -> np.ndarray:
        """Each hinge's lock torque (NH,), N m, NaN while free: -lambda of its lock row, or the
        compliant latch's torque -side P while in contact."""
        tau = lock_torques(self.hinge_names, names, lam)
        compliant = [h for h in self.hinges if h.latch_state == "contact"]
        if compliant:
            angles = self.module.hinge_angles(q, self.p)
            rates = self.module.hinge_rates(q, qd, self.p)
            for h in compliant:
                delta, delta_rate = self._overshoot(h, angles, rates)
                push = latches.contact_torque(delta, delta_rate, h.latch_stiffness,
                                              h.latch_damping)
                tau[h.index] = -h.latch_side * push
        return tau


class MechanismSystem(System):
    """A System whose force, dissipation and energy include the mechanism's runtime terms.

    Dissipators: the module's (the "friction.<h>" power of a hinge whose friction the runtime
    owns replaced by that friction's power), then "latch.<h>" per compliant latch. Energies:
    the module's, then "latch.<h>". Plastic impacts remove kinetic energy at events; their
    records carry it (`impact_energy_loss`), and Result.total_energy counts it."""

    def __init__(self, module, p, mechanism: Mechanism):
        super().__init__(module, p)
        self.mechanism = mechanism
        base = tuple(module.DISSIPATORS)
        self.dissipator_names = base + mechanism.extra_dissipators
        self.energy_names = tuple(module.ENERGIES) + mechanism.extra_energies
        self.nd = len(self.dissipator_names)
        self._base_nd = len(base)
        self._friction_index = {name: base.index(name) for name in base}

    def force(self, q, qd, t):
        f = self.module.force(q, qd, t, self.p)
        if not self.mechanism.forcing:
            return f
        tau = self.mechanism.torques(q, qd)
        return f + np.asarray(self.module.hinge_jacobian(q, self.p), dtype=float).T @ tau

    def dissipation(self, q, qd, t):
        mech = self.mechanism
        base = (np.asarray(self.module.dissipation(q, qd, t, self.p), dtype=float).copy()
                if self._base_nd else np.zeros(0))
        for name, power in mech.friction_powers(q, qd).items():
            if name in self._friction_index:
                base[self._friction_index[name]] = power
        powers, _ = mech.latch_powers_and_energies(q, qd)
        return np.concatenate((base, powers)) if powers else base

    def energy(self, q, qd, t):
        base = np.asarray(self.module.energy(q, qd, t, self.p), dtype=float)
        _, energies = self.mechanism.latch_powers_and_energies(q, qd)
        return np.concatenate((base, energies)) if energies else base
