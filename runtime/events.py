"""Events: zero crossings of g(t, q, qd) located on the dense output, and what happens then.

An `Event` names a function g(t, q, qd) -> float (SI, any unit), the crossing direction it
watches (+1 rising, -1 falling, 0 both) and an optional callback. After every accepted step
the runtime evaluates g at the step's end; on a sign change it locates the crossing on the
step's continuous extension with Brent's method to `EVENT_TIME_TOL` seconds, re-takes the step
exactly to the crossing (so every constraint level holds there), and calls the callback with
an `EventHit`. The callback returns an `EventResponse` (or None): stop, replace q or qd, add
or remove constraint rows (a latch adds a `HingeLock`), apply a plastic impact.

An event with `multipliers=True` is called as g(t, q, qd, lam), lam a dict of the active
rows' multipliers {row name: lambda}: at a step end the step's lambda, on the dense output
lambda from the acceleration pass at the interpolated state (a stop releases when its
multiplier would pull, a sticking hinge slips when its holding torque exceeds static friction).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.optimize

EVENT_TIME_TOL = 1e-12  # s


@dataclass(frozen=True)
class Event:
    """g(t, q, qd) crossing zero in `direction`; `terminal` stops the run unless the callback
    decides; `max_hits` (None: unlimited) disarms the event after that many hits;
    `multipliers`: g takes a fourth argument, the dict {row name: lambda} (module docstring)."""

    name: str
    function: Callable[..., float]
    direction: int = 0
    callback: Callable[[EventHit], EventResponse | None] | None = None
    terminal: bool = False
    max_hits: int | None = None
    multipliers: bool = False

    def __post_init__(self):
        if self.direction not in (-1, 0, 1):
            raise ValueError(f"event '{self.name}': direction must be -1, 0 or +1")


@dataclass(frozen=True)
class EventHit:
    """What a callback sees: the event's name, the time (s), the state there (q, qd (NQ,),
    lam (nc,)), the active `ConstraintSet`, the module and parameters."""

    name: str
    t: float
    q: np.ndarray
    qd: np.ndarray
    lam: np.ndarray
    constraints: object
    module: object
    params: np.ndarray


@dataclass(frozen=True)
class EventResponse:
    """What to do after an event. `stop=None` keeps the event's `terminal` setting.

    `add` rows are appended to the constraint set and `remove` names rows to drop; `q`/`qd`
    replace the state; `impact=True` then applies a plastic impact: qd jumps by the
    M-orthogonal projection onto the velocity constraints of the new set (the kinetic energy
    lost is recorded as `impact_energy_loss`, J). `data` (plain numbers) goes into the record.
    `records`, when given, replaces the event's one record: (name, data) pairs, all at the
    event's time (a mechanism event may latch two hinges at once).
    """

    stop: bool | None = None
    q: np.ndarray | None = None
    qd: np.ndarray | None = None
    add: tuple = ()
    remove: tuple[str, ...] = ()
    impact: bool = False
    data: dict = field(default_factory=dict)
    records: tuple[tuple[str, dict], ...] | None = None


class EventWatch:
    """Tracks the sign of every armed event between steps."""

    def __init__(self, events):
        self.events = tuple(events)
        names = [e.name for e in self.events]
        if len(set(names)) != len(names):
            raise ValueError("event names must be distinct")
        self.hits = [0] * len(self.events)
        self.values = [0.0] * len(self.events)
        self.needs_multipliers = any(e.multipliers for e in self.events)

    def armed(self, k: int) -> bool:
        limit = self.events[k].max_hits
        return limit is None or self.hits[k] < limit

    def reset(self, t, q, qd, fired: int | None = None, side: float = 0.0,
              lam: dict | None = None) -> None:
        """Evaluate every g at (t, q, qd) (and the multipliers `lam` for the events that need
        them); event `fired` is put on `side` of zero (it was just located there, so its value
        is round-off and must not count as a crossing)."""
        for k, event in enumerate(self.events):
            self.values[k] = _value(event, t, q, qd, lam)
        if fired is not None:
            self.values[fired] = side * 1e-300

    def first_crossing(self, t0, t1, q1, qd1, dense, lam1: dict | None = None,
                       multipliers_at=None) -> tuple[int, float, float] | None:
        """The earliest crossing in (t0, t1] as (event index, time, sign of g just after),
        located on `dense` (a callable t -> (q, qd)); None when no armed event crossed.
        lam1: the multipliers at t1; multipliers_at(t, q, qd) -> dict on the dense output."""
        found = None
        for k, event in enumerate(self.events):
            g1 = _value(event, t1, q1, qd1, lam1)
            g0, self.values[k] = self.values[k], g1
            if not self.armed(k) or not _crosses(g0, g1, event.direction):
                continue

            def g(t, event=event):
                q, qd = dense(t)
                lam = multipliers_at(t, q, qd) if event.multipliers else None
                return _value(event, t, q, qd, lam)

            t_root = t1 if g1 == 0.0 else _root(g, t0, t1, g1)
            if found is None or t_root < found[1]:
                found = (k, t_root, -float(np.sign(g0)))
        return found


def _root(g, t0: float, t1: float, g1: float) -> float:
    """The crossing of g in [t0, t1] by Brent's method to EVENT_TIME_TOL. When g at t0,
    re-evaluated on the dense output, is already on g1's side (a value within round-off of
    zero at the step's start), the crossing is t0."""
    if np.sign(g(t0)) == np.sign(g1):
        return t0
    return scipy.optimize.brentq(g, t0, t1, xtol=EVENT_TIME_TOL, rtol=4 * np.finfo(float).eps)


def _value(event: Event, t, q, qd, lam) -> float:
    if event.multipliers:
        return float(event.function(t, q, qd, lam))
    return float(event.function(t, q, qd))


def _crosses(g0: float, g1: float, direction: int) -> bool:
    if g0 == 0.0:
        return False
    rising = g0 < 0.0 <= g1
    falling = g0 > 0.0 >= g1
    return rising if direction > 0 else falling if direction < 0 else rising or falling
