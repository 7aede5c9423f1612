"""Events: zero crossings of g(t, q, qd), and what happens then.

An `Event` names a function g(t, q, qd) -> float (SI, any unit), the crossing direction it
watches (+1 rising, -1 falling, 0 both) and an optional callback. After every accepted step
the integrator evaluates g at the step's end; on a sign change it locates the crossing on the
step's dense output to `EVENT_TIME_TOL` seconds, re-takes the step exactly to the crossing (so
every constraint level holds there), and calls the callback with an `EventHit`. The callback
returns an `EventResponse` (or None): stop, replace q or qd, add or remove constraint rows (a
latch adds a `HingeLock`), apply a plastic impact.

An event with `multipliers=True` is called as g(t, q, qd, lam), lam a dict of the active
rows' multipliers {row name: lambda}: at a step end the step's lambda, on the dense output
lambda from the acceleration pass at the interpolated state (a stop releases when its
multiplier would pull, a sticking hinge slips when its holding torque exceeds static friction).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

EVENT_TIME_TOL = 1e-12  # s, as the core locates crossings (runtime/c/events.c)


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
    `records` is the integrator's own (its latch events may record several hinges at one
    time); a user event leaves it None.
    """

    stop: bool | None = None
    q: np.ndarray | None = None
    qd: np.ndarray | None = None
    add: tuple = ()
    remove: tuple[str, ...] = ()
    impact: bool = False
    data: dict = field(default_factory=dict)
    records: tuple[tuple[str, dict], ...] | None = None
