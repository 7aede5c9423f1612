"""Failures come back from C as the Python runtime raises them: SolverError with the same
message and attributes, ValueError for bad settings, an event callback's own exception; the
process never crashes."""

from __future__ import annotations

import numpy as np
import pytest

from depsim.runtime import Event, EventResponse, HingeLock, SolverError, simulate


def both(built, params=None, **settings):
    """The exception each backend raises (or None)."""
    caught = []
    for run, module in ((simulate, built.numpy), (simulate, built.c)):
        try:
            run(module, params, **settings)
            caught.append(None)
        except Exception as exc:  # noqa: BLE001 - compared below
            caught.append(exc)
    return caught


def with_parameter(module, **values) -> np.ndarray:
    p = np.array(module.PARAMETER_DEFAULTS)
    for name, value in values.items():
        p[module.PARAMETERS.index(name.replace("__", "."))] = value
    return p


def test_inconsistent_initial_state_gives_the_same_solver_error(example_builds):
    built = example_builds("slider_crank")
    p = with_parameter(built.numpy, crank_pin__initial_angle=2.0)
    expected, got = both(built, p, t_end=0.1)
    assert isinstance(expected, SolverError) and isinstance(got, SolverError)
    assert str(got) == str(expected)
    for field in ("t", "stage", "row", "joint", "residual", "hint", "what"):
        assert getattr(got, field) == getattr(expected, field), field


def test_non_finite_forces_give_the_same_solver_error(example_builds):
    built = example_builds("pendulum")
    with np.errstate(all="ignore"):
        expected, got = both(built, with_parameter(built.numpy, gravity__y=-1e306), t_end=1.0)
    assert isinstance(got, SolverError) and str(got) == str(expected)


def test_singular_configuration_names_the_same_pass_and_joint(example_builds):
    """Crank as long as the rod: S becomes singular within the first step. The failure time
    and residual are round-off amplified by the singular S; the diagnosis is the same."""
    built = example_builds("slider_crank")
    expected, got = both(built, with_parameter(built.numpy, r=0.3), t_end=1.0)
    assert isinstance(expected, SolverError) and isinstance(got, SolverError)
    for field in ("stage", "row", "joint", "hint"):
        assert getattr(got, field) == getattr(expected, field), field
    assert got.what.split(";")[0] == expected.what.split(";")[0]
    assert abs(got.t - expected.t) < 1e-5


@pytest.mark.parametrize("settings", [dict(t_end=-1.0), dict(dt_out=0.0), dict(tol=2.0),
                                      dict(t_end=float("nan")), dict(tol=1e-20)])
def test_bad_settings_raise_the_same_error(example_builds, settings):
    built = example_builds("pendulum")
    expected, got = both(built, **settings)
    assert type(got) is type(expected) and str(got) == str(expected)


def test_bad_parameters_raise_the_same_error(example_builds):
    built = example_builds("pendulum")
    for params in (np.ones(3), with_parameter(built.numpy, L=np.inf)):
        expected, got = both(built, params)
        assert type(got) is type(expected) is ValueError and str(got) == str(expected)


def test_events_agree(example_builds):
    """A latch (HingeLock with a plastic impact, once) and a terminal event."""
    built = example_builds("pendulum")
    results = []
    for run, module in ((simulate, built.numpy), (simulate, built.c)):
        p = np.array(module.PARAMETER_DEFAULTS)

        def theta(t, q, qd, module=module, p=p):
            return float(module.hinge_angles(q, p)[0])

        def latch(hit):
            return EventResponse(add=(HingeLock(hit.module, "pivot", 0.0),), impact=True,
                                 data={"omega": float(hit.qd[2])})

        events = [Event("bottom", theta, direction=-1, callback=latch, max_hits=1),
                  Event("late", lambda t, q, qd: t - 0.9, direction=1, terminal=True)]
        results.append(run(module, t_end=2.0, events=events))
    expected, got = results
    assert [e.name for e in got.events] == [e.name for e in expected.events]
    for a, b in zip(expected.events, got.events):
        assert abs(a.t - b.t) < 1e-12 and a.data.keys() == b.data.keys()
        assert all(abs(a.data[k] - b.data[k]) < 1e-9 * max(1, abs(a.data[k])) for k in a.data)
    assert got.constraint_names == expected.constraint_names == ("pivot.x", "pivot.y",
                                                                  "pivot.lock")
    np.testing.assert_array_equal(got.times, expected.times)
    np.testing.assert_allclose(got.outputs, expected.outputs, rtol=0, atol=1e-11)
    np.testing.assert_array_equal(np.isnan(got.lam), np.isnan(expected.lam))
    assert got.stats.events == expected.stats.events == 2


def test_an_exception_in_an_event_function_is_raised_as_is(example_builds):
    def broken(t, q, qd):
        raise ZeroDivisionError("broken event")

    with pytest.raises(ZeroDivisionError, match="broken event"):
        simulate(example_builds("pendulum").c, t_end=0.5, events=[Event("b", broken)])


def test_an_exception_in_a_callback_is_raised_as_is(example_builds):
    def callback(hit):
        raise KeyError("from the callback")

    event = Event("half", lambda t, q, qd: t - 0.25, callback=callback)
    with pytest.raises(KeyError, match="from the callback"):
        simulate(example_builds("pendulum").c, t_end=0.5, events=[event])
