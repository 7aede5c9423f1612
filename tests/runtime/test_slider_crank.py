"""The closed-loop slider-crank against the direct solver and a minimal-coordinate solution."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from references.direct import solve_direct

from depsim.runtime import simulate

T_END = 1.0


@pytest.fixture(scope="module")
def iterative(slider_crank):
    return simulate(slider_crank, t_end=T_END, tol=1e-10, dt_out=0.01)


def crank_coordinates(theta, p):
    """All nine absolute coordinates as functions of the crank angle (complex-safe)."""
    r, l = p[0], p[1]
    s, c = np.sin(theta), np.cos(theta)
    w = np.sqrt(l * l - r * r * s * s)
    zero = 0 * theta
    return np.array([r * c / 2, r * s / 2, theta, r * c + w / 2, r * s / 2,
                     -np.arcsin(r * s / l), r * c + w, zero, zero])


def crank_jacobian(theta, p):
    """d(coordinates)/d(theta), derived by hand (complex-safe)."""
    r, l = p[0], p[1]
    s, c = np.sin(theta), np.cos(theta)
    w = np.sqrt(l * l - r * r * s * s)
    dw = -r * r * s * c / w
    zero = 0 * theta
    return np.array([-r * s / 2, r * c / 2, 1 + zero, -r * s + dw / 2, r * c / 2, -r * c / w,
                     -r * s + dw, zero, zero])


def minimal_solution(p, times):
    """Lagrange's equation in the crank angle alone:
    (g'^T M g') theta'' = T(theta, theta') - (g'^T M g'') theta'^2, g'' by complex step."""
    masses = np.array([p[2], p[2], p[2] * p[0] ** 2 / 12, p[3], p[3], p[3] * p[1] ** 2 / 12,
                       p[4], p[4], p[5]])
    k, preload, c = p[6], p[7], p[8]

    def rhs(t, y):
        theta, omega = y
        g1 = crank_jacobian(theta, p)
        g2 = np.imag(crank_jacobian(theta + 1e-30j, p)) / 1e-30
        inertia = g1 @ (masses * g1)
        torque = preload - k * theta - c * omega
        return [omega, (torque - (g1 @ (masses * g2)) * omega ** 2) / inertia]

    sol = solve_ivp(rhs, (0, times[-1]), [p[9], p[10]], method="DOP853", rtol=1e-13,
                    atol=1e-14, t_eval=times)
    return sol.y


def test_closed_loop_matches_the_direct_solver(slider_crank, iterative):
    direct = solve_direct(slider_crank, t_end=T_END, tol=1e-12, dt_out=0.01)
    assert np.array_equal(iterative.times, direct.times)
    assert np.max(np.abs(iterative.outputs - direct.outputs)) < 1e-8  # measured 7e-10
    assert np.max(np.abs(iterative.q - direct.q)) < 1e-8
    # multipliers at the step end points agree; at output times ours are interpolated
    assert np.max(np.abs(iterative.lam[-1] - direct.lam[-1])) < 1e-6


def test_closed_loop_matches_the_minimal_coordinate_solution(slider_crank, iterative):
    p = np.array(slider_crank.PARAMETER_DEFAULTS)
    theta, omega = minimal_solution(p, iterative.times)
    assert np.max(np.abs(iterative.output("crank_angle") - theta)) < 1e-8
    assert np.max(np.abs(iterative.hinge_rates[:, 0] - omega)) < 1e-8
    coordinates = crank_coordinates(theta, p).T
    assert np.max(np.abs(iterative.q - coordinates)) < 1e-8
    assert np.max(np.abs(iterative.output("piston_x") - coordinates[:, 6])) < 1e-8


def test_every_accepted_step_satisfies_all_three_constraint_levels(slider_crank, iterative):
    stats = iterative.stats
    tol_c = iterative.constraint_tol
    speed = max(1.0, np.max(np.abs(iterative.qd)))
    size = max(1.0, np.max(np.abs(iterative.q)))
    assert stats.max_v_pos <= tol_c * size
    assert stats.max_v_vel <= tol_c * speed
    assert stats.max_v_acc <= tol_c * 100  # accelerations of the model are below 100 m/s^2
    # independently, from the module's own functions at the last (step) point, to the pass's
    # own limit there: tol_c times the size of the terms the residual balances (max |q|, the
    # largest |J_ij qd_j| sum; docs/method.md, 2)
    p = np.array(slider_crank.PARAMETER_DEFAULTS)
    q, qd = iterative.q[-1], iterative.qd[-1]
    J = np.zeros((8, 9))
    J[slider_crank.PHI_Q_ROWS, slider_crank.PHI_Q_COLS] = slider_crank.phi_q(q, T_END, p)
    assert np.max(np.abs(slider_crank.phi(q, T_END, p))) <= tol_c * max(1.0, np.max(np.abs(q)))
    assert np.max(np.abs(J @ qd)) <= tol_c * max(1.0, np.max(np.abs(J) @ np.abs(qd)))
    # between steps (dense output) the residuals stay near the integration tolerance
    assert np.max(iterative.residual_pos) < iterative.tol
    assert np.max(iterative.residual_vel) < 10 * iterative.tol


def test_dissipated_work_closes_the_energy_balance(slider_crank):
    p = np.array(slider_crank.PARAMETER_DEFAULTS)
    p[8] = 0.2  # stronger damping, so the dissipated work is large
    result = simulate(slider_crank, p, t_end=T_END, tol=1e-10, dt_out=0.01)
    work = result.dissipated[:, 0]
    assert np.all(np.diff(work) > -1e-12) and work[-1] > 0.5  # J
    total = result.total_energy()
    assert np.max(np.abs(total - total[0])) < 1e-8 * work[-1]
    # independent quadrature of the damping power c theta'^2 on the output grid
    rate = result.hinge_rates[:, 0]
    simpson = np.sum((rate[:-2:2] ** 2 + 4 * rate[1:-1:2] ** 2 + rate[2::2] ** 2)) * 0.01 / 3
    assert abs(p[8] * simpson - work[-1]) < 1e-5 * work[-1]
