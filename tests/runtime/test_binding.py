"""The binding of models to the integrator core: exceptions raised in a NumPy module's function
come back as they were, Ctrl-C stops a long run on either target, threads may start runs at
once in a fresh process, and a replaced module function is the one called."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from runtime_helpers import variant

from depsim.runtime import simulate

ROOT = Path(__file__).resolve().parents[2]


def test_an_exception_in_a_module_function_is_raised_as_it_was(pendulum):
    def force(q, qd, t, p):
        if t > 0.05:
            raise ArithmeticError("the model's own failure")
        return pendulum.force(q, qd, t, p)

    with pytest.raises(ArithmeticError, match="the model's own failure"):
        simulate(variant(pendulum, force=force), t_end=0.5)
    # the module's binding is not left in a failed state
    assert simulate(pendulum, t_end=0.1).times[-1] == 0.1


def test_a_replaced_module_function_is_the_one_called(pendulum):
    module = variant(pendulum)
    before = simulate(module, t_end=0.3)
    module.force = lambda q, qd, t, p: pendulum.force(q, qd, t, p) * 2.0  # gravity doubled
    after = simulate(module, t_end=0.3)
    assert not np.allclose(before.outputs, after.outputs)


SCRIPT = """
import sys, time
from depsim.codegen import compile_c, compile_numpy, load_generated
from depsim.dsl import load_model
from depsim.runtime import simulate
from depsim.runtime.binding import load_folder

target, folder = sys.argv[1], sys.argv[2]
model = load_model({model!r})
module = (load_folder(compile_c(model, folder)) if target == "c"
          else load_generated(compile_numpy(model, folder)))
print("started", flush=True)
try:
    simulate(module, t_end=1e6, tol=1e-12, dt_out=100.0, max_steps=1e12)  # hours of work
    print("completed")
except KeyboardInterrupt:
    print("interrupted")
"""


@pytest.mark.parametrize("target", ["numpy", "c"])
def test_ctrl_c_stops_a_long_run(tmp_path, target):
    """SIGINT arrives while the C core runs: the run stops and simulate raises
    KeyboardInterrupt (the core asks its progress callback every 64 steps)."""
    script = tmp_path / "run.py"
    script.write_text(textwrap.dedent(SCRIPT.format(model=str(ROOT / "examples" /
                                                              "pendulum.dep"))))
    process = subprocess.Popen([sys.executable, str(script), target, str(tmp_path / "out")],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert process.stdout.readline().strip() == "started"
    time.sleep(0.5)
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=300)
    assert out.strip() == "interrupted", err
    assert "Exception ignored" not in err


THREADS = """
import sys, threading
import numpy as np
from depsim.codegen import load_generated
from depsim.runtime import simulate

module = load_generated(sys.argv[1])
barrier, results, errors = threading.Barrier(6), [None] * 6, []

def run(k):
    barrier.wait()
    try:
        results[k] = simulate(module, t_end=0.5).outputs
    except BaseException as exc:
        errors.append(repr(exc))

threads = [threading.Thread(target=run, args=(k,)) for k in range(6)]
for t in threads: t.start()
for t in threads: t.join()
print(errors or all(np.array_equal(r, results[0]) for r in results))
"""


def test_threads_starting_runs_together_in_a_fresh_process(tmp_path):
    from depsim.codegen import compile_numpy
    from depsim.dsl import load_model

    path = compile_numpy(load_model(ROOT / "examples" / "pendulum.dep"), tmp_path)
    script = tmp_path / "threads.py"
    script.write_text(THREADS)
    done = subprocess.run([sys.executable, str(script), str(path)], capture_output=True,
                          text=True, timeout=300)
    assert done.stdout.strip() == "True", done.stdout + done.stderr
