"""Mode changes of latches, stops and stick-slip hinges at an event (docs/deployment.md, 1-4).

`settle(mechanism, t, q, qd, constraints, due)` applies the transitions named in `due` (event
names "<h>.<kind>"), then, until none is left, every transition whose event function is
already negative at the current state (two hinges latching at the same instant, a stop whose
multiplier pulls right after the impact), except for events whose new mode starts on its
boundary g = 0 by construction (a slip from rest, a stop's release, a compliant latch's
contact or separation: round-off must not switch them back). A rigid latch or a stop that
engages causes a plastic impact (latches.plastic_impact): sticking hinges let go during it (a
finite friction torque transmits no impulse) and afterwards slip in the direction of their new
rate, or are tested for stick when at rest. When rows were added, q and qd are finally
projected onto every constraint (the event was located on the dense output, within the step's
local error of the lock angle). Returns the EventResponse for the integrator.
"""

from __future__ import annotations

import math

import numpy as np

from . import friction, latches
from .constraints import ConstraintSet, HingeLock
from .errors import SolverError
from .events import EventResponse
from .multipliers import PassFailure

MAX_ROUNDS_PER_EVENT = 4  # transitions allowed per mechanism event in one settle
REST = 1e3  # a hinge rate below REST * tol * max(1, max|qd|) counts as at rest


class Context:
    """The state being settled: time, q, qd, the added constraint rows (name -> row) and the
    records made."""

    def __init__(self, mechanism, t, q, qd, constraints):
        self.mechanism = mechanism
        self.system = mechanism.system
        self.t = t
        self.q = np.array(q, dtype=float)
        self.qd = np.array(qd, dtype=float)
        self.rows = {r.name: r for r in constraints.added}
        self.records: list[tuple[str, dict]] = []
        self.impacting: list[tuple[str, dict]] = []
        self.starting: set[str] = set()  # events whose g starts at 0 in their new mode
        self.added = False

    def constraints(self, skip=()) -> ConstraintSet:
        return ConstraintSet(self.system, [r for n, r in self.rows.items() if n not in skip])

    def add_lock(self, hinge, angle: float, kind: str) -> str:
        name = f"{hinge.name}.{kind}"
        self.rows[name] = HingeLock(self.mechanism.module, hinge.name, angle, name=name)
        self.added = True
        return name

    def remove(self, *names) -> None:
        for name in names:
            self.rows.pop(name, None)

    def record(self, name: str, data: dict) -> dict:
        self.records.append((name, data))
        return data

    def angle(self, hinge) -> float:
        return self.mechanism.angle(hinge, self.q)

    def rate(self, hinge) -> float:
        return self.mechanism.rate(hinge, self.q, self.qd)

    def multipliers(self) -> dict:
        """{row name: lambda} at the current state and modes (acceleration pass)."""
        cs = self.constraints()
        lam = latches.acceleration_multipliers(self.system, cs, self.q, self.qd, self.t,
                                               self.mechanism.tol)
        return dict(zip(cs.names, map(float, lam)))

    def response(self, original: ConstraintSet) -> EventResponse:
        before = {r.name: r for r in original.added}
        remove = tuple(n for n, r in before.items() if self.rows.get(n) is not r)
        add = tuple(r for n, r in self.rows.items() if before.get(n) is not r)
        return EventResponse(q=self.q, qd=self.qd, add=add, remove=remove,
                             records=tuple(self.records))


def settle(mechanism, t, q, qd, constraints, due) -> EventResponse:
    """Apply the due transitions and every one they make due (module docstring)."""
    ctx = Context(mechanism, t, q, qd, constraints)
    pending = list(due)
    limit = MAX_ROUNDS_PER_EVENT * max(1, len(mechanism.events))
    try:
        for _ in range(limit):
            if not pending:
                pending = violated(mechanism, ctx)
                if not pending:
                    break
            name = pending.pop(0)
            ctx.starting.discard(name)
            hinge, kind = mechanism.event_of(name)
            pending += TRANSITIONS[kind](mechanism, hinge, kind, ctx)
            if ctx.impacting:
                pending += impact(mechanism, ctx)
        else:
            raise SolverError("latches, stops and stick-slip friction did not settle after "
                              f"{limit} transitions at one instant", t=t, stage="event",
                              hint="the hinges switch modes endlessly (chattering); check "
                              "static_friction against the driving torques")
        if ctx.added:
            project(mechanism, ctx)
    except PassFailure as failure:
        raise SolverError(f"a mechanism transition did not converge: {failure.reason}", t=t,
                          stage="event", residual=failure.residual,
                          hint="a latch or stop made the constraints redundant and "
                               "inconsistent, or Phi_q singular") from None
    return ctx.response(constraints)


def violated(mechanism, ctx: Context) -> list[str]:
    """Events whose g is already negative at the context's state (except those whose mode
    has just started on its boundary)."""
    lam = None
    found = []
    for event in mechanism.events:
        if event.name in ctx.starting:
            continue
        if event.multipliers:
            lam = ctx.multipliers() if lam is None else lam
            g = event.function(ctx.t, ctx.q, ctx.qd, lam)
        else:
            g = event.function(ctx.t, ctx.q, ctx.qd)
        if g < 0:
            found.append(event.name)
    return found


def latch(mechanism, hinge, kind, ctx: Context) -> list[str]:
    """open -> latched (rigid: lock row, impact) or contact (compliant); contact <-> apart."""
    rate = ctx.rate(hinge)
    if hinge.latch_state == "open":
        data = {"hinge": hinge.name, "angle": hinge.latch, "rate": rate,
                "rigid": not hinge.compliant}
        if hinge.compliant:
            hinge.latch_state = "contact"
            ctx.starting.add(f"{hinge.name}.latch")
            ctx.record(f"{hinge.name}.latch", {**data, "impulse": None,
                                                "impact_energy_loss": None})
            return []
        ctx.remove(f"{hinge.name}.stick", f"{hinge.name}.stop")
        hinge.stuck, hinge.stop = False, None
        hinge.latch_state = "latched"
        row = ctx.add_lock(hinge, hinge.latch, "latch")
        ctx.impacting.append((row, ctx.record(f"{hinge.name}.latch", data)))
    elif hinge.latch_state in ("contact", "apart"):
        hinge.latch_state = "apart" if hinge.latch_state == "contact" else "contact"
        ctx.starting.add(f"{hinge.name}.latch")
        what = "separation" if hinge.latch_state == "apart" else "contact"
        ctx.record(f"{hinge.name}.latch.{what}", {"hinge": hinge.name, "rate": rate})
    return []


def stop(mechanism, hinge, kind, ctx: Context) -> list[str]:
    """free -> at the stop (lock row, impact); at the stop -> free (its multiplier would
    pull), then a stick-or-slip test for a stick-slip hinge."""
    limit = kind[len("stop_"):]
    angle = hinge.stop_max if limit == "max" else hinge.stop_min
    if hinge.stop == limit:
        ctx.remove(f"{hinge.name}.stop")
        hinge.stop = None
        ctx.starting.add(f"{hinge.name}.{kind}")
        ctx.record(f"{hinge.name}.stop", {"hinge": hinge.name, "limit": limit,
                                          "angle": angle, "action": "release"})
        if hinge.static is not None:
            hinge.stuck = False
            return [f"{hinge.name}.stick"]
        return []
    ctx.remove(f"{hinge.name}.stick")
    hinge.stuck, hinge.stop = False, limit
    row = ctx.add_lock(hinge, angle, "stop")
    data = {"hinge": hinge.name, "limit": limit, "angle": angle, "action": "contact",
            "rate": ctx.rate(hinge)}
    ctx.impacting.append((row, ctx.record(f"{hinge.name}.stop", data)))
    return []


def stick(mechanism, hinge, kind, ctx: Context) -> list[str]:
    """stuck -> slip (holding torque reached static friction); slipping at rest -> the
    stick-or-slip test with a trial lock row at the current angle."""
    if hinge.locked:
        return []
    name = f"{hinge.name}.stick"
    if hinge.stuck:
        return _start_slip(ctx, hinge, name, ctx.multipliers()[name])
    theta = ctx.angle(hinge)
    ctx.add_lock(hinge, theta, "stick")
    hinge.stuck = True  # the trial: friction is carried by the lock row's multiplier
    lam = ctx.multipliers()[name]
    if friction.holds(lam, hinge.static):
        ctx.record(name, {"hinge": hinge.name, "angle": theta, "torque": -lam})
        return []
    return _start_slip(ctx, hinge, name, lam)


TRANSITIONS = {"latch": latch, "stop_min": stop, "stop_max": stop, "stick": stick}


def impact(mechanism, ctx: Context) -> list[str]:
    """The plastic impact of the rows that just engaged; returns the rest tests it makes due.
    Records get the angular impulse -mu of their row (N m s, on member b in the sense of
    theta), the energy lost (on the first record of the impact) and the joints' impulses."""
    impacting, ctx.impacting = ctx.impacting, []
    stuck = [h for h in mechanism.hinges if h.stuck and not h.locked]
    unilateral = {f"{h.name}.stop": (1.0 if h.stop == "max" else -1.0)
                  for h in mechanism.hinges if h.stop is not None}
    cs = ctx.constraints(skip={f"{h.name}.stick" for h in stuck})
    result = latches.plastic_impact(cs, mechanism.system.mass, ctx.q, ctx.qd, ctx.t,
                                    mechanism.tol, unilateral)
    ctx.qd = result.qd
    joints = {h: math.hypot(result.impulses.get(f"{h}.x", 0.0), result.impulses.get(f"{h}.y", 0.0))
              for h in mechanism.hinge_names}
    for i, (row, data) in enumerate(impacting):
        data["impulse"] = -result.impulses.get(row, 0.0)
        data["impact_energy_loss"] = result.energy_loss if i == 0 else 0.0
        data["joint_impulses"] = joints
    for name in result.released:
        hinge = next(h for h in mechanism.hinges if f"{h.name}.stop" == name)
        ctx.remove(name)
        ctx.record(name, {"hinge": hinge.name, "limit": hinge.stop, "action": "release",
                          "cause": "impact"})
        hinge.stop = None
    follow = []
    at_rest = REST * mechanism.tol * max(1.0, float(np.max(np.abs(ctx.qd), initial=0.0)))
    for hinge in stuck:
        ctx.remove(f"{hinge.name}.stick")
        hinge.stuck = False
        rate = ctx.rate(hinge)
        if abs(rate) > at_rest:
            hinge.direction = 1.0 if rate > 0 else -1.0
            ctx.record(f"{hinge.name}.slip", {"hinge": hinge.name, "direction": hinge.direction,
                                              "cause": "impact"})
        else:
            follow.append(f"{hinge.name}.stick")
    return follow


def project(mechanism, ctx: Context) -> None:
    """q and qd moved M-orthogonally onto every constraint level. The moves are of the order
    of the located event's error (the step's local error); the kinetic energy the velocity
    projection removes is that small too, and is not recorded."""
    cs = ctx.constraints()
    mass = mechanism.system.mass
    ctx.q = latches.project_positions(cs, mass, ctx.q, ctx.t, mechanism.tol)
    ctx.qd = latches.project_velocities(cs, mass, ctx.q, ctx.qd, ctx.t, mechanism.tol)


def _start_slip(ctx, hinge, name: str, lam: float) -> list:
    """Release a stuck hinge: drop its stick row and slide against the holding torque."""
    ctx.remove(name)
    hinge.stuck = False
    hinge.direction = friction.slip_direction(lam, hinge.direction)
    ctx.starting.add(name)
    ctx.record(f"{hinge.name}.slip", {"hinge": hinge.name, "direction": hinge.direction,
                                      "torque": -lam})
    return []
