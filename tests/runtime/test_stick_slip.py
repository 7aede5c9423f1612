"""Stick-slip hinge friction (`static_friction` given) against closed-form answers.

The model: a bar pinned to the ground in zero gravity, inertia about the pin J_O = 1 kg m^2,
a hinge spring torque P - k theta, kinetic friction F_k, static friction F_s.
"""

import numpy as np
import pytest

from depsim.runtime import simulate

MODEL = """model stick "a spring-loaded hinge with stick-slip friction"
bar arm {{ length = 1 m; mass = 3 kg; inertia = 0.25 kg*m^2 }}
hinge h joins ground.origin to arm.a {{
    stiffness = {k} N*m/rad
    preload = {P} N*m
    friction = {Fk} N*m
    static_friction = {Fs} N*m
}}
simulate {{ t_end = {T} s; tol = 1e-10; dt_out = 0.01 s }}
output theta = h
output omega = h.rate
"""
J_O = 0.25 + 3 * 0.5 ** 2


@pytest.fixture(scope="module")
def build(tmp_path_factory):
    import depsim.codegen as codegen
    import depsim.dsl as dsl
    folder = tmp_path_factory.mktemp("stick_models")

    def get(**values):
        source = folder / f"stick{len(list(folder.glob('*.dep')))}.dep"
        source.write_text(MODEL.format(**values))
        return codegen.load_generated(codegen.compile_numpy(dsl.load_model(source),
                                                            folder / source.stem))

    return get


def test_a_preload_below_static_friction_never_moves(build):
    module = build(k=0.0, P=0.5, Fk=0.6, Fs=0.8, T=2.0)
    result = simulate(module)
    assert [e.name for e in result.events] == ["h.stick"]
    assert result.events[0].t == 0.0
    # held by the stick row to the passes' tolerance (0.01 tol = 1e-12)
    assert np.max(np.abs(result.output("theta"))) < 1e-11
    assert np.max(np.abs(result.output("omega"))) < 1e-11
    # the lock holds the preload: T = -P on the arm
    assert np.allclose(result.hinge_loads["h"].torque, -0.5, atol=1e-12)
    assert result.deployment.friction_energy == 0.0


def test_a_preload_above_static_friction_slides_at_preload_minus_kinetic_friction(build):
    module = build(k=0.0, P=1.0, Fk=0.6, Fs=0.8, T=2.0)
    result = simulate(module)
    assert [e.name for e in result.events] == ["h.slip"]
    assert result.events[0].data["direction"] == 1.0
    # theta'' = (P - F_k) / J_O from the start (not P / J_O: no tanh ramp at zero rate)
    t = result.times
    assert np.allclose(result.output("theta"), 0.5 * (1.0 - 0.6) / J_O * t ** 2, atol=1e-9)
    assert np.allclose(result.output("omega"), (1.0 - 0.6) / J_O * t, atol=1e-9)
    # friction work F_k theta, exactly
    assert result.deployment.friction_energy == pytest.approx(0.6 * result.output("theta")[-1],
                                                              rel=1e-9)
    assert np.all(np.isnan(result.hinge_loads["h"].torque[1:]))  # free while sliding


def piecewise(t, P=1.0, k=1.0, Fk=0.1, Fs=0.15):
    """Half-cycles of the harmonic oscillator about the shifted centre (P -+ F_k) / k: each one
    lasts pi sqrt(J_O/k) and ends at rest; it continues the other way while the spring torque
    there exceeds F_s, else the hinge sticks. Returns (theta(t), [(t_i, kind)])."""
    w = np.sqrt(k / J_O)
    theta, start, direction, events = 0.0, 0.0, 1.0, []
    pieces = []
    while True:
        spring = P - k * theta
        if abs(spring) <= Fs:
            events.append((start, "h.stick"))
            pieces.append((start, np.inf, theta, 0.0))
            break
        direction = np.sign(spring)
        events.append((start, "h.slip"))
        centre = (P - direction * Fk) / k
        pieces.append((start, start + np.pi / w, centre, theta - centre))
        theta = centre - (theta - centre)
        start += np.pi / w
    out = np.empty_like(t)
    for a, b, centre, amplitude in pieces:
        sel = (t >= a) & (t <= b)
        out[sel] = centre + amplitude * np.cos(w * (t[sel] - a))
    return out, events


def test_stick_slip_reversals_and_final_stick_match_the_closed_form(build):
    module = build(k=1.0, P=1.0, Fk=0.1, Fs=0.15, T=17.0)
    result = simulate(module)
    expected, events = piecewise(result.times)
    assert [e.name for e in result.events] == [name for _, name in events]
    # rest is reached every pi s; the event times, to the run's accumulated error
    for got, (t, _) in zip(result.events, events):
        assert abs(got.t - t) < 2e-9
    assert np.max(np.abs(result.output("theta") - expected)) < 1e-8
    # it sticks at theta = 1 where the spring torque vanishes, with |holding torque| <= F_s
    assert result.output("theta")[-1] == pytest.approx(1.0, abs=1e-9)
    assert abs(result.events[-1].data["torque"]) <= 0.15
    # friction work: F_k times the path 1.8 + 1.4 + 1.0 + 0.6 + 0.2 rad
    assert result.deployment.friction_energy == pytest.approx(0.1 * 5.0, rel=1e-8)
    assert np.max(np.abs(result.total_energy() - result.total_energy()[0])) < 1e-9


def test_without_static_friction_the_tanh_law_stays(build, tmp_path):
    """No `static_friction`: no stick-slip events, the module's regularised friction acts
    (a preload below the friction creeps at about slip_rate * atanh(P / F))."""
    import depsim.codegen as codegen
    import depsim.dsl as dsl
    text = MODEL.replace("    static_friction = {Fs} N*m\n", "").format(k=0.0, P=0.5, Fk=0.6,
                                                                          T=2.0)
    (tmp_path / "tanh.dep").write_text(text)
    module = codegen.load_generated(codegen.compile_numpy(dsl.load_model(tmp_path / "tanh.dep"),
                                                          tmp_path))
    result = simulate(module)
    assert result.events == ()
    creep = 1e-3 * np.arctanh(0.5 / 0.6)
    assert result.output("omega")[-1] == pytest.approx(creep, rel=1e-3)
