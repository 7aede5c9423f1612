"""RunEnds: a study's runs read at their end alone give the numbers of the whole run's Result
(the same dep_simulate call), on both targets, run after run; failures raise as simulate's."""

import math

import numpy as np
import pytest

from depsim.runtime import SolverError, simulate
from depsim.runtime.runner import RunEnds
from depsim.runtime.sweep.metrics import evaluate
from runtime_helpers import variant

# Two bars sprung into their latches, h1 against friction (in zero gravity): events with
# data (rate, impulse, energy lost), friction work, peak loads; deployed for P = 4 and 6 N m,
# not for 0.5 (h1 stays short of its latch).
LATCHING = """model latching "two bars sprung into their latches against friction"
param P = 4 N*m
bar bar1 { length = 1 m; mass = 2 kg; inertia = 0.2 kg*m^2 }
bar bar2 { length = 0.8 m; mass = 1 kg; inertia = 0.05 kg*m^2 }
hinge h1 joins ground.origin to bar1.a {
    preload = P
    friction = 0.3 N*m
    latch = 60 deg
}
hinge h2 joins bar1.b to bar2.a {
    preload = 1 N*m
    latch = 45 deg
}
simulate { t_end = 3 s; tol = 1e-9; dt_out = 0.01 s }
output theta1 = h1
output theta2 = h2
"""


@pytest.fixture(params=["numpy", "c"])
def latching(request, build, build_c):
    return build(LATCHING) if request.param == "numpy" else build_c(LATCHING)


def same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def test_the_end_holds_the_whole_runs_numbers(latching):
    ends = RunEnds(latching, dt_out=float(latching.T_END))
    deployed = []
    for preload in (4.0, 0.5, 6.0, 4.0):  # run after run through one RunEnds
        p = np.array(latching.PARAMETER_DEFAULTS, dtype=float)
        p[list(latching.PARAMETERS).index("P")] = preload
        end = ends.run(p)
        result = simulate(latching, p, dt_out=float(latching.T_END))
        assert np.array_equal(end.parameters, result.parameters)
        assert end.outputs.shape == (1, len(result.output_names))
        assert np.array_equal(end.outputs[0], result.outputs[-1])
        assert np.array_equal(end.dissipated[0], result.dissipated[-1])
        assert end.dissipator_names == result.dissipator_names
        assert end.events == result.events and end.stats == result.stats
        assert repr(end.deployment) == repr(result.deployment)  # NaN where nothing latched
        assert repr(end.peak_loads) == repr(result.peak_loads)
        assert end.output("theta2")[-1] == result.output("theta2")[-1]
        # the study's metrics: the same names in the same order, bit for bit
        got, _ = evaluate(end, latching, None)
        want, _ = evaluate(result, latching, None)
        assert list(got) == list(want)
        assert all(same(got[name], want[name]) for name in want), preload
        deployed.append(got["deployed"])
    assert deployed == [1.0, 0.0, 1.0, 1.0]
    assert "event.h1.latch.impulse" in got and "dissipated.friction" in got


def test_a_failing_run_raises_as_simulate_and_the_next_runs(latching, build):
    ends = RunEnds(latching, t_end=0.5)
    bad = np.array(latching.PARAMETER_DEFAULTS, dtype=float)
    bad[list(latching.PARAMETERS).index("bar1.mass")] = -1.0
    with pytest.raises(ValueError) as caught:
        ends.run(bad)
    with pytest.raises(ValueError) as plain:
        simulate(latching, bad, t_end=0.5)
    assert str(caught.value) == str(plain.value)
    assert ends.run(None).stats == simulate(latching, t_end=0.5).stats
    with pytest.raises(SolverError, match="tol"):
        RunEnds(latching, t_end=0.5, tol=1e-18).run(None)
    if latching.__class__.__name__ != "CModule":  # a NumPy model's function that raises
        broken = [True]

        def force(*args):
            if broken[0]:
                raise ZeroDivisionError("in force")
            return latching.force(*args)

        failing = RunEnds(variant(latching, force=force), t_end=0.5)
        with pytest.raises(ZeroDivisionError, match="in force"):
            failing.run(None)
        broken[0] = False  # the failure is not carried into the next run
        assert failing.run(None).stats == simulate(latching, t_end=0.5).stats
