"""Stick-slip friction through another hinge's latch impact (docs/deployment.md, section 2).

Two panels in zero gravity: the root hinge h1 (ground to panel1) has kinetic and static
friction and a spring preload pushing it backwards; the outer hinge h2 drives panel2 forwards
and latches rigidly. h1 is slipping backwards when h2 latches; the plastic impact conserves
the angular momentum about the ground pin (the only external impulse acts there; a finite
friction torque transmits none) and leaves h1 moving forwards. It must slip forwards, stop,
and then stick or slip back depending on its static friction. The reference is independent of
depsim: the two-angle equations of motion (solve_ivp) up to the latch, then the rigid
system's rotation about the pin in closed form.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from depsim.runtime import simulate

L, M1, M2 = 1.0, 1.0, 4.0            # both panels 1 m; masses (kg)
I1, I2 = M1 * L * L / 12, M2 * L * L / 12
P1, FK = -0.25, 0.2                  # h1 preload (backwards) and kinetic friction (N m)
P2 = 5.0                             # h2 preload (N m), latch at 0 deg
W1, W2 = -0.3, 2.0                   # initial rates (rad/s); h2 starts at -90 deg

MODEL = """model two_panel "root hinge slipping backwards when the outer hinge latches"
bar panel1 {{ length = 1 m; mass = 1 kg; inertia = 1 kg*m^2 / 12 }}
bar panel2 {{ length = 1 m; mass = 4 kg; inertia = 4 kg*m^2 / 12 }}
hinge h1 joins ground.origin to panel1.a {{
    preload = {P1} N*m
    friction = {FK} N*m
    static_friction = {FS} N*m
}}
hinge h2 joins panel1.b to panel2.a {{ preload = {P2} N*m; latch = 0 deg }}
initial {{ h1.rate = {W1} rad/s; h2 = -90 deg; h2.rate = {W2} rad/s }}
simulate {{ t_end = 4 s; tol = 1e-10; dt_out = 0.01 s }}
output theta1 = h1
output omega1 = h1.rate
"""

# in absolute angles phi1 = theta1, phi2 = theta1 + theta2 (a double pendulum's mass matrix)
M11 = I1 + M1 * (L / 2) ** 2 + M2 * L ** 2
M22 = I2 + M2 * (L / 2) ** 2
C = M2 * L * (L / 2)
J_LATCHED = M11 + 2 * C + M22       # the rigid pair about the pin at theta2 = 0


def reference():
    """(t_latch, theta1 at the latch, omega1 just after it) from the two-angle equations."""
    def rhs(t, y):
        p1, p2, w1, w2 = y
        d = p2 - p1
        mass = np.array([[M11, C * np.cos(d)], [C * np.cos(d), M22]])
        tau1 = P1 - (-1.0) * FK            # h1 slips backwards: friction pushes forwards
        q = np.array([tau1 - P2 + C * np.sin(d) * w2 ** 2, P2 - C * np.sin(d) * w1 ** 2])
        return [w1, w2, *np.linalg.solve(mass, q)]

    def latch(t, y):
        return y[1] - y[0]
    latch.terminal, latch.direction = True, 1
    sol = solve_ivp(rhs, (0, 5), [0.0, -np.pi / 2, W1, W1 + W2], method="DOP853",
                    rtol=1e-13, atol=1e-14, events=latch, dense_output=True)
    t_latch = sol.t_events[0][0]
    p1, p2, w1, w2 = sol.y_events[0][0]
    assert np.all(sol.sol(np.linspace(0, t_latch, 200))[2] < 0)  # slipping backwards until then
    momentum = (M11 + C) * w1 + (M22 + C) * w2                    # about the pin, at d = 0
    return t_latch, p1, momentum / J_LATCHED


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    import depsim.codegen as codegen
    import depsim.dsl as dsl
    folder = tmp_path_factory.mktemp("stick_impact")

    def get(static_friction):
        source = folder / f"two_panel_{len(list(folder.glob('*.dep')))}.dep"
        source.write_text(MODEL.format(P1=P1, FK=FK, FS=static_friction, P2=P2, W1=W1, W2=W2))
        module = codegen.load_generated(codegen.compile_numpy(dsl.load_model(source),
                                                              folder / source.stem))
        return simulate(module)

    return get


@pytest.mark.parametrize("static_friction", [0.22, 0.24, 0.26, 0.3])
def test_an_impact_that_reverses_a_slipping_hinge_makes_it_slip_the_new_way(run,
                                                                             static_friction):
    result = run(static_friction)
    t_latch, theta_latch, w_after = reference()
    assert w_after > 0.05  # the impact reverses h1 (hand computation)
    names = [(e.name, e.t) for e in result.events]
    assert names[0][0] == "h2.latch" and abs(names[0][1] - t_latch) < 1e-8
    assert names[1][0] == "h1.slip" and names[1][1] == names[0][1]
    assert result.events[1].data["direction"] == 1.0

    # forwards against preload and friction: omega1 falls linearly to rest
    decel = (abs(P1) + FK) / J_LATCHED
    t_rest = t_latch + w_after / decel
    theta_rest = theta_latch + w_after ** 2 / (2 * decel)
    t = result.times
    sliding = (t > t_latch + 1e-6) & (t < t_rest - 1e-6)
    assert np.allclose(result.output("omega1")[sliding],
                       w_after - decel * (t[sliding] - t_latch), rtol=0, atol=1e-8)

    # at rest the preload needs a holding torque of |P1| = 0.25 N m
    assert names[2][0] == ("h1.stick" if static_friction >= abs(P1) else "h1.slip")
    assert abs(names[2][1] - t_rest) < 1e-7
    assert abs(result.output("theta1")[np.searchsorted(t, t_rest)] - theta_rest) < 1e-6
    after = t > t_rest + 1e-6
    if static_friction >= abs(P1):
        assert len(names) == 3
        assert np.all(np.abs(result.output("omega1")[after]) < 1e-9)
    else:  # slips back, accelerated by |P1| - F_k
        assert result.events[2].data["direction"] == -1.0
        assert np.allclose(result.output("omega1")[after],
                           -(abs(P1) - FK) / J_LATCHED * (t[after] - t_rest), atol=1e-8)

    # nothing is lost but the impact's and the friction's recorded work
    energy = result.total_energy()
    assert np.max(np.abs(energy - energy[0])) < 1e-8 * energy[0]
