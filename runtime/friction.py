"""Stick-slip hinge friction (a hinge with `static_friction`): the torques and the tests.

Without `static_friction` a hinge's Coulomb friction is the module's regularised law
-friction tanh(rate / slip_rate), already in `force`. With it, the runtime owns that hinge's
friction (docs/deployment.md, section 4):

* stick: a lock row "<h>.stick" (theta - theta_stick = 0) holds the hinge; its holding torque
  is T = -lambda. The hinge sticks while |lambda| <= static_friction.
* slip in direction s = +-1: the exact kinetic friction -s friction (the tanh term in `force`
  is cancelled). The slip lasts while s rate > 0.

Transitions: rate reaching zero while slipping -> `rest_test`: stick if the holding torque a
trial lock needs is within static friction, otherwise slip in the direction s = sign(lambda)
the unbalanced torque drives; stick with |lambda| reaching static friction -> slip with
s = sign(lambda). These functions hold no state; deployment.py keeps the hinge's mode.
"""

from __future__ import annotations

import math


def friction_torque(rate: float, kinetic: float, slip_rate: float, direction: float,
                    sliding: bool) -> float:
    """The torque (N m) the runtime adds on a stick-slip hinge's angle: +kinetic tanh(rate /
    slip_rate) cancels the module's regularised law, and while sliding -direction kinetic is
    the exact Coulomb torque. While stuck (or locked by a latch or stop) only the
    cancellation remains: the lock row's multiplier carries the holding torque."""
    cancel = kinetic * math.tanh(rate / slip_rate) if kinetic else 0.0
    return cancel - direction * kinetic if sliding else cancel


def friction_power(rate: float, kinetic: float, direction: float, sliding: bool) -> float:
    """Power the stick-slip friction removes (W, >= 0 while sliding in `direction`; 0 stuck)."""
    return direction * kinetic * rate if sliding else 0.0


def holds(holding_multiplier: float, static: float) -> bool:
    """Does static friction hold? |lambda| <= static_friction (the holding torque is -lambda)."""
    return abs(holding_multiplier) <= static


def slip_direction(holding_multiplier: float, previous: float = 1.0) -> float:
    """The direction a released hinge slides: sign(lambda) (the unbalanced torque's direction
    is opposite to the holding torque -lambda); `previous` when lambda is exactly zero."""
    if holding_multiplier == 0.0:
        return previous or 1.0
    return 1.0 if holding_multiplier > 0 else -1.0
