"""The multiplier iteration (6) itself: monotone decrease, sensitivities, the CG inner solve."""

import numpy as np
import pytest

from depsim.runtime.constraints import ConstraintSet
from depsim.runtime.multipliers import Schur, pcg, project_velocity
from depsim.runtime.stepper import State, Stepper
from depsim.runtime.system import MassMatrix, System


def start(module, tol=1e-12):
    p = np.array(module.PARAMETER_DEFAULTS)
    system = System(module, p)
    stepper = Stepper(system, ConstraintSet(system), tol)
    q, qd = module.initial_state(p)
    lam, qdd, _ = stepper.acceleration(q, qd, 0.0, np.zeros(module.NC))
    return stepper, State(0.0, q, qd, qdd, lam, np.zeros(len(module.DISSIPATORS)))


@pytest.mark.parametrize("name, h", [("pendulum", 0.05), ("slider_crank", 0.02)])
def test_each_pass_reduces_its_error_monotonically_below_tolerance(request, name, h):
    module = request.getfixturevalue(name)
    stepper, state = start(module)
    # a poor starting guess (lambda = 0: no constraint forces) makes the iteration work
    outcome = stepper.step(state, h, np.zeros(module.NC))
    position, velocity, acceleration = outcome.reports
    assert position.iterations >= 3
    for report in outcome.reports:
        errors = np.array(report.errors)
        assert np.all(np.diff(errors) < 0), (report.stage, errors)
    assert position.errors[-1] <= stepper.constraint_tol * max(1, np.max(np.abs(outcome.state.q)))
    # velocity and acceleration passes are linear in lambda_{i+1}: one update suffices
    assert velocity.iterations == 1 and acceleration.iterations == 1
    assert acceleration.errors[-1] < 1e-12


def test_position_sensitivity_is_h_squared_over_six(pendulum):
    """For frozen Phi_q, d q_{i+1} / d lambda_{i+1} = -(h^2/6) M^-1 Phi_q^T: the first update
    of (6) with C = h^2/6 removes the error up to O(h) (the contraction shrinks with h)."""
    rates = []
    for h in (0.02, 0.01, 0.005):
        stepper, state = start(pendulum)
        outcome = stepper.step(state, h, np.zeros(2))
        errors = outcome.reports[0].errors
        rates.append(errors[1] / errors[0])
    assert rates[0] < 0.1
    assert rates[2] < rates[1] < rates[0]


def test_conjugate_gradients_solve_the_schur_system():
    rng = np.random.default_rng(1)
    J = rng.normal(size=(6, 9))
    for mass in (MassMatrix(np.diag(rng.uniform(0.5, 2, 9)), "abcdefghi"),
                 MassMatrix(np.eye(9) * 2 + 0.1 * np.ones((9, 9)), "abcdefghi")):
        S = J @ np.linalg.solve(mass.matrix, J.T)
        for schur in (Schur(J, mass), _matrix_free(J, mass)):
            b = rng.normal(size=6)
            result = pcg(schur, b)
            assert result.converged and result.iterations <= 6 + 1
            assert np.allclose(result.x, np.linalg.solve(S, b), rtol=1e-8)


def _matrix_free(J, mass):
    schur = Schur.__new__(Schur)
    schur.J, schur.mass, schur.explicit = J, mass, None
    schur.diag = np.einsum("ij,ji->i", J, mass.solve(J.T))
    return schur


def test_plastic_impact_is_the_mass_orthogonal_velocity_projection(slider_crank):
    p = np.array(slider_crank.PARAMETER_DEFAULTS)
    system = System(slider_crank, p)
    cs = ConstraintSet(system)
    q, _ = slider_crank.initial_state(p)
    qd = np.random.default_rng(2).normal(size=9)  # violates the velocity constraints
    J = cs.jacobian(q, 0.0)
    projected, impulse, _ = project_velocity(J, system.mass, qd, np.zeros(8), 1e-14)
    M = system.mass.matrix
    # independent: minimise (v - qd)^T M (v - qd) subject to J v = 0 via the KKT system
    kkt = np.block([[M, J.T], [J, np.zeros((8, 8))]])
    expected = np.linalg.solve(kkt, np.concatenate((M @ qd, np.zeros(8))))[:9]
    assert np.allclose(projected, expected, atol=1e-12)
    assert np.max(np.abs(J @ projected)) < 1e-13
