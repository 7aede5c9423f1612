"""An input driven by fmpy against `depsim run` with the same input as a time table
(tests/fmu/models/motor.dep: a pendulum with hinge friction and a motor torque T_motor).

The FMU's and the run's step sequences differ (the FMU's steps end at every communication
point), so they agree to the integration error: 10 tol of each signal's scale (at least 1)."""

from __future__ import annotations

import numpy as np
import pytest
from fmpy import simulate_fmu

import depsim
from fmu_helpers import model_path

INTERVAL = 0.01
T_END = 3.0


@pytest.fixture(scope="module")
def motor():
    model = depsim.load(model_path("motor"))
    return model, model.compile(target="c")


def _error(fmu_result, result, module) -> float:
    """The largest difference of the outputs and hinge angles, relative to their scale."""
    assert np.allclose(fmu_result["time"], result.times, rtol=0, atol=1e-9)
    worst = 0.0
    pairs = [(name, np.asarray(result.outputs)[:, j]) for j, name in enumerate(module.OUTPUTS)]
    pairs += [(f"{h}.angle", np.asarray(result.hinge_angles)[:, k])
              for k, h in enumerate(module.HINGES)]
    for name, reference in pairs:
        scale = max(1.0, float(np.max(np.abs(reference))))
        worst = max(worst, float(np.max(np.abs(fmu_result[name] - reference))) / scale)
    return worst


def _signal(rows):
    return np.array(rows, dtype=[("time", float), ("T_motor", float)])


def test_step_torque(motor, fmu_path):
    """T_motor steps from 0 to 3 N*m at t = 1 s (fmpy ends a communication step there)."""
    model, sim = motor
    tol = model.ir.simulation.tol
    table = [(0.0, 0.0), (1.0, 0.0), (1.0, 3.0), (T_END, 3.0)]
    result = sim.run(inputs={"T_motor": table}, dt_out=INTERVAL, t_end=T_END)
    fmu_result = simulate_fmu(str(fmu_path("motor")), output_interval=INTERVAL,
                              stop_time=T_END, input=_signal(table),
                              output=["theta", "pivot.angle", "pivot.torque"])
    assert _error(fmu_result, result, sim.module) <= 10 * tol
    # the step moves the pendulum: without it the run is elsewhere by far more than tol
    held = sim.run(inputs={"T_motor": [(0.0, 0.0)]}, dt_out=INTERVAL, t_end=T_END)
    assert _error(fmu_result, held, sim.module) > 1e4 * tol


def _drive_ramp(slave, rate: float, derivatives: bool) -> np.ndarray:
    """A master's loop: at each communication point T_motor = rate * t, with its derivative
    (fmi2SetRealInputDerivatives) or without; returns the rows (time, theta, pivot.angle).
    (fmpy's simulate_fmu cannot send derivatives of fewer than nine inputs.)"""
    fmu, vr = slave.fmu, slave.vr
    slave.start(stop_time=T_END)
    names = ["theta", "pivot.angle"]
    rows = [(0.0, *fmu.getReal([vr[n] for n in names]))]
    steps = round(T_END / INTERVAL)
    for k in range(steps):
        t = k * INTERVAL
        fmu.setReal([vr["T_motor"]], [rate * t])
        if derivatives:
            fmu.setRealInputDerivatives([vr["T_motor"]], [1], [rate])
        fmu.doStep(t, INTERVAL)
        rows.append(((k + 1) * INTERVAL, *fmu.getReal([vr[n] for n in names])))
    return np.array(rows, dtype=[("time", float)] + [(n, float) for n in names])


def test_ramp_with_input_derivatives(motor, fmu_path, slave):
    """A torque ramp: with fmi2SetRealInputDerivatives the FMU follows the ramp inside each
    communication step and matches the run's table; held constant over each step it lags by
    about rate * interval / 2 and does not."""
    model, sim = motor
    tol = model.ir.simulation.tol
    rate = 2.0  # N*m/s
    result = sim.run(inputs={"T_motor": [(0.0, 0.0), (T_END, rate * T_END)]},
                     dt_out=INTERVAL, t_end=T_END)
    ramped = _drive_ramp(slave(fmu_path("motor")), rate, derivatives=True)
    assert _error(ramped, result, sim.module) <= 10 * tol
    held = _drive_ramp(slave(fmu_path("motor")), rate, derivatives=False)
    assert _error(held, result, sim.module) > 100 * tol


def test_input_start_value_is_the_default(motor, fmu_path):
    """Without an input signal the FMU holds T_motor at the model's default (0.5 N*m), as
    `depsim run` does."""
    model, sim = motor
    result = sim.run(dt_out=INTERVAL, t_end=1.0)
    fmu_result = simulate_fmu(str(fmu_path("motor")), output_interval=INTERVAL,
                              stop_time=1.0, output=["theta", "pivot.angle", "T_motor"])
    assert np.all(fmu_result["T_motor"] == 0.5)
    assert _error(fmu_result, result, sim.module) <= 10 * model.ir.simulation.tol
