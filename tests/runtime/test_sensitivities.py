"""Forward sensitivities (docs/method.md, 12; docs/calibration.md) against central finite
differences of runs at a tight tolerance.

Tolerances. A sensitivity is compared with (y(p + h) - y(p - h)) / 2h. That quotient carries
the truncation error h^2 y''' / 6 and each run's own integration error (about tol times the
output's scale) divided by h. With a relative step of 1e-4 and tol = 1e-11 both are near 1e-7
of the sensitivity's scale; the sensitivities' own integration (the classical fourth-order
method on the step's interpolant, the state's error at tol) adds about tol times the
sensitivity's scale over the run. So agreement to 1e-5 of the largest value of the compared
history is what the method owes, with a margin of 100 over the sum of those errors.
"""

import numpy as np
import pytest

import depsim

RELATIVE_STEP = 1e-4
TOL = 1e-11
AGREEMENT = 1e-5  # of the history's largest |value| (module docstring)


@pytest.fixture(scope="module")
def pendulum():
    return depsim.load("examples/pendulum.dep").compile("c")


@pytest.fixture(scope="module")
def intelsat():
    return depsim.load("examples/intelsat5.dep").compile("c")


def finite_difference(sim, name, output, **run):
    """d output / d parameter `name` by central differences at RELATIVE_STEP."""
    p0 = sim.parameters()[sim.parameter_names.index(name)]
    h = RELATIVE_STEP * max(abs(p0), 1.0)
    ends = [sim.run(set={name: p0 + sign * h}, tol=TOL, **run).output(output)
            for sign in (1.0, -1.0)]
    return (ends[0] - ends[1]) / (2 * h)


def assert_agrees(computed, reference, what):
    scale = np.max(np.abs(reference))
    error = np.max(np.abs(computed - reference))
    assert error <= AGREEMENT * scale, f"{what}: off by {error:.3g} of {scale:.3g}"


@pytest.mark.parametrize("name", ["L", "pivot.initial_angle", "gravity.y"])
def test_pendulum_angle_against_finite_differences(pendulum, name):
    result = pendulum.run(tol=TOL, t_end=3.0, dt_out=0.05, sensitivities=[name])
    computed = result.sensitivities.output("theta", name)
    reference = finite_difference(pendulum, name, "theta", t_end=3.0, dt_out=0.05)
    assert_agrees(computed, reference, f"d theta / d {name}")


def test_pendulum_does_not_depend_on_its_mass(pendulum):
    """A uniform bar's swing is the same for any mass (its inertia is m L^2 / 12): the
    sensitivity to m is zero, to the round-off of the tangent solves."""
    result = pendulum.run(tol=TOL, t_end=3.0, dt_out=0.05, sensitivities=["m"])
    assert np.max(np.abs(result.sensitivities.output("theta", "m"))) < 1e-8


def test_unknown_parameter_is_refused(pendulum):
    with pytest.raises(ValueError, match="not a parameter"):
        pendulum.run(t_end=0.1, sensitivities=["nope"])
