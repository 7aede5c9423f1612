"""Events on the dense output, and constraint rows added at run time (a latch)."""

import numpy as np
import pytest
from runtime_helpers import pendulum_period

from references.direct import solve_direct

from depsim.runtime import (ConstraintSet, Event, EventResponse, HingeLock, LinearConstraint,
                            simulate)
from depsim.runtime.interface import dense

LOCK = np.radians(30.0)


def theta(q):
    return q[2] + np.pi / 2


def latch_event(lock_row):
    """Lock the pivot at 30 degrees on the way down, with a plastic impact."""
    def callback(hit):
        return EventResponse(add=(lock_row(hit),), impact=True, data={"angle": LOCK})

    return Event("latch", lambda t, q, qd: theta(q) - LOCK, direction=-1, callback=callback,
                 max_hits=1)


def hinge_lock(hit):
    return HingeLock(hit.module, "pivot", LOCK)


def linear_lock(hit):  # the same row written by hand: phi - (LOCK - pi/2) = 0
    return LinearConstraint("pivot.lock", "pivot", np.array([0.0, 0.0, 1.0]), LOCK - np.pi / 2)


@pytest.mark.parametrize("lock_row", [hinge_lock, linear_lock])
def test_a_latch_adds_a_lock_row_and_holds_the_pendulum(pendulum, lock_row):
    p = np.array(pendulum.PARAMETER_DEFAULTS)
    result = simulate(pendulum, t_end=1.0, tol=1e-10, dt_out=0.01, events=[latch_event(lock_row)])
    (event,) = result.events
    m, g, d = p[1], p[2], p[0] / 2
    # the latch time: the swing from 60 to 30 degrees, checked against the direct solver
    direct = solve_direct(pendulum, t_end=1.0, tol=1e-12, dt_out=0.01,
                          events=[latch_event(lock_row)])
    assert abs(event.t - direct.events[0].t) < 1e-9
    # plastic impact: all kinetic energy m g d (cos 30 - cos 60) is lost
    assert event.data["impact_energy_loss"] == pytest.approx(m * g * d * (np.cos(LOCK) - 0.5),
                                                             rel=1e-9)
    after = result.times > event.t
    assert np.max(np.abs(result.output("theta")[after] - LOCK)) < 1e-10
    assert np.max(np.abs(result.output("omega")[after])) < 1e-10
    # statics: the lock carries the gravity moment, lambda_lock = -m g d sin(30 deg)
    assert result.constraint_names == ("pivot.x", "pivot.y", "pivot.lock")
    assert np.all(np.isnan(result.lam[~after, 2]))
    assert np.allclose(result.lam[after, 2], -m * g * d * np.sin(LOCK), rtol=1e-9)
    assert np.allclose(result.lam[after, 1], -m * g, rtol=1e-9)


def test_a_terminal_event_stops_the_run_at_the_crossing(pendulum):
    p = np.array(pendulum.PARAMETER_DEFAULTS)
    T = pendulum_period(p)
    bottom = Event("bottom", lambda t, q, qd: theta(q), direction=-1, terminal=True)
    result = simulate(pendulum, t_end=2.0, tol=1e-10, dt_out=0.1, events=[bottom])
    assert [e.name for e in result.events] == ["bottom"]
    assert result.events[0].t == pytest.approx(T / 4, rel=1e-9)
    assert result.times[-1] == result.events[0].t  # a last row at the stop
    assert np.all(np.diff(result.times[:-1]) > 0.099)
    assert abs(result.output("theta")[-1]) < 1e-9


def test_events_are_located_to_the_time_tolerance_and_counted(pendulum):
    p = np.array(pendulum.PARAMETER_DEFAULTS)
    T = pendulum_period(p)
    hits = []

    def count(hit):
        hits.append(hit.t)

    crossing = Event("zero", lambda t, q, qd: theta(q), direction=0, callback=count)
    result = simulate(pendulum, t_end=2.4 * T, tol=1e-10, dt_out=0.1, events=[crossing])
    expected = T / 4 + np.arange(5) * T / 2  # both directions
    assert len(hits) == 5
    assert np.max(np.abs(np.array(hits) - expected)) < 1e-8
    assert result.stats.events == 5


def test_a_callback_can_replace_the_state(pendulum):
    """At the bottom, stop the bar by hand (qd = 0): it stays at rest, hanging."""
    bottom = Event("stop", lambda t, q, qd: theta(q), direction=-1,
                   callback=lambda hit: EventResponse(qd=np.zeros(3)))
    result = simulate(pendulum, t_end=1.0, tol=1e-10, dt_out=0.05, events=[bottom])
    after = result.times > result.events[0].t
    assert np.max(np.abs(result.output("theta")[after])) < 1e-8
    assert np.max(np.abs(result.output("omega")[after])) < 1e-8


def test_constraint_set_combines_module_rows_with_added_rows(pendulum):
    p = np.array(pendulum.PARAMETER_DEFAULTS)
    base = ConstraintSet(pendulum, p)
    lock = HingeLock(pendulum, "pivot", LOCK)
    both = base.with_rows([lock])
    q, qd = pendulum.initial_state(p)
    assert both.names == ("pivot.x", "pivot.y", "pivot.lock") and both.nc == 3
    assert np.allclose(both.jacobian(q, 0.0)[2], dense(pendulum, "hinge_jacobian", q, p)[0])
    assert both.phi(q, 0.0)[2] == pytest.approx(np.radians(60) - LOCK)
    assert both.gamma(q, np.array([0.1, 0.2, 0.3]), 0.0)[2] == 0.0  # theta linear in q
    assert both.describe(2) == ("lock pivot", "pivot.lock")
    assert both.without(["pivot.lock"]).names == base.names
    with pytest.raises(ValueError, match="unknown hinge 'nope'"):
        HingeLock(pendulum, "nope", 0.0)
    with pytest.raises(ValueError, match="named twice"):
        both.with_rows([lock])
