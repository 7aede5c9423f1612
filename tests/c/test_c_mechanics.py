"""Latches, hard stops and stick-slip friction (depsim.runtime's deployment mechanics) in the
C integrator: the same steps, mode changes, records, hinge loads and energies as Python.

Models: INTELSAT V with its hinge friction lowered to 0.3 N m so that two rigid latches
engage within the run (the default deploys after 40 s); tests/c/models/pendulum_stops.dep
(hard stops with plastic impacts and releases, stick-slip friction); pendulum_at_stop.dep
(starting at rest against a stop: modes settled at t = 0); compliant_latch.dep (a
spring-damper latch pressed and left twice)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from depsim.codegen import compile_c, compile_numpy, derive, load_generated
from depsim.dsl import load_model
from depsim.runtime import Event, simulate
from depsim.runtime.binding import load_folder

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
CASES = {  # name -> (model path, parameter changes, t_end)
    "intelsat5_latching": (ROOT / "examples" / "intelsat5.dep",
                           {f"h{k}.friction": 0.3 for k in range(1, 5)}, 17.0),
    "pendulum_stops": (HERE / "models" / "pendulum_stops.dep", {}, 4.0),
    "compliant_latch": (HERE / "models" / "compliant_latch.dep", {}, 3.0),
    "pendulum_at_stop": (HERE / "models" / "pendulum_at_stop.dep", {}, 2.0),
}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """case -> (NumPy module, C module, p, NumPy Result, C Result)."""
    cache = {}

    def get(case):
        if case not in cache:
            path, changes, t_end = CASES[case]
            model = load_model(path)
            system = derive(model)
            root = tmp_path_factory.mktemp(case)
            numpy_module = load_generated(compile_numpy(model, root / "numpy", system))
            c_module = load_folder(compile_c(model, root / "c", system))
            p = np.array(numpy_module.PARAMETER_DEFAULTS)
            for name, value in changes.items():
                p[numpy_module.PARAMETERS.index(name)] = value
            cache[case] = (numpy_module, c_module, p, simulate(numpy_module, p, t_end=t_end),
                           simulate(c_module, p, t_end=t_end))
        return cache[case]

    return get


def close(a, b, rtol=1e-9, atol=1e-12) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(close(a[k], b[k], rtol, atol) for k in a)
    if isinstance(a, float) and isinstance(b, float):
        return abs(a - b) <= atol + rtol * abs(a)
    return a == b


@pytest.mark.parametrize("case", list(CASES))
def test_same_steps_and_events(runs, case):
    *_, expected, got = runs(case)
    for field in ("accepted_steps", "rejected_steps", "failed_steps", "events"):
        assert getattr(got.stats, field) == getattr(expected.stats, field), field
    assert [e.name for e in got.events] == [e.name for e in expected.events]
    assert expected.events, "the case should exercise the mechanism"
    for a, b in zip(expected.events, got.events):
        assert abs(a.t - b.t) <= 1e-9 * max(1.0, a.t), a.name
        assert close(a.data, b.data), (a.name, a.data, b.data)


@pytest.mark.parametrize("case", list(CASES))
def test_same_results(runs, case):
    *_, expected, got = runs(case)
    assert got.constraint_names == expected.constraint_names
    assert got.energy_names == expected.energy_names
    assert got.dissipator_names == expected.dissipator_names
    assert got.latch_hinges == expected.latch_hinges
    for name in ("outputs", "q", "energy", "dissipated", "hinge_torque", "lam"):
        a, b = getattr(expected, name), getattr(got, name)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=name)
        scale = max(1.0, float(np.nanmax(np.abs(a), initial=0.0)))
        assert np.nanmax(np.abs(a - b), initial=0.0) <= 1e-8 * scale, name
    np.testing.assert_allclose(got.total_energy(), expected.total_energy(), rtol=0, atol=1e-8)
    for hinge, peak in expected.peak_loads.items():
        other = got.peak_loads[hinge]
        assert abs(other.force - peak.force) <= 1e-8 * max(1.0, peak.force), hinge
        assert abs(other.torque - peak.torque) <= 1e-8 * max(1.0, peak.torque), hinge


def test_deployment_summary_agrees(runs):
    *_, expected, got = runs("intelsat5_latching")
    a, b = expected.deployment, got.deployment
    assert [r.hinge for r in b.latches] == [r.hinge for r in a.latches] == ["h4", "h3"]
    for x, y in zip(a.latches, b.latches):
        assert close(x.t, y.t) and close(x.rate, y.rate) and close(x.impulse, y.impulse)
    assert close(a.friction_energy, b.friction_energy)
    assert close(a.impact_energy, b.impact_energy)


def test_without_mechanics(runs):
    numpy_module, c_module, p, _, _ = runs("pendulum_stops")
    expected = simulate(numpy_module, p, t_end=1.0, mechanics=False)
    got = simulate(c_module, p, t_end=1.0, mechanics=False)
    assert not got.events and got.dissipator_names == expected.dissipator_names
    np.testing.assert_allclose(got.outputs, expected.outputs, rtol=0, atol=1e-10)


def test_user_events_watching_multipliers(runs):
    """A user event with multipliers=True beside the mechanism's: stop when the pivot's
    vertical reaction first exceeds 30 N."""
    results = []
    for run, module in ((simulate, runs("pendulum_stops")[0]), (simulate,
                                                                runs("pendulum_stops")[1])):
        event = Event("heavy", lambda t, q, qd, lam: 30.0 - lam["pivot.y"], direction=-1,
                      terminal=True, multipliers=True)
        results.append(run(module, t_end=4.0, events=[event]))
    expected, got = results
    assert [e.name for e in got.events] == [e.name for e in expected.events]
    assert got.events[-1].name == "heavy"
    assert abs(got.events[-1].t - expected.events[-1].t) < 1e-9


def test_program_prints_the_python_report(runs, tmp_path):
    """`./<model> -o CSV` prints Result.report(); the residual line holds round-off values."""
    import subprocess

    from depsim.codegen.c_emit import c_program_name
    path, changes, t_end = CASES["intelsat5_latching"]
    model = load_model(path)
    folder = compile_c(model, tmp_path / "c")
    name = c_program_name(model)
    subprocess.run(["make", "-s", "-C", str(folder), name], check=True)
    arguments = [f"--set={k}={v!r}" for k, v in changes.items()]
    run = subprocess.run([str(folder / name), *arguments, "--t-end", repr(t_end),
                          "-o", str(tmp_path / "out.csv")], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    *_, expected, _ = runs("intelsat5_latching")

    def comparable(text):
        return [line for line in text.splitlines() if "constraint residuals" not in line]

    assert comparable(run.stdout) == comparable(expected.report())
