"""The generated derivatives against finite differences of the generated values, at random
states of every model case: Phi_q, Phi_t, gamma, the conservative force, the hinge jacobian, the tree tangent;
and the non-conservative force against the reported dissipation."""

from __future__ import annotations

import numpy as np

from fd_states import random_states

from depsim.runtime.interface import dense

H = 1e-6  # first differences
H2 = 1e-4  # second differences


def central_jacobian(function, x):
    """d function / d x by central differences, shape (len(function(x)), len(x))."""
    columns = []
    for i in range(len(x)):
        step = np.zeros_like(x)
        step[i] = H
        columns.append((function(x + step) - function(x - step)) / (2 * H))
    return np.array(columns).T.reshape(len(function(x)), len(x))


def assert_close(actual, expected, rtol=1e-6):
    scale = max(1.0, float(np.max(np.abs(expected), initial=0.0)))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=rtol * scale)


def test_phi_q_is_the_jacobian_of_phi(compiled):
    m = compiled.module
    for s in random_states(m):
        numeric = central_jacobian(lambda q: m.phi(q, s.t, s.p), s.q)
        assert_close(dense(m, "phi_q", s.q, s.t, s.p), numeric)


def test_phi_q_transpose_times_is_the_jacobian_transposed_times_lam(compiled):
    """Phi_q^T lam, the constraints' generalized force at the stages: against the finite
    differences of Phi (as Phi_q itself) and, to round-off, the values of Phi_q."""
    m = compiled.module
    rng = np.random.default_rng(3)
    for s in random_states(m):
        lam = rng.standard_normal(m.NC)
        got = m.phi_q_transpose_times(s.q, s.t, s.p, lam)
        numeric = central_jacobian(lambda q: m.phi(q, s.t, s.p), s.q)
        assert_close(got, numeric.T @ lam)
        values = dense(m, "phi_q", s.q, s.t, s.p)
        # the same entries summed in another order: within (terms + 1) eps of their sizes
        terms = np.bincount(np.array(m.PHI_Q_COLS, dtype=int), minlength=m.NQ)
        bound = (terms + 1) * np.finfo(float).eps * (np.abs(values).T @ np.abs(lam))
        assert np.all(np.abs(got - values.T @ lam) <= bound)


def test_phi_q_pattern_is_sorted_and_unique(compiled):
    m = compiled.module
    pairs = list(zip(m.PHI_Q_ROWS, m.PHI_Q_COLS))
    assert pairs == sorted(set(pairs))
    assert all(0 <= r < m.NC and 0 <= c < m.NQ for r, c in pairs)


def test_phi_t_is_the_time_derivative_of_phi(compiled):
    m = compiled.module
    for s in random_states(m):
        numeric = (m.phi(s.q, s.t + H, s.p) - m.phi(s.q, s.t - H, s.p)) / (2 * H)
        assert_close(m.phi_t(s.q, s.t, s.p), numeric)


def test_gamma_is_minus_the_second_derivative_along_the_motion(compiled):
    """d^2/ds^2 Phi(q + s qd, t + s) = (Phi_q qd)_q qd + 2 Phi_qt qd + Phi_tt = -gamma."""
    m = compiled.module
    for s in random_states(m):
        def along(step):
            return m.phi(s.q + step * s.qd, s.t + step, s.p)
        second = (along(H2) - 2 * along(0.0) + along(-H2)) / H2**2
        assert_close(m.gamma(s.q, s.qd, s.t, s.p), -second, rtol=1e-5)


def test_conservative_force_is_minus_the_potential_gradient(compiled):
    """At rest friction and damping vanish: f(q, 0) = -d(sum of potentials)/dq."""
    m = compiled.module
    rest = np.zeros(m.NQ)
    for s in random_states(m):
        def potential(q):
            return np.array([np.sum(m.energy(q, rest, s.t, s.p)[1:])])
        gradient = central_jacobian(potential, s.q)[0]
        assert_close(m.force(s.q, rest, s.t, s.p), -gradient)


def test_dissipation_is_the_power_of_the_non_conservative_force(compiled):
    m = compiled.module
    for s in random_states(m):
        moving = m.force(s.q, s.qd, s.t, s.p)
        non_conservative = moving - m.force(s.q, 0 * s.qd, s.t, s.p)
        dissipation = m.dissipation(s.q, s.qd, s.t, s.p)
        assert np.all(dissipation >= 0)
        roundoff = 1e-12 * np.abs(moving) @ np.abs(s.qd)  # f(q, qd) - f(q, 0) cancels
        np.testing.assert_allclose(np.sum(dissipation), -non_conservative @ s.qd,
                                   rtol=1e-10, atol=roundoff)


def test_hinge_jacobian_and_rates(compiled):
    m = compiled.module
    for s in random_states(m):
        numeric = central_jacobian(lambda q: m.hinge_angles(q, s.p), s.q)
        jacobian = dense(m, "hinge_jacobian", s.q, s.p)  # zero outside the pattern
        assert_close(jacobian, numeric)  # so the derivative vanishes there too
        assert_close(m.hinge_rates(s.q, s.qd, s.p), jacobian @ s.qd, rtol=1e-12)
    pairs = list(zip(m.HINGE_JACOBIAN_ROWS, m.HINGE_JACOBIAN_COLS))
    assert pairs == sorted(set(pairs))


def test_hinge_gamma_is_minus_the_second_derivative_of_theta(compiled):
    m = compiled.module
    for s in random_states(m):
        def along(step):
            return m.hinge_angles(s.q + step * s.qd, s.p)
        second = (along(H2) - 2 * along(0.0) + along(-H2)) / H2**2
        assert_close(m.hinge_gamma(s.q, s.qd, s.p), -second, rtol=1e-5)


def test_kinetic_energy_and_mass_matrix(compiled):
    m = compiled.module
    for s in random_states(m):
        mass = dense(m, "mass_matrix", s.p)
        np.testing.assert_array_equal(mass, mass.T)
        assert np.all(np.linalg.eigvalsh(mass) > 0)
        assert_close(m.energy(s.q, s.qd, s.t, s.p)[0], 0.5 * s.qd @ mass @ s.qd, rtol=1e-12)


def test_module_matches_sympy(compiled):
    """The printed code evaluates to what the symbolic system does (checks lower and emit)."""
    m, system = compiled.module, compiled.system
    s = random_states(m, count=1)[0]
    values = dict(zip(system.q, s.q)) | dict(zip(system.qd, s.qd)) | dict(zip(system.p, s.p)) \
        | dict(zip(system.lam, s.lam)) | dict(zip(system.w, s.w))
    values[system.t] = s.t
    # named constant geometry, each of p and those before it; then the spatial hinges' named
    # vectors and turn parts, of q, qd and those before them
    for group in system.constants + system.hinge_steps:
        for symbol, value in group:
            values[symbol] = value.xreplace(values).evalf()

    def symbolic(matrix):
        return np.array(matrix.xreplace(values).evalf(), dtype=float).reshape(matrix.shape)

    assert_close(m.force(s.q, s.qd, s.t, s.p), symbolic(system.force)[:, 0], rtol=1e-12)
    assert_close(m.gamma(s.q, s.qd, s.t, s.p), symbolic(system.gamma)[:, 0], rtol=1e-12)
    assert_close(m.outputs(s.q, s.qd, s.t, s.p, s.lam, s.w), symbolic(system.outputs)[:, 0],
                 rtol=1e-12)
    assert_close(m.energy(s.q, s.qd, s.t, s.p), symbolic(system.energy)[:, 0], rtol=1e-12)


def test_tree_tangent_is_the_derivative_of_tree_pose(compiled):
    """tree_tangent(v, vd) = d tree_pose / d v . vd, at perturbed joint values."""
    m = compiled.module
    rng = np.random.default_rng(5)
    for s in random_states(m):
        v0, _ = m.tree_values(s.p)
        v = v0 + 0.1 * rng.standard_normal(len(v0))
        vd = rng.standard_normal(len(v0))
        numeric = (m.tree_pose(v + H * vd, s.p) - m.tree_pose(v - H * vd, s.p)) / (2 * H)
        assert_close(m.tree_tangent(v, vd, s.p), numeric)
