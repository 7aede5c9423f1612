"""The local sensitivity study (depsim.runtime.sweep.local) against a Monte Carlo of the same
spreads, small enough (1 %) for the latch times to be linear over them.

The Monte Carlo's standard deviation from n = 300 runs has a relative standard error of
about 1 / sqrt(2 n) = 4 %; the first-order prediction is compared to 20 % (five of those),
and the curvature over a 1 % spread is far below that (the latch times' second derivatives
change them by about 1e-4 of their spread)."""

import numpy as np
import pytest

import depsim
from depsim.runtime.sweep import local_study, parse_sample

SPREADS = ["h1.friction=normal(0.68, 0.0068)", "h2.preload=normal(0.85, 0.0085)",
           "cable_k=uniform(4475, 4525)"]
RUNS = 300


@pytest.fixture(scope="module")
def intelsat():
    return depsim.load("examples/intelsat5.dep").compile("c")


def test_first_order_spread_matches_a_monte_carlo(intelsat):
    samples = [parse_sample(item) for item in SPREADS]
    nominal = {d.name: d.mean for d in samples}
    result = intelsat.run(set=nominal, tol=1e-9, sensitivities=list(nominal))
    study = local_study(result, {d.name: d.std for d in samples})
    draws = np.column_stack([d.draw(1, RUNS) for d in samples])
    times = []
    for row in draws:
        run = intelsat.run(set=dict(zip(nominal, row)), tol=1e-9, dt_out=70.0)
        times.append([e.t for e in run.events])
    times = np.array(times)
    for k, event in enumerate(result.events):
        metric = study.metrics.index(f"event.{event.name}.t")
        assert study.values[metric] == event.t
        assert study.sigma[metric] == pytest.approx(np.std(times[:, k], ddof=1), rel=0.2)
    assert "time_to_deploy" in study.metrics
    text = study.text()
    assert "event.h1.latch.t" in text and "h2.preload" in text
    assert set(study.to_dict()["metrics"]["time_to_deploy"]["derivatives"]) == set(nominal)


def test_distribution_moments():
    for item, mean, std in [("x=normal(2, 0.5)", 2.0, 0.5),
                            ("x=uniform(1, 4)", 2.5, 3 / np.sqrt(12)),
                            ("x=triangular(0, 1, 4)", 5 / 3, np.sqrt((1 + 16 - 4) / 18)),
                            ("x=lognormal(2, 0.1)", 2 * np.exp(0.005),
                             2 * np.sqrt(np.exp(0.01) * np.expm1(0.01)))]:
        d = parse_sample(item)
        draws = d.draw(3, 200_000)
        assert d.mean == pytest.approx(mean, rel=1e-12)
        assert d.std == pytest.approx(std, rel=1e-12)
        assert np.mean(draws) == pytest.approx(mean, abs=5 * std / np.sqrt(len(draws)))
        assert np.std(draws) == pytest.approx(std, rel=0.02)
