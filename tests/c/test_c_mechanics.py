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


ARRAYS = ("outputs", "q", "energy", "dissipated", "hinge_torque", "lam")
RELATIVE = 1e-8


def differences(a, b) -> dict[str, float]:
    """Each array's largest difference over its scale (at least 1), and the events'
    largest time difference (s)."""
    found = {}
    for name in ARRAYS:
        x, y = getattr(a, name), getattr(b, name)
        scale = max(1.0, float(np.nanmax(np.abs(x), initial=0.0)))
        found[name] = float(np.nanmax(np.abs(x - y), initial=0.0)) / scale
    found["event times"] = max((abs(e.t - f.t) for e, f in zip(a.events, b.events)),
                               default=0.0)
    return found


@pytest.fixture(scope="module")
def bounds(runs):
    """case -> the allowed difference of each quantity between the two targets: RELATIVE,
    or ten times how far one ulp in the first parameter moves the C run where that is more
    (a latching INTELSAT V is sensitive to round-off: no two evaluations of its model
    functions may differ in a last bit for tighter agreement to be physical)."""
    cache = {}

    def get(case):
        if case not in cache:
            _, c_module, p, _, got = runs(case)
            moved_p = p.copy()
            moved_p[0] = np.nextafter(moved_p[0], np.inf)
            moved = simulate(c_module, moved_p, t_end=CASES[case][2])
            cache[case] = {k: max(RELATIVE, 10 * v)
                           for k, v in differences(got, moved).items()}
        return cache[case]

    return get


@pytest.mark.parametrize("case", list(CASES))
def test_same_events(runs, bounds, case):
    *_, expected, got = runs(case)
    assert [e.name for e in got.events] == [e.name for e in expected.events]
    assert expected.events, "the case should exercise the mechanism"
    allowed = bounds(case)["event times"]
    for a, b in zip(expected.events, got.events):
        assert abs(a.t - b.t) <= allowed * max(1.0, a.t), a.name
        assert close(a.data, b.data, rtol=max(1e-9, allowed)), (a.name, a.data, b.data)


@pytest.mark.parametrize("case", ["pendulum_stops", "compliant_latch", "pendulum_at_stop"])
def test_same_steps(runs, case):
    """Models without round-off sensitivity take the very same steps on both targets."""
    *_, expected, got = runs(case)
    for field in ("accepted_steps", "rejected_steps", "failed_steps", "events"):
        assert getattr(got.stats, field) == getattr(expected.stats, field), field


@pytest.mark.parametrize("case", list(CASES))
def test_same_results(runs, bounds, case):
    *_, expected, got = runs(case)
    assert got.constraint_names == expected.constraint_names
    assert got.energy_names == expected.energy_names
    assert got.dissipator_names == expected.dissipator_names
    assert got.latch_hinges == expected.latch_hinges
    allowed = bounds(case)
    found = differences(expected, got)
    for name in ARRAYS:
        np.testing.assert_array_equal(np.isnan(getattr(expected, name)),
                                      np.isnan(getattr(got, name)), err_msg=name)
        assert found[name] <= allowed[name], (name, found[name], allowed[name])
    scale = max(allowed.values())
    np.testing.assert_allclose(got.total_energy(), expected.total_energy(), rtol=0,
                               atol=max(1e-8, scale))
    for hinge, peak in expected.peak_loads.items():
        other = got.peak_loads[hinge]
        assert abs(other.force - peak.force) <= scale * max(1.0, peak.force), hinge
        assert abs(other.torque - peak.torque) <= scale * max(1.0, peak.torque), hinge


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
