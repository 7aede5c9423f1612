"""The FMU state (canGetAndSetFMUstate, canSerializeFMUstate) through fmpy: a state got at t1,
the steps to t2, the state set back and the steps to t2 again give the same outputs bit for
bit, as an instance that never saved does; also through bytes (fmi2SerializeFMUstate) read
back in the same instance and in another one, across latches engaging, hard stops,
stick-slip and a hold-down's release, and inputs set between the steps."""

from __future__ import annotations

import ctypes
import math

import numpy as np
import pytest


def observed(s) -> np.ndarray:
    """Every Real variable and every Boolean one at the current communication point."""
    reals = [v.valueReference for v in s.description.modelVariables if v.type == "Real"]
    booleans = [v.valueReference for v in s.description.modelVariables if v.type == "Boolean"]
    values = list(s.fmu.getReal(reals))
    values += [float(b) for b in (s.fmu.getBoolean(booleans) if booleans else [])]
    return np.array(values)


def steps(s, t0, t1, h, inputs=None) -> np.ndarray:
    """fmi2DoStep from t0 to t1 by h (inputs(t) set before each step); what each gives."""
    rows, n = [], int(round((t1 - t0) / h))
    for k in range(n):
        t = t0 + k * h
        if inputs is not None:
            for name, value in inputs(t).items():
                s.fmu.setReal([s.vr[name]], [value])
        s.fmu.doStep(t, h)
        rows.append(observed(s))
    return np.array(rows)


def same_bits(a: np.ndarray, b: np.ndarray) -> None:
    assert a.shape == b.shape and a.size > 0
    assert np.array_equal(a.view(np.int64), b.view(np.int64))


def motor_torque(t: float) -> dict:
    return {"T_motor": 2.0 * math.sin(3.0 * t) + (1.5 if t >= 1.0 else 0.0)}


CASES = {  # FMU, save at, steps to, step size, stop time, inputs
    "intelsat5": ("intelsat5", 40.0, 60.0, 0.5, None, None),
    "stops": ("stops", 1.0, 3.0, 0.05, 4.0, None),
    "motor": ("motor", 0.8, 2.0, 0.02, None, motor_torque),
    "free_flyer": ("free_flyer", 1.5, 20.0, 0.25, None, None),  # held at the save
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_state_set_back_gives_the_same_steps(fmu_path, slave, case):
    name, t1, t2, h, stop, inputs = CASES[case]
    path = fmu_path(name)
    reference = slave(path)
    reference.start(stop_time=stop)
    steps(reference, 0.0, t1, h, inputs)
    expected = steps(reference, t1, t2, h, inputs)
    if name in ("intelsat5", "free_flyer"):  # a latch engages between t1 and t2
        latched = [v.valueReference for v in reference.description.modelVariables
                   if v.type == "Boolean"]
        assert 0 < sum(expected[-1, -len(latched):]) > sum(expected[0, -len(latched):])

    s = slave(path)
    s.start(stop_time=stop)
    steps(s, 0.0, t1, h, inputs)
    state = s.fmu.getFMUstate()
    data = s.fmu.serializeFMUstate(state)
    same_bits(steps(s, t1, t2, h, inputs), expected)
    s.fmu.setFMUstate(state)  # the instance's own run: its memory put back
    assert s.real("time") == t1
    same_bits(steps(s, t1, t2, h, inputs), expected)
    again = s.fmu.deSerializeFMUstate(data)  # bytes read back in the same instance
    s.fmu.setFMUstate(again)
    same_bits(steps(s, t1, t2, h, inputs), expected)
    s.fmu.freeFMUstate(state)
    s.fmu.freeFMUstate(again)

    other = slave(path)  # another instance, only instantiated: the run's calls made again
    elsewhere = other.fmu.deSerializeFMUstate(data)
    other.fmu.setFMUstate(elsewhere)
    same_bits(steps(other, t1, t2, h, inputs), expected)
    other.fmu.freeFMUstate(elsewhere)
    assert not s.log.errors() and not other.log.errors()


def test_a_state_with_inputs_set_for_the_next_step(fmu_path, slave):
    """Inputs set (a value and a rate) but not yet heard by the run are part of the state."""
    path = fmu_path("motor")
    runs = []
    for save in (False, True):
        s = slave(path)
        s.start()
        steps(s, 0.0, 0.5, 0.05)
        s.fmu.setReal([s.vr["T_motor"]], [1.25])
        s.fmu.setRealInputDerivatives([s.vr["T_motor"]], [1], [0.5])
        if save:
            state = s.fmu.getFMUstate()
            steps(s, 0.5, 1.0, 0.05, motor_torque)
            s.fmu.setFMUstate(state)
        runs.append(steps(s, 0.5, 1.0, 0.05))
    same_bits(runs[1], runs[0])


def test_states_before_the_run_and_after_it(fmu_path, slave):
    """A state in the instantiated state keeps the parameters set; one of a run that was
    terminated since opens the run again (its calls repeated); getting into a state given
    back reuses it."""
    s = slave(fmu_path("pendulum"))
    s.fmu.setReal([s.vr["L"]], [2.0])
    before = s.fmu.getFMUstate()
    s.fmu.setReal([s.vr["L"]], [3.0])
    s.fmu.setFMUstate(before)
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    assert s.real("L") == 2.0
    s.fmu.exitInitializationMode()
    steps(s, 0.0, 0.5, 0.1)
    state = s.fmu.getFMUstate()
    expected = steps(s, 0.5, 1.0, 0.1)
    s.fmu.terminate()
    s.fmu.setFMUstate(state)
    same_bits(steps(s, 0.5, 1.0, 0.1), expected)
    s.fmu.fmi2GetFMUstate(s.fmu.component, ctypes.byref(state))  # the same state, now at 1.0
    later = steps(s, 1.0, 1.5, 0.1)
    s.fmu.setFMUstate(state)
    same_bits(steps(s, 1.0, 1.5, 0.1), later)
    for used in (before, state):
        s.fmu.freeFMUstate(used)
    assert not s.log.errors()
