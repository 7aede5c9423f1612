"""The FMU's binary built with AddressSanitizer and UBSan, driven by fmpy in a fresh Python
(LD_PRELOAD of the compiler's libasan): a deployment with latches, an input step, and the
error paths (unknown value reference, a parameter after initialization, a solver failure
inside a step), FMU states saved, written, read back and set in the same instance and
in another, run without a finding."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

from depsim.runtime.core import compiler

HELPERS = Path(__file__).resolve().parent

SCRIPT = textwrap.dedent("""
    import sys
    import numpy as np
    from fmpy import simulate_fmu
    from fmpy.fmi1 import FMICallException
    sys.path.insert(0, sys.argv[1])
    from fmu_helpers import Slave

    intelsat, motor = sys.argv[2:4]
    result = simulate_fmu(intelsat, output_interval=0.01, stop_time=60.0,
                          output=["theta1", "h1.latched", "h2.force_x", "h2.torque"])
    assert result["h1.latched"][-1], "h1 latches at about 51 s"
    signal = np.array([(0.0, 0.0), (1.0, 0.0), (1.0, 3.0), (2.0, 3.0)],
                      dtype=[("time", float), ("T_motor", float)])
    simulate_fmu(motor, output_interval=0.01, stop_time=2.0, input=signal)

    def refused(call, *args):
        try:
            call(*args)
        except FMICallException as exc:
            assert exc.status == 3
            return
        raise AssertionError("not refused")

    s = Slave(motor, loggingOn=True)
    s.start()
    refused(s.fmu.getReal, [100000])
    s.fmu.reset()
    s.start()
    refused(s.fmu.setReal, [s.vr["rod.mass"]], [3.0])
    s.fmu.reset()
    s.start()
    for k in range(20):
        s.fmu.setReal([s.vr["T_motor"]], [0.2 * k])
        s.fmu.doStep(0.05 * k, 0.05)
    state = s.fmu.getFMUstate()
    data = s.fmu.serializeFMUstate(state)
    s.fmu.doStep(1.0, 0.5)
    s.fmu.setFMUstate(state)
    s.fmu.setFMUstate(s.fmu.deSerializeFMUstate(data))
    s.fmu.doStep(1.0, 0.5)
    refused(s.fmu.deSerializeFMUstate, data[:-3])
    s.fmu.reset()
    other = Slave(motor)
    other.fmu.setFMUstate(other.fmu.deSerializeFMUstate(data))
    other.fmu.doStep(1.0, 0.5)
    other.fmu.freeFMUstate(other.fmu.getFMUstate())
    other.free()
    s.fmu.freeFMUstate(state)
    s.start({"pivot.slip_rate": 1e-6}, stop_time=1000.0)
    t = 0.0
    try:
        while t < 10.0:
            s.fmu.setReal([s.vr["T_motor"]], [0.1 * t])
            s.fmu.setRealInputDerivatives([s.vr["T_motor"]], [1], [0.1])
            s.fmu.doStep(t, 0.01)
            t += 0.01
        raise AssertionError("the stiff run did not fail")
    except FMICallException:
        pass
    assert s.log.errors()
    s.free()
    print("clean")
""")


def test_asan_ubsan_clean(fmu_path, tmp_path):
    runtime = subprocess.run([*compiler(), "-print-file-name=libasan.so"], capture_output=True,
                             text=True).stdout.strip()
    assert os.path.isabs(runtime), f"the C compiler has no AddressSanitizer runtime ({runtime})"
    script = tmp_path / "drive.py"
    script.write_text(SCRIPT)
    env = {**os.environ, "LD_PRELOAD": runtime, "ASAN_OPTIONS": "detect_leaks=0",
           "UBSAN_OPTIONS": "halt_on_error=1:print_stacktrace=1"}
    run = subprocess.run([sys.executable, str(script), str(HELPERS),
                          str(fmu_path("intelsat5", sanitize=True)),
                          str(fmu_path("motor", sanitize=True))],
                         capture_output=True, text=True, env=env, timeout=300)
    report = run.stdout + run.stderr
    assert "AddressSanitizer" not in report and "runtime error" not in report, report
    assert run.returncode == 0 and run.stdout.strip().endswith("clean"), report
