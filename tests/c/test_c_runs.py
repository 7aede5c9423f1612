"""Full runs: the C target against the NumPy target on every example, both through the one
integrator core, with the models' own tolerances.

Criterion: every output column, and q, qd, energy, dissipated work and the multipliers (each
array against its own largest value), agree to 1e-9 of their scale, and the runs take the
very same steps. Where a model is sensitive at the round-off level (INTELSAT V's friction and
cable loops at tol 1e-8: a one-ulp change of one parameter already moves its step sequence,
and the two targets' model functions may differ in a last bit where the compiler fuses sin
and cos), the runs part and then differ by the integration error itself: the bound is then
100 tol of each array's scale (the measured error against an independent solution is about
20 tol, docs/method.md), or ten times the measured one-ulp sensitivity if that is more.
"""

from __future__ import annotations

import numpy as np
import pytest

from depsim.runtime import simulate

# example -> end time (s): the model's own, but two_link_flex is stiff (0.03 s of it is
# 3000 steps of NumPy, 4 s).
RUNS = {"pendulum": None, "slider_crank": None, "intelsat5": None, "two_link_flex": 0.03}
STEP_FOR_STEP = ("pendulum", "slider_crank", "two_link_flex")
RELATIVE = 1e-9


@pytest.fixture(scope="module")
def runs(example_builds):
    """example -> (built, NumPy Result, C Result)."""
    cache = {}

    def get(name):
        if name not in cache:
            built = example_builds(name)
            t_end = RUNS[name]
            cache[name] = (built, simulate(built.numpy, t_end=t_end),
                           simulate(built.c, t_end=t_end))
        return cache[name]

    return get


def column_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """max |a - b| per column over each column's largest |a| (0/0 = 0)."""
    scale = np.nanmax(np.abs(a), axis=0, initial=0.0)
    diff = np.nanmax(np.abs(a - b), axis=0, initial=0.0)
    return np.where(scale > 0, diff / np.where(scale > 0, scale, 1.0), diff)


def array_error(a: np.ndarray, b: np.ndarray) -> float:
    scale = float(np.nanmax(np.abs(a), initial=0.0))
    return float(np.nanmax(np.abs(a - b), initial=0.0)) / (scale or 1.0)


def sensitivity(built, reference, t_end) -> dict[str, np.ndarray]:
    """How far a run moves when the first parameter changes by one ulp."""
    p = np.array(built.numpy.PARAMETER_DEFAULTS)
    p[0] = np.nextafter(p[0], np.inf)
    moved = simulate(built.numpy, p, t_end=t_end)
    return measured(reference, moved)


def measured(a, b) -> dict[str, np.ndarray]:
    errors = {"outputs": column_error(a.outputs, b.outputs)}
    for name in ("q", "qd", "energy", "dissipated", "lam"):
        errors[name] = np.array([array_error(getattr(a, name), getattr(b, name))])
    return errors


@pytest.mark.parametrize("name", list(RUNS))
def test_c_run_agrees_with_numpy(runs, name):
    built, expected, got = runs(name)
    assert got.output_names == expected.output_names
    assert got.constraint_names == expected.constraint_names
    np.testing.assert_array_equal(got.times, expected.times)
    errors = measured(expected, got)
    if any(np.any(e > RELATIVE) for e in errors.values()):
        floor = sensitivity(built, expected, RUNS[name])
        bounds = {k: np.maximum(max(RELATIVE, 100 * expected.tol), 10 * floor[k])
                  for k in errors}
    else:
        bounds = {k: RELATIVE for k in errors}
    for key, error in errors.items():
        assert np.all(error <= bounds[key]), f"{name} {key}: {error} > {bounds[key]}"


@pytest.mark.parametrize("name", STEP_FOR_STEP)
def test_c_takes_the_same_steps(runs, name):
    _, expected, got = runs(name)
    for field in ("accepted_steps", "rejected_steps", "failed_steps", "integrations",
                  "rhs_evaluations", "cg_iterations", "position", "velocity", "acceleration"):
        assert getattr(got.stats, field) == getattr(expected.stats, field), field


def test_intelsat_is_step_for_step_before_its_sensitivity_grows(example_builds):
    """The first 15 ms of INTELSAT V (26 steps): the same steps, round-off differences only
    (against each array's scale: the folding angles are still micro-radians here)."""
    built = example_builds("intelsat5")
    expected = simulate(built.numpy, t_end=0.015, dt_out=0.001)
    got = simulate(built.c, t_end=0.015, dt_out=0.001)
    assert got.stats.accepted_steps == expected.stats.accepted_steps
    assert got.stats.rejected_steps == expected.stats.rejected_steps
    assert array_error(expected.q, got.q) < 1e-13
    assert np.max(np.abs(expected.outputs - got.outputs)) < 1e-13  # rad


def test_result_fields_match(runs):
    _, expected, got = runs("slider_crank")
    for field in ("model", "method", "parameter_names", "coordinate_names", "hinge_names",
                  "output_units", "energy_names", "dissipator_names", "tol", "constraint_tol",
                  "t_end", "dt_out"):
        assert getattr(got, field) == getattr(expected, field), field
    np.testing.assert_array_equal(got.parameters, expected.parameters)
    assert got.q.shape == expected.q.shape and got.lam.shape == expected.lam.shape
    # at output times: round-off for positions and velocities; for accelerations the
    # residual of the interpolated lambda (not a converged one), ~1e-4 here. The two targets'
    # lambdas agree only as far as the acceleration level determines them (both converge to
    # |v_acc| ~ 1e-13 at the steps; lambda moves by v_acc / the smallest eigenvalue of S), so
    # their residuals agree to a small fraction of the residual itself, not to round-off
    for level in ("residual_pos", "residual_vel"):
        assert np.max(getattr(got, level)) <= max(1e-12, 10 * np.max(getattr(expected, level)))
    assert array_error(expected.residual_acc, got.residual_acc) < 1e-3


def test_parameters_change_without_recompiling(example_builds):
    built = example_builds("pendulum")
    p = np.array(built.numpy.PARAMETER_DEFAULTS)
    p[built.numpy.PARAMETERS.index("L")] = 2.0
    expected = simulate(built.numpy, p, t_end=0.5)
    got = simulate(built.c, p, t_end=0.5)
    assert np.all(column_error(expected.outputs, got.outputs) < 1e-9)
    assert got.parameters[0] == 2.0
