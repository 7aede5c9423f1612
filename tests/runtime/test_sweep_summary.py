"""Reading a study (runtime/sweep/summary.py, probability.py, plot.py) on studies made by hand
with known values (study_fixtures.py): P(not deployed) and P(metric > limit) with their exact
intervals, units everywhere, metrics that vary only by round-off left out and not ranked, and
a figure that shows deployment first and stays legible with 4 or 40 latches."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from depsim.runtime.sweep import plot_study, summarize
from depsim.runtime.sweep.plot import study_figure
from depsim.runtime.sweep.probability import beta_cdf, exceedance, not_deployed, probability
from depsim.runtime.sweep.summary import metric_table, varying
from study_fixtures import deployment_study


@pytest.fixture(scope="module")
def study():
    return deployment_study(latches=4, runs=200)


@pytest.mark.parametrize("k, n", [(0, 200), (17, 198), (3, 10), (10, 10), (1, 1)])
def test_the_interval_is_clopper_pearsons(k, n):
    from scipy.stats import binomtest

    interval = binomtest(k, n).proportion_ci(confidence_level=0.95, method="exact")
    got = probability(k, n)
    assert got.p == k / n
    assert got.low == pytest.approx(interval.low, abs=1e-12)
    assert got.high == pytest.approx(interval.high, abs=1e-12)


@pytest.mark.parametrize("n", [1, 2, 5, 37, 200, 1999, 10_000])
@pytest.mark.parametrize("confidence", [0.95, 0.99, 0.5])
def test_the_interval_is_scipys_betaincinv_without_scipy(n, confidence):
    """The beta quantiles computed here (no scipy import in a study's summary) against
    scipy.special.betaincinv, for every k from the ends to the middle: within 1e-9 of the
    value (lgamma of 10,000 carries 1e-11)."""
    from scipy.special import betaincinv

    tail = (1 - confidence) / 2
    for k in sorted({0, 1, 2, 3, n // 7, n // 2, n - 3, n - 2, n - 1, n} & set(range(n + 1))):
        got = probability(k, n, confidence)
        low = 0.0 if k == 0 else float(betaincinv(k, n - k + 1, tail))
        high = 1.0 if k == n else float(betaincinv(k + 1, n - k, 1 - tail))
        assert got.low == pytest.approx(low, rel=1e-9, abs=1e-300), (k, n)
        assert got.high == pytest.approx(high, rel=1e-9), (k, n)


def test_the_beta_cdf_is_scipys_betainc():
    """Within 1e-10 (a = 5000: lgamma's round-off, 1e-11 of the prefactor), 1e-13 below."""
    from scipy.special import betainc

    for a, b in [(1, 1), (3, 7), (100, 2), (0.5, 0.5), (5000, 5001), (1, 9999)]:
        for x in np.linspace(0.0, 1.0, 41):
            assert beta_cdf(x, a, b) == pytest.approx(float(betainc(a, b, x)),
                                                      abs=1e-10 if a > 1000 else 1e-13)


def test_no_failure_in_n_runs_bounds_the_probability_by_the_rule_of_three():
    """k = 0: the upper end solves (1 - p)^n = 0.025, about 3.7 / n (the 'rule of three'
    at 97.5 %)."""
    got = probability(0, 200)
    assert got.low == 0 and got.high == pytest.approx(1 - 0.025 ** (1 / 200), rel=1e-12)


def test_not_deploying_and_a_load_above_a_limit_are_counted_over_completed_runs(study):
    preload = study["preload"].values
    completed = ~study["failed"].values
    stuck = completed & (preload < 1.55)  # the fixture's runs that do not deploy
    assert 0 < stuck.sum() < completed.sum()
    missing = not_deployed(study)
    assert (missing.k, missing.n) == (stuck.sum(), completed.sum())
    torque = 4 * preload + 0.1 * study["friction"].values  # the fixture's peak.h1.torque
    above = exceedance(study, "peak.h1.torque", 7.2)
    assert (above.k, above.n) == ((torque[completed] > 7.2).sum(), completed.sum())
    text = summarize(study, limits={"peak.h1.torque": 7.2})
    assert f"deployed in {missing.n - missing.k} of {missing.n} completed runs; " \
           f"P(not deployed) = {100 * missing.p:.1f} % (95 % CI {100 * missing.low:.1f} to " \
           f"{100 * missing.high:.1f} %, Clopper-Pearson; {missing.k} of {missing.n} runs)" \
           in text
    assert f"P(peak.h1.torque > 7.2 N*m) = {100 * above.p:.1f} %" in text


def test_every_metric_is_shown_in_its_own_unit(study):
    lines = {line.split()[0]: line.split() for line in summarize(study).splitlines()
             if line.startswith(("time_to_deploy", "event.", "peak.", "final.", "stats."))}
    assert lines["time_to_deploy"][1] == "s" and lines["event.h1.latch.t"][1] == "s"
    assert lines["event.h1.latch.impulse"][1] == "N*m*s"
    assert lines["peak.h1.torque"][1] == "N*m" and lines["peak.h1.force"][1] == "N"
    assert lines["final.tip_y"][1] == "m"
    # the fixture's tip_y varies by a millimetre on 8 m: the percentiles show it
    p5, p50, p95 = map(float, lines["final.tip_y"][2:5])
    expected = np.percentile(study["final.tip_y"].values[~study["failed"].values], [5, 50, 95])
    assert p5 < p50 < p95 and np.allclose([p5, p50, p95], expected, rtol=1e-6)


def test_metrics_that_vary_by_round_off_are_left_out_and_not_ranked(study):
    """tip_x is 0 to 1e-14 m and theta1 is held at 90 deg to 1e-11 rad (both well inside
    tol x scale); the latch angles are constant; all of them are listed once as not
    varying, with their value, and get no drivers."""
    varies = varying(study)
    steady = {"final.tip_x", "final.theta1", "event.h1.latch.angle", "event.h4.latch.angle"}
    assert not any(varies[name] for name in steady)
    assert all(varies[name] for name in ("final.tip_y", "time_to_deploy", "peak.h4.torque"))
    assert np.ptp(study["final.tip_x"].values[~study["failed"].values]) > 0  # not exactly 0
    rows = {row["metric"]: row for row in metric_table(study)}
    assert all(rows[name]["drivers"] == [] for name in steady)
    text = summarize(study)
    table = text.split("not varying")[0]
    assert not any(line.startswith(tuple(steady)) for line in table.splitlines())
    assert "final.theta1 = 90 deg" in text and "event.h4.latch.angle = 180 deg" in text


def test_the_figure_shows_deployment_first_then_latches_and_loads(study, tmp_path):
    figure = study_figure(study, limits={"peak.h1.torque": 7.2})
    titles = [ax.get_title() for part in figure.subfigs for ax in part.axes]
    assert titles[0].startswith("share of runs deployed by time t")
    assert titles[1].startswith("P(not deployed) = ")
    assert [t.split(":")[0] for t in titles[2:5]] == ["latch times", "peak lock torques",
                                                       "peak hinge forces"]
    assert any(t.startswith("Spearman rank correlation") for t in titles)
    assert any(t.startswith("what drives time_to_deploy") for t in titles)
    latch_axis = figure.subfigs[1].axes[0]
    assert [t.get_text() for t in latch_axis.get_yticklabels()] == ["h1", "h2", "h3", "h4"]
    assert latch_axis.get_xlabel() == "latch time [s]"
    png = plot_study(study, tmp_path / "study.png", limits={"peak.h1.torque": 7.2})
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("latches", [4, 40])
def test_labels_never_overlap_with_4_or_40_latches(latches):
    """Every panel's tick labels, drawn: no two along one axis overlap (a latch's name, a
    metric's row), and none is smaller than 7 points."""
    figure = study_figure(deployment_study(latches=latches, runs=120))
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    for ax in figure.axes:
        for labels in (ax.get_yticklabels(), ax.get_xticklabels()):
            labels = [t for t in labels if t.get_text()]
            boxes = [t.get_window_extent(renderer) for t in labels]
            for a, b in itertools.combinations(boxes, 2):
                assert not a.overlaps(b), (ax.get_title(), latches)
            assert all(t.get_fontsize() >= 7 for t in labels)
    heights = figure.get_size_inches()[1]
    assert (heights > 20) == (latches == 40)  # the figure grows with the rows, not shrinks


def test_a_study_without_latches_shows_the_distributions(study):
    plain = study.drop_vars([n for n in study.data_vars
                             if n in ("deployed", "time_to_deploy") or n.startswith(("event.",
                                                                                     "peak."))])
    figure = study_figure(plain)
    first = figure.subfigs[0].axes[0]
    assert first.get_ylabel() == "share of runs <= x"
    assert "P(not deployed)" not in summarize(plain)
    assert not math.isnan(float(metric_table(plain)[0]["p50"]))


def test_one_run_is_one_run():
    text = summarize(deployment_study(runs=1, failed=()))
    assert "monte carlo, 1 run, 0 failed" in text
    assert "deployed in 1 of 1 completed run; P(not deployed) = 0.0 % (95 % CI 0.0 to " \
           "97.5 %, Clopper-Pearson; 0 of 1 run)" in text
    figure = study_figure(deployment_study(runs=1, failed=()))
    assert figure.texts[0].get_text().endswith(": 1 run, 0 failed")
    assert figure.subfigs[0].axes[1].get_xlabel() == "share of the run"
