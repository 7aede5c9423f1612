"""Error paths of the FMU: every refused call returns fmi2Error with its reason in the log
(category logError) and leaves the instance refusing steps until fmi2Reset; the CLI's
refusals leave no file behind."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from fmpy.fmi1 import FMICallException

from fmu_helpers import model_path

FMI2_ERROR = 3


def _raises_error(call, *args):
    with pytest.raises(FMICallException) as caught:
        call(*args)
    assert caught.value.status == FMI2_ERROR


def test_unknown_value_reference(fmu_path, slave):
    s = slave(fmu_path("pendulum"))
    s.start()
    _raises_error(s.fmu.getReal, [10_000])
    assert any("unknown value reference 10000" in m for m in s.log.errors())
    # the instance refuses to step on
    _raises_error(s.fmu.doStep, 0.0, 0.01)
    assert "not allowed in state error" in s.log.errors()[-1]


def test_outputs_cannot_be_set(fmu_path, slave):
    s = slave(fmu_path("intelsat5"))
    s.start()
    _raises_error(s.fmu.setReal, [s.vr["theta1"]], [1.0])
    assert "'theta1' is an output" in s.log.errors()[-1]
    t = slave(fmu_path("intelsat5"))
    t.start()
    _raises_error(t.fmu.setBoolean, [t.vr["h1.latched"]], [True])
    assert "'h1.latched' is an output" in t.log.errors()[-1]


def test_parameter_after_initialization(fmu_path, slave):
    """A parameter is fixed: settable before fmi2ExitInitializationMode only; after fmi2Reset
    it can be set again and the run uses it."""
    s = slave(fmu_path("pendulum"))
    s.start()
    _raises_error(s.fmu.setReal, [s.vr["L"]], [2.0])
    assert "parameter 'L' is fixed once initialization ends" in s.log.errors()[-1]
    s.fmu.reset()
    s.start({"L": 2.0, "pivot.initial_angle": 0.5})
    assert s.real("L") == 2.0
    assert s.real("theta") == pytest.approx(0.5, abs=1e-12)


def test_null_and_non_finite_arguments(fmu_path, slave):
    s = slave(fmu_path("pendulum"))
    s.fmu.setupExperiment(startTime=0.0)
    _raises_error(s.fmu.setReal, [s.vr["L"]], [float("nan")])
    assert "the value for 'L' is not a finite number" in s.log.errors()[-1]
    s.fmu.reset()
    status = s.fmu.dll.fmi2SetReal(s.fmu.component, None, 1, None)
    assert status == FMI2_ERROR
    assert "vr or value is NULL" in s.log.errors()[-1]


def test_values_out_of_the_models_ranges_are_refused_when_set(fmu_path, slave):
    """fmi2SetReal refuses a value that breaks a range of the model text (as `depsim run
    --set` does), with the reason, before fmi2EnterInitializationMode and in initialization
    mode alike; nothing is stored; fmi2Reset starts afresh and the model's values run."""
    s = slave(fmu_path("fourbar"))
    _raises_error(s.fmu.setReal, [s.vr["crank"]], [-0.1])
    assert s.log.errors() == ["fmi2SetReal: crank_bar.length must be positive, got -0.1 m "
                              "(from crank = -0.1 m)"]
    s.fmu.reset()
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    assert s.real("crank") == 0.1  # the refused value was not kept
    _raises_error(s.fmu.setReal, [s.vr["drive.damping"]], [-0.5])
    assert s.log.errors()[-1] == ("fmi2SetReal: drive.damping must not be negative, got -0.5 "
                                  "N*m*s/rad")
    _raises_error(s.fmu.exitInitializationMode)  # the instance refuses to go on
    s.fmu.reset()
    s.start({"drive.damping": 0.5, "crank": 0.12})
    s.fmu.doStep(0.0, 0.1)
    assert s.real("crank") == 0.12


def test_the_ranges_of_springs_particles_and_hold_downs_are_refused_when_set(fmu_path, slave):
    """examples/free_flyer.dep: a spring's stiffness and free length, a member's mass and the
    hold-downs' release (from the parameter t_release) are held to the model text's ranges as
    any other value; the model's values then run."""
    s = slave(fmu_path("free_flyer"))
    _raises_error(s.fmu.setReal, [s.vr["kick.stiffness"]], [-1000.0])
    assert s.log.errors() == ["fmi2SetReal: kick.stiffness must not be negative, got -1000 N/m"]
    s.fmu.reset()
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    _raises_error(s.fmu.setReal, [s.vr["t_release"]], [-1.0])
    assert s.log.errors()[-1] == (
        "fmi2SetReal: h1.release must not be negative, got -1 s (from t_release = -1 s); "
        "h2.release must not be negative, got -1 s (from t_release = -1 s)")
    s.fmu.reset()
    s.start({"kick.free_length": 0.1, "t_release": 0.5})
    s.fmu.doStep(0.0, 0.1)
    assert s.real("t_release") == 0.5


def test_a_range_between_two_parameters_is_checked_once_both_can_be_set(fmu_path, slave):
    """stop_min < stop_max: one call setting both is checked at once; separate calls may pass
    through a pair out of order, and the pair is checked when initialization ends."""
    s = slave(fmu_path("stops"))
    stop_min, stop_max = s.vr["pivot.stop_min"], s.vr["pivot.stop_max"]
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    _raises_error(s.fmu.setReal, [stop_min, stop_max], [2.0, 1.5])
    assert s.log.errors() == ["fmi2SetReal: pivot.stop_min must be less than pivot.stop_max, "
                              "got 2 rad and 1.5 rad (from pivot.stop_max = 1.5 rad)"]
    s.fmu.reset()
    s.start({"pivot.stop_min": 2.0, "pivot.stop_max": 3.0, "pivot.initial_angle": 2.5})
    s.fmu.doStep(0.0, 0.1)
    s.fmu.reset()
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    s.fmu.setReal([stop_min], [2.0])  # stop_max is still 75 deg
    _raises_error(s.fmu.exitInitializationMode)
    assert s.log.errors()[-1] == ("pivot.stop_min must be less than pivot.stop_max, got 2 rad "
                                  "and 1.309 rad")


def test_states_that_are_no_states_of_this_fmu(fmu_path, slave):
    """Bytes of another FMU, or damaged, and a state pointer that is none: fmi2Error with the
    reason, the instance as it was before the call otherwise."""
    from fmpy.fmi2 import fmi2FMUstate

    s = slave(fmu_path("pendulum"))
    s.start()
    s.fmu.doStep(0.0, 0.1)
    data = s.fmu.serializeFMUstate(s.fmu.getFMUstate())
    t = slave(fmu_path("motor"))
    t.start()
    _raises_error(t.fmu.deSerializeFMUstate, data)
    assert "are not a state of this FMU" in t.log.errors()[-1]
    u = slave(fmu_path("pendulum"))
    u.start()
    damaged = bytearray(data)
    damaged[-20] ^= 0xFF
    _raises_error(u.fmu.deSerializeFMUstate, bytes(damaged))
    assert "these bytes are not a saved state of this model's run" in u.log.errors()[-1]
    v = slave(fmu_path("pendulum"))
    v.start()
    _raises_error(v.fmu.setFMUstate, fmi2FMUstate())  # NULL
    assert "FMUstate is not a state of this FMU" in v.log.errors()[-1]


def test_loops_that_cannot_close(fmu_path, slave):
    """Initial values set through the FMU that no pose satisfies: fmi2ExitInitializationMode
    fails with the solver's own message (as `depsim run --set` prints it)."""
    s = slave(fmu_path("slider_crank"))
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    s.fmu.setReal([s.vr["crank_pin.initial_angle"]], [2.0])
    _raises_error(s.fmu.exitInitializationMode)
    (message,) = s.log.errors()
    assert "initial state" in message and "cannot all hold" in message


def test_failure_inside_a_step(fmu_path, slave):
    """A solver failure during fmi2DoStep: fmi2Error, the SolverError text in the log, the
    time of the last successful step kept, and no further step."""
    s = slave(fmu_path("pendulum"))
    s.start({"pivot.initial_angle": 1.0}, stop_time=10.0)
    s.fmu.doStep(0.0, 0.5)
    _raises_error(s.fmu.doStep, 0.5, 20.0)  # passes stopTime
    assert "passes stopTime 10" in s.log.errors()[-1]
    assert s.fmu.getRealStatus(2) == 0.5  # fmi2LastSuccessfulTime


def test_stiff_run_stops_with_the_solver_message(fmu_path, slave):
    """Friction regularised over 1e-6 rad/s damps the pendulum where it creeps at about 3e5 1/s,
    which holds the step near 1e-5 s: the core's step-budget failure (the run would pass
    max_steps), raised in fmi2DoStep with its full text and hint naming the hinge; the last
    successful time is the step before."""
    s = slave(fmu_path("motor"))
    s.start({"pivot.slip_rate": 1e-6}, stop_time=1000.0)
    t = 0.0
    with pytest.raises(FMICallException) as caught:
        while t < 10.0:
            s.fmu.doStep(t, 0.01)
            t += 0.01
    assert caught.value.status == FMI2_ERROR
    (message,) = s.log.errors()
    assert "step size: the model is stiff here: hinge pivot's friction" in message
    assert "hint: a larger slip_rate on pivot" in message
    assert s.fmu.getRealStatus(2) == pytest.approx(t)  # fmi2LastSuccessfulTime
    assert 1.0 < t < 10.0


def _depsim(*args, cwd=None, env=None):
    return subprocess.run([sys.executable, "-m", "depsim", *args], capture_output=True,
                          text=True, cwd=cwd, env=env)


def test_cli_bad_paths(tmp_path):
    model = str(model_path("pendulum"))
    (tmp_path / "folder.fmu").mkdir()
    for out, said in [(tmp_path / "missing" / "p.fmu", "does not exist"),
                      (tmp_path / "p.zip", "unknown format '.zip'"),
                      (tmp_path / "folder.fmu", "it is a folder")]:
        run = _depsim("compile", model, "--target", "fmu", "-o", str(out))
        assert run.returncode == 2
        assert said in run.stderr and "Traceback" not in run.stderr
    assert sorted(os.listdir(tmp_path)) == ["folder.fmu"]
    assert os.listdir(tmp_path / "folder.fmu") == []


def test_cli_compiler_failure(tmp_path):
    """The C compiler fails: one clear error, exit code 2, no file and no temporary left."""
    env = {**os.environ, "CC": "false"}
    run = _depsim("compile", str(model_path("pendulum")), "--target", "fmu", "-o",
                  str(tmp_path / "p.fmu"), env=env)
    assert run.returncode == 2
    assert run.stderr.startswith("depsim: error: building the FMU's binary failed")
    assert "Traceback" not in run.stderr
    assert os.listdir(tmp_path) == []


def test_cli_default_name(tmp_path, fmu_path):
    """Without -o: <model>.fmu in the current folder, byte for byte the FMU compile_fmu
    writes (the archive is reproducible)."""
    run = _depsim("compile", str(model_path("pendulum")), "--target", "fmu", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert os.listdir(tmp_path) == ["pendulum.fmu"]
    assert (tmp_path / "pendulum.fmu").read_bytes() == fmu_path("pendulum").read_bytes()
