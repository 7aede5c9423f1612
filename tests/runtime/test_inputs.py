"""Inputs (docs/language.md, Inputs): external loads a run drives, as constants, ramps and time
tables, in both targets, against closed-form motions and an independent joint-coordinate
solution; and the core's piecewise API (dep_open / dep_set_inputs / dep_advance) an FMU
steps with.

Tolerances: every run uses tol = 1e-10; the motions here are polynomials in t or a smooth
one-degree-of-freedom ODE, where the method's global error stays within a few tol (measured
1e-13 .. 3e-10). Bounds of 100 tol leave room for any CPU and BLAS."""

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import depsim
from depsim.runtime.binding import bind
from depsim.runtime.core import core, ffi

MODELS = Path(__file__).resolve().parent / "models"
TOL = 1e-10
BOUND = 100 * TOL
I_PIVOT = 1.0 + 1.0 * 0.5 ** 2  # the bar's inertia about its pivot (kg m^2)


@pytest.fixture(scope="module", params=["numpy", "c"])
def driven(request):
    return depsim.load(MODELS / "driven.dep").compile(target=request.param)


def twice_integrated(t, pieces):
    """theta(t) from rest for u(t) = sum of (t0, value jump, slope change) pieces / I."""
    theta = np.zeros_like(t)
    for t0, jump, slope in pieces:
        s = np.clip(t - t0, 0.0, None)
        theta += jump * s ** 2 / 2 + slope * s ** 3 / 6
    return theta / I_PIVOT


def test_constant_and_ramp_from_parameters(driven):
    result = driven.run(set={"T": "0.5 N*m", "T.rate": 0.3})
    exact = twice_integrated(result.times, [(0.0, 0.5, 0.3)])
    assert np.abs(result.output("theta") - exact).max() < BOUND


def test_time_table_with_jumps_and_ramps(driven):
    table = [(0, 0), (0.5, 0), (0.5, 1.0), (1.0, 1.0), (1.6, 1.6), (1.6, -0.4)]
    result = driven.run(inputs={"T": table})
    # a jump of 1 at 0.5, slope +1 from 1.0 to 1.6, then a jump of -2 and the slope back to 0
    exact = twice_integrated(result.times, [(0.5, 1.0, 0.0), (1.0, 0.0, 1.0),
                                            (1.6, -2.0, -1.0)])
    assert np.abs(result.output("theta") - exact).max() < BOUND
    # the input's work is in the balance: kinetic energy = work done, total stays 0
    assert np.abs(result.total_energy()).max() < BOUND
    kinetic = result.energy[:, 0]
    assert kinetic[-1] == pytest.approx(I_PIVOT * result.output("omega")[-1] ** 2 / 2)


def test_force_at_a_point_against_the_joint_coordinate_equation(driven):
    fx, fy = -0.7, 2.0
    result = driven.run(set={"F.x": fx, "F.y": fy})

    def rhs(_t, y):  # I theta'' = r_b x F, r_b = (cos theta, sin theta)
        return [y[1], (np.cos(y[0]) * fy - np.sin(y[0]) * fx) / I_PIVOT]

    reference = solve_ivp(rhs, (0, 2), [0.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-13,
                          t_eval=result.times)
    assert np.abs(result.output("theta") - reference.y[0]).max() < BOUND
    assert np.abs(result.output("omega") - reference.y[1]).max() < BOUND
    assert np.abs(result.total_energy()).max() < BOUND


def test_both_targets_agree_on_a_table():
    model = depsim.load(MODELS / "driven.dep")
    table = {"T": [(0, 0.2), (0.3, 1.0), (0.9, 1.0), (0.9, -0.5)], "F.y": 1.0}
    numpy_run, c_run = (model.compile(target=t).run(inputs=table) for t in ("numpy", "c"))
    np.testing.assert_allclose(numpy_run.output("theta"), c_run.output("theta"), rtol=0,
                               atol=BOUND)


def test_an_input_jump_frees_a_stuck_hinge_there():
    """Stuck (static friction 1 N m) under 0 and 0.5 N m; 1.5 N m from t = 0.5 s breaks it
    loose at once, then kinetic friction 0.8 N m: theta = 0.7 (t - 0.5)^2 / (2 I)."""
    result = depsim.load(MODELS / "stuck.dep").compile(target="c").run(
        inputs={"T": [(0, 0), (0.2, 0), (0.2, 0.5), (0.5, 0.5), (0.5, 1.5)]})
    slips = [e.t for e in result.events if e.name == "pivot.slip"]
    assert slips == [pytest.approx(0.5, abs=1e-12)]
    exact = np.where(result.times > 0.5, 0.7 * (result.times - 0.5) ** 2 / (2 * I_PIVOT), 0.0)
    assert np.abs(result.output("theta") - exact).max() < BOUND
    assert np.abs(result.total_energy()).max() < BOUND


@pytest.mark.parametrize("inputs, message", [
    ({"Q": 1.0}, "unknown input 'Q'; the model's inputs: T, F.x, F.y"),
    ({"T": [(0, 1), (-1, 2)]}, "times must not decrease"),
    ({"T": [(0, 1, 2)]}, "must be rows of (t, value)"),
    ({"T": [(0, float("nan"))]}, "a value that is not finite"),
])
def test_bad_tables_are_value_errors(driven, inputs, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        driven.run(inputs=inputs, t_end=0.1)


# ---- the piecewise API of the core ----------------------------------------------------------

class Piecewise:
    """dep_open / dep_set_inputs / dep_advance / dep_outputs through cffi, as an FMU calls
    them."""

    def __init__(self, sim, t_end=float("inf")):
        self.lib, self.view = core(), ffi()
        self.binding = bind(sim.module)
        settings = self.lib.dep_default_settings(self.binding.pointer)
        settings.t_end = t_end
        self.error = self.view.new("dep_error *")
        out = self.view.new("dep_run **")
        status = self.lib.dep_open(self.binding.pointer, self.view.NULL,
                                   self.view.new("dep_settings *", settings), out, self.error)
        assert status == 0, self.message
        self.run = out[0]
        self.n_in, self.n_out = self.binding.sizes["ni"], self.binding.sizes["nout"]

    @property
    def message(self) -> str:
        return self.view.string(self.error.message).decode()

    def set_inputs(self, values, rates=None):
        rates_array = self.view.NULL if rates is None else self.view.new("double[]", rates)
        return self.lib.dep_set_inputs(self.run, self.view.new("double[]", values),
                                       rates_array, self.error)

    def advance(self, t):
        return self.lib.dep_advance(self.run, t, self.error)

    def outputs(self):
        out = self.view.new("double[]", self.n_out)
        self.lib.dep_outputs(self.run, out)
        return list(out)

    def close(self):
        self.lib.dep_close(self.run)


def test_stepping_with_held_inputs_matches_the_same_table():
    """Inputs held over communication steps of 0.01 s (an FMU's default) give the run of
    the table with those steps' values: the same motion, to the method's accuracy."""
    sim = depsim.load(MODELS / "stuck.dep").compile(target="c")
    piecewise = Piecewise(sim)

    def torque(t):
        return 0.0 if t < 0.2 else 0.5 if t < 0.5 else 1.5

    times = np.round(np.arange(0.0, 1.0, 0.01), 12)
    thetas = [piecewise.outputs()[0]]
    for t0 in times:
        assert piecewise.set_inputs([torque(t0)]) == 0, piecewise.message
        assert piecewise.advance(t0 + 0.01) == 0, piecewise.message
        thetas.append(piecewise.outputs()[0])
    assert piecewise.lib.dep_time(piecewise.run) == pytest.approx(1.0, abs=1e-12)
    states = piecewise.view.new("dep_hinge_state[]", 1)
    piecewise.lib.dep_hinge_states(piecewise.run, states)
    piecewise.close()
    reference = sim.run(inputs={"T": [(0, 0), (0.2, 0), (0.2, 0.5), (0.5, 0.5), (0.5, 1.5)]})
    np.testing.assert_allclose(thetas, reference.output("theta"), rtol=0, atol=BOUND)
    assert states[0].angle == pytest.approx(thetas[-1], abs=1e-15)
    assert states[0].rate == pytest.approx(0.7 * 0.5 / I_PIVOT, abs=BOUND)
    assert states[0].torque == 0.0 and states[0].latched == 0


def test_a_ramp_over_a_step_is_exact():
    """dep_set_inputs with a rate: u = value + rate (t - now) over the step."""
    sim = depsim.load(MODELS / "driven.dep").compile(target="c")
    piecewise = Piecewise(sim, t_end=2.0)
    assert piecewise.set_inputs([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]) == 0
    assert piecewise.advance(1.0) == 0, piecewise.message
    assert piecewise.set_inputs([1.0, 0.0, 0.0], [0.0, 0.0, 0.0]) == 0
    assert piecewise.advance(2.0) == 0, piecewise.message
    theta = piecewise.outputs()[0]
    piecewise.close()
    exact = twice_integrated(np.array([2.0]), [(0.0, 0.0, 1.0), (1.0, 0.0, -1.0)])[0]
    assert theta == pytest.approx(exact, abs=BOUND)


def test_piecewise_misuse_is_an_error_not_a_crash():
    sim = depsim.load(MODELS / "driven.dep").compile(target="c")
    piecewise = Piecewise(sim, t_end=1.0)
    assert piecewise.advance(0.5) == 0
    assert piecewise.advance(0.25) == core().DEP_SETTINGS_ERROR
    assert "cannot advance to t = 0.25 s: the run is at t = 0.5 s" in piecewise.message
    assert piecewise.advance(2.0) == core().DEP_SETTINGS_ERROR
    assert piecewise.set_inputs([float("nan"), 0, 0]) == core().DEP_SETTINGS_ERROR
    assert "input T: its value and rate must be finite" in piecewise.message
    assert piecewise.advance(1.0) == 0
    piecewise.close()
