"""Beams at the system level, through the real pipeline: `.dep` text -> depsim.dsl ->
depsim.codegen (NumPy module) -> depsim.runtime.simulate (the iterative multiplier method).

Reference numbers are Euler-Bernoulli beam theory:
* cantilever under its own weight w and a tip load P on a root spring k:
  tip deflection w L^4/(8 EI) + P L^3/(3 EI) + (w L^2/2 + P L) L / k;
* cantilever frequencies omega_k = beta_k^2 sqrt(EI / (rho A L^4)), cos b cosh b = -1.

The test beams are not M2's: their EA / EI (100 or 1000 m^-2 instead of 4.9e4) keeps the axial
modes, which bound an explicit step, low enough for runs of a few seconds. Bending does not
depend on EA in these (linear, transversely loaded) cases.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import linalg, optimize

from depsim.codegen import compile_numpy, load_generated
from depsim.dsl import load_model
from depsim.runtime import simulate
from depsim.runtime.interface import dense
from depsim.runtime.interface import initial_state, outputs_at

G = 9.81  # m/s^2
CANTILEVER_ROOTS = (1.8751040687119611, 4.6940911329741746)  # cos b cosh b = -1

# A beam on a torsional root spring (stiffness k, viscous damping c) carrying a tip mass on a
# free pin, in gravity -y: the clamp's compliance is accounted for in the reference. k = EI/L
# makes the first mode mostly root rotation, so the root damper settles it (zeta 0.55).
SPRING_CLAMPED = """\
model spring_clamped "cantilever on a root spring, own weight and a tip mass"
gravity = (0, -9.81) m/s^2
param k = {k} N*m/rad
beam arm {{
    length = {L} m; EI = {EI} N*m^2; EA = {EA} N; mass_per_length = {rhoA} kg/m
    elements = {n}
}}
body tipmass {{ mass = {m} kg; inertia = 1e-4 kg*m^2; point pin = (0, 0) m }}
hinge root joins ground.origin to arm.a {{
    angle = arm - ground; stiffness = k; damping = {c} N*m*s/rad
}}
hinge pin joins arm.b to tipmass.pin
simulate {{ t_end = {t_end} s; tol = 1e-6; dt_out = 0.005 s }}
output tip_y = arm.b.y
"""
STATIC = dict(L=1.0, EI=1000.0, EA=1e5, rhoA=1.0, k=1000.0, c=47.0, m=0.5, t_end=0.4)

# An exact clamp: a slider along the beam's axis fixes end a's lateral position and its tangent
# (the slider keeps the relative angle); the axial rigid motion it leaves free is not excited.
SLIDER_CLAMPED = """\
model slider_clamped "cantilever vibrating about its static sag"
gravity = (0, -9.81) m/s^2
beam arm {{
    length = 1 m; EI = {EI} N*m^2; EA = {EA} N; mass_per_length = 1 kg/m; elements = {n}
}}
slider clamp joins ground.origin to arm.a {{ axis = (1, 0) }}
simulate {{ t_end = {t_end} s; tol = 1e-6; dt_out = 0.001 s }}
output deflection = arm.tip_deflection
"""
VIBRATION = dict(EI=100.0, EA=1e4)


def compile_text(tmp_path, text: str, name: str):
    """Write a model, compile it to NumPy and load the module."""
    path = tmp_path / f"{name}.dep"
    path.write_text(text, encoding="utf-8")
    return load_generated(compile_numpy(load_model(path), tmp_path / f"{name}_gen"))


def defaults(module) -> np.ndarray:
    return np.array(module.PARAMETER_DEFAULTS, dtype=float)


def constraint_jacobian(module, q, p) -> np.ndarray:
    J = np.zeros((module.NC, module.NQ))
    J[list(module.PHI_Q_ROWS), list(module.PHI_Q_COLS)] = module.phi_q(q, 0.0, p)
    return J


def stiffness(module, q, p, step=1e-6) -> np.ndarray:
    """Tangent stiffness -d force / d q of the generated module (central differences)."""
    qd = np.zeros(module.NQ)
    columns = []
    for unit in np.eye(module.NQ):
        plus = np.asarray(module.force(q + step * unit, qd, 0.0, p))
        minus = np.asarray(module.force(q - step * unit, qd, 0.0, p))
        columns.append(-(plus - minus) / (2 * step))
    K = np.array(columns).T
    return 0.5 * (K + K.T)


def spring_clamped_deflection(L, EI, rhoA, k, m, **_) -> float:
    """Static tip deflection (m, downward positive) of SPRING_CLAMPED, linear theory."""
    w, P = rhoA * G, m * G
    return w * L**4 / (8 * EI) + P * L**3 / (3 * EI) + (w * L**2 / 2 + P * L) * L / k


def dominant_frequency(t: np.ndarray, y: np.ndarray, modes: int = 2) -> float:
    """The lowest angular frequency of y(t) = c + sum_k (a_k cos w_k t + b_k sin w_k t),
    fitted by least squares (amplitudes by linear least squares for given w_k). Start: the
    zero crossings of y - mean for w_1, the cantilever's frequency ratios for the others."""
    centred = y - y.mean()
    crossings = np.nonzero(np.sign(centred[1:]) != np.sign(centred[:-1]))[0]
    guess = math.pi / np.mean(np.diff(t[crossings]))
    ratios = (1.0, (CANTILEVER_ROOTS[1] / CANTILEVER_ROOTS[0]) ** 2)[:modes]

    def misfit(omegas):
        basis = np.column_stack([np.ones_like(t)] + [f(w * t) for w in omegas
                                                     for f in (np.cos, np.sin)])
        amplitudes, *_ = np.linalg.lstsq(basis, y, rcond=None)
        return basis @ amplitudes - y

    start = np.array([guess * r for r in ratios])
    return float(optimize.least_squares(misfit, start, x_scale=start).x[0])


# -- statics ---------------------------------------------------------------------------------

def test_spring_clamped_cantilever_settles_at_the_static_deflection(tmp_path):
    """Released undeformed, damped by the root hinge, the run settles at beam theory's tip
    deflection (own weight + tip load + root-spring compliance). One element: the Hermite
    element's nodal deflections are exact for a uniform load, so the difference left is the
    geometric nonlinearity (root rotation 0.01 rad, deflection 1.3 % of L: O(1e-4))."""
    module = compile_text(tmp_path, SPRING_CLAMPED.format(n=1, **STATIC), "spring_clamped")
    result = simulate(module)
    tip = -result.output("tip_y")
    exact = spring_clamped_deflection(**STATIC)
    tail = tip[result.times >= 0.9 * STATIC["t_end"]]
    assert np.ptp(tail) < 1e-3 * exact  # settled
    assert tip[-1] == pytest.approx(exact, rel=2e-3)  # measured: -1.5e-4
    # The position pass holds each row within constraint_tol times its size,
    # sum_k |J_ik| (s_k + |q_k|), s_k the coordinate's scale (L): a few L for these rows.
    assert result.stats.max_v_pos < 10 * result.constraint_tol * STATIC["L"]


def test_static_equilibrium_of_the_generated_forces_at_eight_elements(tmp_path):
    """The equilibrium f(q) = Phi_q^T lambda, Phi(q) = 0 of the generated module with eight
    elements (solved directly, no integration) has the same tip deflection, and the hinge
    reaction carries the weight."""
    module = compile_text(tmp_path, SPRING_CLAMPED.format(n=8, **STATIC), "spring_clamped8")
    p = defaults(module)
    q0, _ = initial_state(module, p)
    nq, zero = module.NQ, np.zeros(module.NQ)

    def residual(z):
        q, lam = z[:nq], z[nq:]
        J = constraint_jacobian(module, q, p)
        return np.concatenate((np.asarray(module.force(q, zero, 0.0, p)) - J.T @ lam,
                               np.asarray(module.phi(q, 0.0, p))))

    # the tip mass spins freely on its pin (a zero mode): Levenberg-Marquardt copes
    solution = optimize.least_squares(residual, np.concatenate((q0, np.zeros(module.NC))),
                                      method="lm", xtol=1e-14, ftol=1e-14)
    assert np.max(np.abs(solution.fun)) < 1e-9
    q = solution.x[:nq]
    tip = -outputs_at(module, q, zero, 0.0, p)[module.OUTPUTS.index("tip_y")]
    assert tip == pytest.approx(spring_clamped_deflection(**STATIC), rel=2e-3)
    # ground reaction of the root hinge: the rows are r_ground - r_arm, so it is +lambda
    weight = (STATIC["rhoA"] * STATIC["L"] + STATIC["m"]) * G
    lam = solution.x[nq:]
    root_y = lam[module.CONSTRAINTS.index("root.y")]
    assert abs(root_y) == pytest.approx(weight, rel=1e-9)


def test_stiffness_is_the_force_jacobian_where_the_strains_vanish(tmp_path):
    """`stiffness` (K, D: the linearly implicit step's Jacobian, docs/method.md, 10) against
    central differences of `force`, for a beam on a root spring and damper carrying a tip mass
    (beams, hinge spring and damper). In the undeformed pose, with the spring at its rest
    angle, the terms K leaves out (each proportional to a strain or the spring's angle) vanish,
    so K is -df/dq there to the differences' accuracy; D = -df/dqd everywhere (f is linear in
    qd). In a deformed pose K stays symmetric positive semi-definite."""
    module = compile_text(tmp_path, SPRING_CLAMPED.format(n=3, **STATIC), "spring_stiffness")
    p = defaults(module)
    q0, _ = initial_state(module, p)
    nq = module.NQ
    K, D = (np.zeros((nq, nq)) for _ in range(2))
    values = module.stiffness(q0, p)
    K[list(module.STIFFNESS_ROWS), list(module.STIFFNESS_COLS)] = values[0]
    D[list(module.STIFFNESS_ROWS), list(module.STIFFNESS_COLS)] = values[1]
    scale = np.abs(K).max()
    assert np.max(np.abs(K - stiffness(module, q0, p))) < 1e-6 * scale
    zero, rates = np.zeros(nq), []
    for unit in np.eye(nq):
        rates.append(-(np.asarray(module.force(q0, unit, 0.0, p))
                       - np.asarray(module.force(q0, zero, 0.0, p))))
    assert np.max(np.abs(D - np.array(rates).T)) < 1e-9 * np.abs(D).max()
    assert STATIC["c"] * 0.99 < np.abs(D).max()  # the root damper is in it
    rng = np.random.default_rng(3)
    q = q0 + 1e-3 * rng.normal(size=nq)
    K[list(module.STIFFNESS_ROWS), list(module.STIFFNESS_COLS)] = module.stiffness(q, p)[0]
    assert np.max(np.abs(K - K.T)) < 1e-12 * scale
    assert np.linalg.eigvalsh(K).min() > -1e-9 * scale


# -- vibration -------------------------------------------------------------------------------

def test_linearised_generated_cantilever_has_beam_theory_frequencies(tmp_path):
    """Eigenvalues of the generated stiffness (finite differences of `force`) and
    `mass_matrix` on the null space of Phi_q, eight elements: the first two cantilever
    frequencies of beam theory (and one zero mode, the free axial slide)."""
    module = compile_text(tmp_path, SLIDER_CLAMPED.format(n=8, t_end=1, **VIBRATION),
                          "slider_clamped8")
    p = defaults(module)
    q0, _ = initial_state(module, p)
    null = linalg.null_space(constraint_jacobian(module, q0, p))
    K, M = stiffness(module, q0, p), dense(module, "mass_matrix", p)
    squares = linalg.eigh(null.T @ K @ null, null.T @ M @ null, eigvals_only=True)
    assert abs(squares[0]) < 1e-6  # the slide
    omegas = np.sqrt(squares[1:3])
    exact = [b**2 * math.sqrt(VIBRATION["EI"]) for b in CANTILEVER_ROOTS]
    assert omegas[0] == pytest.approx(exact[0], rel=1e-4)  # measured +2e-6
    assert omegas[1] == pytest.approx(exact[1], rel=1e-3)


def test_integrated_cantilever_vibrates_at_its_first_bending_frequency(tmp_path):
    """Released undeformed in gravity, the clamped beam oscillates about its static sag; the
    frequency fitted to the tip deflection over 2.5 periods is beam theory's. Four elements
    (f1 error 3e-5 in the element): eight take 7x longer, the limiting step being set by the
    highest bending mode (omega_max / omega_1 = 270 at four elements, 1090 at eight). The
    explicit step, which resolves every mode and so conserves energy; the linearly implicit
    one: tests/runtime/test_implicit_step.py."""
    module = compile_text(tmp_path, SLIDER_CLAMPED.format(n=4, t_end=0.45, **VIBRATION),
                          "slider_clamped4")
    result = simulate(module, stepping="explicit")
    omega = dominant_frequency(result.times, result.output("deflection"))
    exact = CANTILEVER_ROOTS[0] ** 2 * math.sqrt(VIBRATION["EI"])
    assert omega == pytest.approx(exact, rel=1e-3)  # measured -5e-5
    # the oscillation is about the static sag w L^4 / (8 EI) and starts from zero deflection
    deflection = -result.output("deflection")
    assert deflection[0] == 0.0
    assert deflection.mean() == pytest.approx(G / (8 * VIBRATION["EI"]), rel=0.05)
    # undamped and conservative: the energy stays constant
    total = result.total_energy()
    kinetic = result.energy[:, result.energy_names.index("kinetic")]
    assert np.max(np.abs(total - total[0])) < 1e-5 * kinetic.max()
