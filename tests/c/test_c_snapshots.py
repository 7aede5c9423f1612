"""A run's state saved and put back (dep_save, dep_restore, dep_snapshot_read/write): after a
restore the run goes on bit for bit as it went on from the save, across latches, stops,
stick-slip, a hold-down's release and input changes; into the same run (its memory copied
back) and into another run or from bytes (its calls made again). The continuation without any
save is the reference."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from depsim.codegen.c_emit import compile_c
from depsim.dsl import load_model
from depsim.runtime.binding import load_folder
from depsim.runtime.core import core, ffi

ROOT = Path(__file__).resolve().parents[2]


class Run:
    """One dep_open run of a C model through the core library."""

    def __init__(self, module, t_end=math.inf):
        self.view, self.library, self.module = ffi(), core(), module
        self.error = self.view.new("dep_error *")
        settings = self.view.new("dep_settings *", self.library.dep_default_settings(
            module.pointer))
        settings.t_end = t_end
        self.handle = self.view.new("dep_run **")
        self.check(self.library.dep_open(module.pointer, self.view.NULL, settings, self.handle,
                                         self.error))

    @property
    def run(self):
        return self.handle[0]

    def check(self, status):
        assert status == 0, self.view.string(self.error.message).decode()

    def advance(self, t):
        self.check(self.library.dep_advance(self.run, t, self.error))

    def inputs(self, values):
        array = self.view.new("double[]", list(values) or [0.0])
        self.check(self.library.dep_set_inputs(self.run, array, self.view.NULL, self.error))

    def observe(self) -> np.ndarray:
        """Time, outputs and every hinge's observables at the current state."""
        m = self.module.pointer
        outputs = self.view.new("double[]", max(m.nout, 1))
        hinges = self.view.new("dep_hinge_state[]", max(m.nh, 1))
        self.library.dep_outputs(self.run, outputs)
        self.library.dep_hinge_states(self.run, hinges)
        row = [self.library.dep_time(self.run)] + [outputs[k] for k in range(m.nout)]
        for h in hinges[0:m.nh]:
            row += [h.angle, h.rate, h.force_x, h.force_y, h.torque, h.latched]
        return np.array(row)

    def save(self):
        snapshot = self.view.new("dep_snapshot **")
        self.check(self.library.dep_save(self.run, snapshot, self.error))
        return self.view.gc(snapshot[0], self.library.dep_snapshot_free)

    def restore(self, snapshot):
        self.check(self.library.dep_restore(self.handle, snapshot, self.error))

    def close(self):
        self.library.dep_close(self.run)
        self.handle[0] = self.view.NULL


def as_bytes(snapshot) -> bytes:
    view, library = ffi(), core()
    buffer = view.new("unsigned char[]", library.dep_snapshot_size(snapshot))
    library.dep_snapshot_write(snapshot, buffer)
    return bytes(view.buffer(buffer))


def read(module, data: bytes):
    view, library = ffi(), core()
    snapshot, error = view.new("dep_snapshot **"), view.new("dep_error *")
    status = library.dep_snapshot_read(module.pointer, data, len(data), snapshot, error)
    return status, view.string(error.message).decode(), (
        view.gc(snapshot[0], library.dep_snapshot_free) if status == 0 else None)


def steps(run: Run, times, inputs=None) -> np.ndarray:
    """Advance to each time (inputs(t) set before each step); the observations after each."""
    rows = []
    for t0, t1 in zip(times[:-1], times[1:]):
        if inputs is not None:
            run.inputs(inputs(t0))
        run.advance(t1)
        rows.append(run.observe())
    return np.array(rows)


def same_bits(a: np.ndarray, b: np.ndarray) -> None:
    assert a.shape == b.shape
    assert np.array_equal(a.view(np.int64), b.view(np.int64))


@pytest.fixture(scope="module")
def models(example_builds, tmp_path_factory):
    def get(name):
        if name in ("intelsat5", "fourbar", "free_flyer"):
            return example_builds(name).c
        path = ROOT / "tests" / "fmu" / "models" / f"{name}.dep"
        return load_folder(compile_c(load_model(path), tmp_path_factory.mktemp(name)))

    return get


def motor_torque(t):
    return [3.0 * math.sin(4.0 * t) + (2.0 if t > 0.9 else 0.0)]


CASES = {  # model, communication points before the save, after it, the inputs
    "intelsat5": ("intelsat5", np.arange(0.0, 40.5, 0.5), np.arange(40.0, 60.5, 0.5), None),
    "stops": ("stops", np.arange(0.0, 1.01, 0.05), np.arange(1.0, 3.01, 0.05), None),
    "motor": ("motor", np.arange(0.0, 0.81, 0.02), np.arange(0.8, 2.01, 0.02), motor_torque),
    # saved while the hold-downs hold; restored, the release, the kick-off spring, the
    # latches and the outputs of loads and momentum go on as they went on
    "free_flyer": ("free_flyer", np.arange(0.0, 1.51, 0.25), np.arange(1.5, 20.01, 0.25), None),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_restored_run_goes_on_as_it_went_on(models, case):
    name, before, after, inputs = CASES[case]
    module = models(name)
    reference = Run(module)
    steps(reference, before, inputs)
    expected = steps(reference, after, inputs)
    latched = expected[:, 1 + module.sizes["nout"] + 5::6].sum(axis=1)
    if name in ("intelsat5", "free_flyer"):  # a latch engages between the save and the end
        assert latched[-1] > latched[0]

    run = Run(module)
    steps(run, before, inputs)
    saved, pointer = run.save(), run.run
    data = as_bytes(saved)
    same_bits(steps(run, after, inputs), expected)
    run.restore(saved)  # the same run: its memory copied back
    assert run.run == pointer
    same_bits(steps(run, after, inputs), expected)
    status, _, again = read(module, data)
    assert status == 0
    run.restore(again)  # read back from bytes, into the same run: still its memory
    assert run.run == pointer
    same_bits(steps(run, after, inputs), expected)

    other = Run(module)  # another run: the calls made again
    steps(other, before[:5], inputs)
    other.restore(again)
    assert other.run != pointer
    same_bits(steps(other, after, inputs), expected)
    other.restore(saved)  # a snapshot of another run
    same_bits(steps(other, after, inputs), expected)
    for r in (reference, run, other):
        r.close()


def test_a_snapshot_into_no_run_opens_one(models):
    module = models("stops")
    run = Run(module)
    steps(run, np.arange(0.0, 0.51, 0.1))
    saved = run.save()
    expected = steps(run, np.arange(0.5, 1.01, 0.1))
    run.close()
    run.restore(saved)  # *run was NULL
    same_bits(steps(run, np.arange(0.5, 1.01, 0.1)), expected)
    run.close()


def test_bytes_that_are_no_snapshot_of_the_model(models):
    stops, fourbar = models("stops"), models("fourbar")
    run = Run(stops)
    run.advance(0.2)
    data = as_bytes(run.save())
    run.close()
    assert read(stops, data)[0] == 0
    damaged = bytearray(data)
    damaged[len(damaged) // 2] ^= 1
    for model, text in ((stops, bytes(damaged)), (stops, data[:-9]), (stops, b""),
                        (fourbar, data)):
        status, message, _ = read(model, text)
        assert status == core().DEP_SETTINGS_ERROR
        assert message.startswith("these bytes are not a saved state of this model's run")
