"""The FMU under fmpy against `depsim run --target c` (the Python API on the same core).

Both integrate the same model with the same tolerance `tol`; the FMU's steps also end at each
communication point (every 0.01 s), so the two step sequences differ and the results agree
to the integration error, not to round-off. Outputs and hinge angles are compared at the
output times to 10 tol of each signal's scale (at least 1), latch times to the output
interval (the FMU's `<hinge>.latched` turns 1 at the first communication point after the
latch engaged)."""

from __future__ import annotations

import numpy as np
import pytest
from fmpy import simulate_fmu

import depsim
from fmu_helpers import model_path

INTERVAL = 0.01


# The FMU lands on every communication point, so it steps differently from one run to
# t_end: the two agree to the method's global error, not to round-off. At tol 1e-8 each is
# within about 30 tol of an independent joint-coordinate solution of INTELSAT V over the
# deployment (docs/method.md), and they are measured 7-14 tol apart (the friction's stick
# and slip amplify round-off-level differences of lambda); the bound allows 30.
AGREE = 30


@pytest.fixture(scope="module")
def intelsat():
    model = depsim.load(model_path("intelsat5"))
    return model, model.compile(target="c")


def _agree(fmu_result, result, module, tol):
    """Outputs and hinge angles at every output time within AGREE tol of their scale;
    latches at the same times (to the output interval)."""
    assert len(fmu_result) == len(result.times)
    assert np.allclose(fmu_result["time"], result.times, rtol=0, atol=1e-9)
    signals = [(name, np.asarray(result.outputs)[:, j]) for j, name in enumerate(module.OUTPUTS)]
    signals += [(f"{h}.angle", np.asarray(result.hinge_angles)[:, k])
                for k, h in enumerate(module.HINGES)]
    worst = 0.0
    for name, reference in signals:
        scale = max(1.0, float(np.max(np.abs(reference))))
        error = float(np.max(np.abs(fmu_result[name] - reference))) / scale
        assert error <= AGREE * tol, f"{name}: {error:.3g} of its scale"
        worst = max(worst, error)
    latches = {r.hinge: r.t for r in result.deployment.latches}
    for hinge in result.deployment.latch_hinges:
        latched = np.flatnonzero(fmu_result[f"{hinge}.latched"])
        if hinge not in latches:
            assert latched.size == 0, hinge
            continue
        t_fmu = fmu_result["time"][latched[0]]
        assert latches[hinge] <= t_fmu + 1e-6 and t_fmu - latches[hinge] <= INTERVAL + 1e-6, \
            f"{hinge}: FMU {t_fmu}, run {latches[hinge]}"
    return worst


def _outputs(module):
    return (list(module.OUTPUTS) + [f"{h}.angle" for h in module.HINGES]
            + [f"{h}.latched" for h in module.HINGES])


def test_intelsat5_deployment(intelsat, fmu_path):
    """The full 80 s deployment with its four latches."""
    model, sim = intelsat
    tol = model.ir.simulation.tol
    result = sim.run(dt_out=INTERVAL)
    assert result.deployment.deployed
    fmu_result = simulate_fmu(str(fmu_path("intelsat5")), output_interval=INTERVAL,
                              stop_time=model.ir.simulation.t_end, output=_outputs(sim.module))
    _agree(fmu_result, result, sim.module, tol)


def test_intelsat5_parameters_through_the_fmu(intelsat, fmu_path):
    """Start values set through the FMU equal `--set` of the same parameters: more friction
    at h2, less preload at h1 (30 s)."""
    model, sim = intelsat
    tol = model.ir.simulation.tol
    changes = {"h2.friction": 0.75, "h1.preload": 1.5}
    result = sim.run(set=changes, dt_out=INTERVAL, t_end=30.0)
    fmu_result = simulate_fmu(str(fmu_path("intelsat5")), output_interval=INTERVAL,
                              stop_time=30.0, start_values=changes,
                              output=_outputs(sim.module))
    _agree(fmu_result, result, sim.module, tol)
    defaults = sim.run(dt_out=INTERVAL, t_end=30.0)
    moved = np.max(np.abs(np.asarray(defaults.outputs) - np.asarray(result.outputs)))
    assert moved > 1000 * tol  # the change matters, so the agreement says something


def test_the_linearly_implicit_step_through_the_fmu(fmu_path):
    """two_link_flex (docs/beams.md) switches to the linearly implicit step within its first
    millisecond; through the FMU every step also ends at a communication point, where the step
    size it holds for K, D and W to serve (docs/method.md, 10) must resume after the cut. Each
    run is within the step's global error of the converged solution at tol 1e-8 over 0.5 s
    (docs/method.md, 10: 8.6e-7 rad in chord2, 1.9e-5 m in tip2), so they agree to twice
    that (measured: 1.1e-8 rad, 1.4e-7 m)."""
    sim = depsim.load(model_path("two_link_flex")).compile(target="c")
    result = sim.run(dt_out=INTERVAL, t_end=0.5)
    assert result.stats.implicit_from < 0.01
    fmu_result = simulate_fmu(str(fmu_path("two_link_flex")), output_interval=INTERVAL,
                              stop_time=0.5, output=["chord2", "tip2"])
    assert len(fmu_result) == len(result.times)
    for name, bound in (("chord2", 2 * 8.6e-7), ("tip2", 2 * 1.9e-5)):
        assert np.max(np.abs(fmu_result[name] - result.output(name))) <= bound, name


def test_the_free_flyers_loads_and_momentum_through_the_fmu(fmu_path):
    """examples/free_flyer.dep: its outputs of hinge loads, spring force, system momentum and
    energies, read from the FMU (the core's run values and multipliers at each communication
    point), as the run gives them. The kick-off spring's switch at its free length is found
    by the step control, not located (docs/language.md, spring): the FMU's steps, which end
    at each communication point, meet it elsewhere: the two agree to 1000 tol (measured 250
    tol on the hinge angle after it). At the release itself (t = 2 s, a communication point)
    the FMU gives the state after the event, the run the state its output time reached first
    (held): that instant is left out."""
    model = depsim.load(model_path("free_flyer"))
    sim = model.compile(target="c")
    result = sim.run(dt_out=INTERVAL, t_end=6.0)
    fmu_result = simulate_fmu(str(fmu_path("free_flyer")), output_interval=INTERVAL,
                              stop_time=6.0, output=list(sim.module.OUTPUTS))
    compared = np.abs(result.times - 2.0) > 1e-9
    for name in sim.module.OUTPUTS:
        reference = result.output(name)[compared]
        scale = max(1.0, float(np.max(np.abs(reference))))
        error = float(np.max(np.abs(fmu_result[name][compared] - reference))) / scale
        assert error <= 1000 * result.tol, f"{name}: {error:.3g} of its scale"


def test_a_spatial_model_through_the_fmu(fmu_path):
    """The README's reflector arm (a spatial model, tests/fmu/models/arm.dep): its outputs,
    hinge angles and the latch sequence through the FMU, as the run gives them (to the
    method's global error, as INTELSAT V's); its 3-D hinge force, which jumps at the latch
    impacts, to where the two step sequences meet them (measured 58 tol of 1 N)."""
    model = depsim.load(model_path("arm"))
    sim = model.compile(target="c")
    result = sim.run(dt_out=INTERVAL)
    assert result.deployment.deployed
    names = _outputs(sim.module) + [f"{h}.force_{axis}" for h in sim.module.HINGES
                                    for axis in "xyz"]
    fmu_result = simulate_fmu(str(fmu_path("arm")), output_interval=INTERVAL,
                              stop_time=model.ir.simulation.t_end, output=names)
    _agree(fmu_result, result, sim.module, result.tol)
    loads = result.hinge_loads["shoulder"]
    np.testing.assert_allclose(fmu_result["shoulder.force_z"], loads.force_z, rtol=0,
                               atol=300 * result.tol * max(1.0, np.max(np.abs(loads.force_z))))
