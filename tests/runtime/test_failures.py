"""Failures are loud: SolverError names the time, the pass, the joint and what to try."""

import numpy as np
import pytest
from runtime_helpers import variant

from depsim.runtime import SolverError, simulate


def drifting_pin(pendulum, start=0.1, rate=1e-2):
    """A second hinge `pin` repeating pivot.x, redundant (and consistent) until t = start, then
    asking x_a = rate (t - start)^3: two rows that can no longer both hold."""
    def shift(t, k):
        s = max(0.0, t - start)
        return (rate * s ** 3, 3 * rate * s ** 2, 6 * rate * s)[k]

    def phi(q, t, p):
        base = pendulum.phi(q, t, p)
        return np.append(base, base[0] - shift(t, 0))

    def phi_q(q, t, p):
        values = pendulum.phi_q(q, t, p)
        return np.concatenate((values, values[:2]))

    def gamma(q, qd, t, p):
        base = pendulum.gamma(q, qd, t, p)
        return np.append(base, base[0] + shift(t, 2))

    def phi_q_transpose_times(q, t, p, lam):  # the third row repeats the first's values
        return pendulum.phi_q_transpose_times(q, t, p, np.array([lam[0] + lam[2], lam[1]]))

    return variant(pendulum, NC=3, CONSTRAINTS=("pivot.x", "pivot.y", "pin.x"),
                   CONSTRAINT_JOINTS=("pivot", "pivot", "pin"), HINGES=("pivot", "pin"),
                   HINGE_WRAPS=(0, 0),
                   CONSTRAINT_HINGES=(0, 0, 1), CONSTRAINT_SLIDERS=(-1, -1, -1),
                   PHI_Q_ROWS=(0, 0, 1, 1, 2, 2), PHI_Q_COLS=(0, 2, 1, 2, 0, 2), phi=phi,
                   phi_q=phi_q, phi_q_transpose_times=phi_q_transpose_times, gamma=gamma,
                   phi_t=lambda q, t, p: np.array([0.0, 0.0, -shift(t, 1)]),
                   hinge_angles=lambda q, p: np.repeat(pendulum.hinge_angles(q, p), 2),
                   hinge_rates=lambda q, qd, p: np.repeat(pendulum.hinge_rates(q, qd, p), 2),
                   HINGE_JACOBIAN_ROWS=(0, 1), HINGE_JACOBIAN_COLS=(2, 2),
                   hinge_jacobian=lambda q, p: np.repeat(pendulum.hinge_jacobian(q, p), 2),
                   hinge_gamma=lambda q, qd, p: np.zeros(2),
                   hinge_properties=lambda p: np.full((2, len(pendulum.HINGE_PROPERTIES)), np.nan))


def test_a_dead_point_is_passed_on_its_branch(slider_crank):
    """With rod length = crank length the loop has dead points at 90 and 270 degrees (piston
    at the crank pivot) where Phi_q loses rank and two branches cross: the piston at
    x = 2 r cos(theta), or held at x = 0. The run passes them (the weak direction deflated,
    docs/method.md, Scale, rank and singular positions) and keeps to the branch it moves on,
    as the mechanism's inertia does: x = 2 r cos(theta) throughout, to the position pass's
    limits."""
    p = np.array(slider_crank.PARAMETER_DEFAULTS)
    p[1] = p[0]  # l = r
    p[8], p[9], p[10] = 0.0, np.radians(60), 5.0  # start at 60 deg, turning towards 90
    tol, r = 1e-9, p[0]
    result = simulate(slider_crank, p, t_end=1.0, tol=tol)
    theta, x = result.output("crank_angle"), result.output("piston_x")
    passed = np.count_nonzero(np.diff(np.sign(np.cos(theta))) != 0)
    assert passed >= 2  # through 90 deg on the way up and again on the way back
    assert np.max(np.abs(x - 2 * r * np.cos(theta))) < tol * r


def test_redundant_rows_that_become_inconsistent_fail_where_they_part(pendulum):
    module = drifting_pin(pendulum)
    # while the rows agree the redundancy is harmless: conjugate gradients solve the
    # consistent singular system
    early = simulate(module, t_end=0.09, tol=1e-9, dt_out=0.01)
    reference = simulate(pendulum, t_end=0.09, tol=1e-9, dt_out=0.01)
    assert np.max(np.abs(early.outputs - reference.outputs)) < 1e-8
    with pytest.raises(SolverError) as caught:
        simulate(module, t_end=0.5, tol=1e-9)
    error = caught.value
    assert 0.1 <= error.t < 0.11
    assert error.stage in ("position", "velocity", "acceleration")
    assert error.joint in ("hinge pivot", "hinge pin")
    assert f"t = {error.t:.9g} s" in str(error)


def test_an_inconsistent_initial_state_names_the_joint(slider_crank):
    def tree_pose(v, p):
        q = slider_crank.tree_pose(v, p).copy()
        q[5] += 1e-3  # the rod angle no longer closes the loop
        return q

    module = variant(slider_crank, tree_pose=tree_pose)
    with pytest.raises(SolverError) as caught:
        simulate(module, t_end=0.1)
    error = caught.value
    assert error.stage == "initial state" and error.t == 0.0
    assert error.joint in ("hinge wrist", "hinge gudgeon")
    assert "position constraint" in str(error) and "closed loop" in str(error)


def test_non_finite_forces_are_reported(pendulum):
    def force(q, qd, t, p):
        return pendulum.force(q, qd, t, p) * (np.nan if t > 0.05 else 1.0)

    with pytest.raises(SolverError, match="non-finite"):
        simulate(variant(pendulum, force=force), t_end=0.2, tol=1e-8)


def test_a_tolerance_below_round_off_is_refused(pendulum):
    with pytest.raises(SolverError, match="round-off") as caught:
        simulate(pendulum, tol=1e-17)
    assert "hint: use tol >=" in str(caught.value)


def test_bad_arguments_are_value_errors(pendulum):
    with pytest.raises(ValueError, match=r"params must have shape \(6,\)"):
        simulate(pendulum, params=np.ones(3))
    with pytest.raises(ValueError, match="dt_out"):
        simulate(pendulum, dt_out=0.0)
    with pytest.raises(ValueError, match="t_end"):
        simulate(pendulum, t_end=-1.0)
    # 1e10 output rows would be 74 GiB of results: refused before anything is allocated
    with pytest.raises(ValueError, match=r"asks for 1e\+10 output times; this model records "
                                         r"at most \d+ \(1 GiB of results\)"):
        simulate(pendulum, t_end=10.0, dt_out=1e-9)
    partial = variant(pendulum)
    del partial.gamma
    with pytest.raises(TypeError, match="missing gamma"):
        simulate(partial)
