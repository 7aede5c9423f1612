"""The fit engine (depsim.runtime.fit, docs/calibration.md) on synthetic ground tests of
INTELSAT V: parameters recovered within their reported intervals, a pair the data cannot
separate flagged, the Jacobian against finite differences, the covariance of singular
Jacobians.

The synthetic test: the model run at TRUTH (tol 1e-10, far below the noise), theta1..theta4
sampled at 100 Hz to T_END, Gaussian noise of NOISE rad (seed 1); latch times with noise of
LATCH_NOISE s. The four kinetic frictions are fitted: a hinge's preload and friction enter
almost only as their difference while it opens (correlation 0.9999, docs/calibration.md), so
freeing both of one hinge tests identifiability, not recovery. The fit starts 20 % below the
truth: 20 % above, the array does not deploy within the run (the latches are missed).
"""

import numpy as np
import pytest

import depsim
from depsim.runtime import fit as engine
from depsim.runtime.fit_result import uncertainty

TRUTH = {"h1.friction": 0.62, "h2.friction": 0.70, "h3.friction": 0.64, "h4.friction": 0.75}
T_END = 72.0  # s: the last latch (h3) at 68.1 s
NOISE = 1e-3  # rad
LATCH_NOISE = 0.01  # s
TOL = 1e-8  # the fit's runs


@pytest.fixture(scope="module")
def intelsat():
    return depsim.load("examples/intelsat5.dep").compile("c")


@pytest.fixture(scope="module")
def measured(intelsat):
    """The synthetic ground test: Measurements with time histories and latch times."""
    run = intelsat.run(set=TRUTH, tol=1e-10, t_end=T_END, dt_out=0.01)
    rng = np.random.default_rng(1)
    latches = [e for e in run.events if e.kind == "latch"]
    assert [e.name for e in latches] == ["h1.latch", "h2.latch", "h4.latch", "h3.latch"]
    return engine.Measurements(
        columns=run.output_names, units=run.output_units, times=run.times,
        values=run.outputs + rng.normal(0, NOISE, run.outputs.shape),
        sigmas=np.full(len(run.output_names), np.nan),
        events=tuple(e.name for e in latches),
        event_times=np.array([e.t for e in latches]) + rng.normal(0, LATCH_NOISE, 4),
        event_sigmas=np.full(4, LATCH_NOISE), sources=("synthetic",))


def free(sim, names, factor=0.8, low=0.0, high=2.0):
    return [engine.FreeParameter(name, sim.parameter_names.index(name),
                                 factor * TRUTH.get(name, sim.defaults[
                                     sim.parameter_names.index(name)]), low, high, "N*m")
            for name in names]


def run_fit(sim, data, names, **free_options):
    parameters = free(sim, names, **free_options)
    dt_out = engine.output_interval(data.times, T_END, 0.05)
    return engine.fit(sim.tangent_module(), sim.defaults, parameters, data,
                      settings=engine.Settings(T_END, dt_out, TOL), model="intelsat5")


def histories_only(data):
    return engine.Measurements(columns=data.columns, units=data.units, times=data.times,
                               values=data.values, sigmas=data.sigmas, sources=data.sources)


@pytest.mark.parametrize("with_latches", [False, True], ids=["histories", "and-latch-times"])
def test_recovers_the_frictions_within_two_sigma(intelsat, measured, with_latches):
    data = measured if with_latches else histories_only(measured)
    fit = run_fit(intelsat, data, list(TRUTH))
    truth = np.array(list(TRUTH.values()))
    print(f"\n{fit.report()}")
    assert fit.converged and all(fit.identifiable) and not any(fit.notes)
    low, high = fit.intervals.T
    assert np.all((low <= truth) & (truth <= high)), (fit.estimates, fit.standard_errors)
    # the noise estimated from the residuals is the noise put in (7200 samples a column)
    assert np.allclose(fit.sigmas, NOISE, rtol=0.05)
    assert fit.sigmas_estimated == (True,) * 4
    assert np.all(fit.standard_errors < 1e-3 * truth)  # the data determine them well
    if with_latches:
        assert fit.event_sigmas_estimated == (False,) * 4
        assert np.all(np.abs(fit.event_fitted - fit.event_measured) < 4 * LATCH_NOISE)
    assert fit.runs <= 30 and fit.iterations >= 1


def test_a_pair_entering_as_one_product_is_not_identifiable(intelsat, measured):
    """cable_k and pulley_r enter INTELSAT V only as cable_k * pulley_r^2."""
    fit = run_fit(intelsat, histories_only(measured), ["cable_k", "pulley_r", "h1.friction"],
                  factor=1.0, low=-np.inf, high=np.inf)
    assert fit.identifiable == (False, False, True)
    assert np.all(np.isinf(fit.standard_errors[:2])) and np.isfinite(fit.standard_errors[2])
    assert abs(fit.correlation[0, 1]) > 0.999
    assert "not identifiable from these data" in fit.notes[0] and "pulley_r" in fit.notes[0]
    summary = fit.summary()["parameters"]
    assert summary["cable_k"]["standard_error"] is None
    assert summary["cable_k"]["interval_2sigma"] == [None, None]
    assert "not identifiable" in fit.report()


def test_the_jacobian_is_the_residuals_derivative(intelsat, measured):
    """Against central differences of the residuals, away from the latch times (where a
    difference straddles the kink)."""
    parameters = free(intelsat, list(TRUTH), factor=0.99)
    runs = engine._Runs(intelsat.tangent_module(), intelsat.defaults, parameters, measured,
                        engine.Settings(T_END, 0.005, 1e-10), None)
    x = np.array([f.start for f in parameters])
    at = runs.at(x)
    times = np.concatenate([measured.times] * 4)
    away = np.min(np.abs(times[:, None] - at.event_times[None, :]), axis=1) > 0.05
    for i in range(len(x)):
        h = 1e-5 * x[i]
        step = np.eye(len(x))[i] * h
        difference = (runs.at(x + step).residuals - runs.at(x - step).residuals) / (2 * h)
        column = at.jacobian[:, i]
        assert np.abs(difference[:len(times)][away] - column[:len(times)][away]).max() \
            < 1e-3 * np.abs(column).max()
        assert np.allclose(difference[len(times):], column[len(times):], rtol=1e-3)


def test_a_missed_event_at_the_start_is_an_error(intelsat, measured):
    """20 % more friction: the array does not deploy by T_END."""
    with pytest.raises(engine.MissingEventError, match="does not happen") as caught:
        run_fit(intelsat, measured, list(TRUTH), factor=1.2)
    assert "h1.friction = 0.744 N*m" in str(caught.value)
    assert caught.value.index == 0


def test_uncertainty_of_a_singular_jacobian():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(50, 1))
    jacobian = np.hstack((a, 2 * a, rng.normal(size=(50, 1))))  # column 2 = 2 x column 1
    found = uncertainty(jacobian, np.ones(3))
    assert found.identifiable == (False, False, True)
    assert np.isinf(found.standard_errors[:2]).all()
    assert found.correlation[0, 1] == pytest.approx(-1, abs=1e-6)
    regular = uncertainty(rng.normal(size=(50, 3)), np.array([1.0, 1e3, 1e-3]))
    j = rng.normal(size=(50, 3))
    exact = np.linalg.inv(j.T @ j)
    scaled = uncertainty(j, np.array([1.0, 1e3, 1e-3]))
    assert np.allclose(scaled.standard_errors, np.sqrt(np.diag(exact)), rtol=1e-10)
    assert all(regular.identifiable)
    fewer = uncertainty(rng.normal(size=(2, 3)), np.ones(3))  # fewer values than parameters
    assert not all(fewer.identifiable)
