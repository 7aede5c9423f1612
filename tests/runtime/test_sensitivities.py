"""Forward sensitivities (docs/method.md, 12; docs/calibration.md) against central finite
differences of runs at a tight tolerance.

Tolerances. A sensitivity is compared with (y(p + h) - y(p - h)) / 2h. That quotient carries
the truncation error h^2 y''' / 6 and each run's own integration error (about tol times the
output's scale) divided by h. With a relative step of 1e-4 and tol = 1e-11 both are near 1e-7
of the sensitivity's scale; the sensitivities' own integration (the classical fourth-order
method on the step's interpolant, at the state's steps) adds about tol times the
sensitivity's scale over the run. So agreement to 1e-5 of the largest value of the compared
history is what the method owes, with a margin of about 100 over the sum of those errors.
An event time is located to the integration's accuracy (tol times the time scale of the
motion), so its quotient's noise is about tol / h = 1e-6 of it at tol = 1e-10: event-time
sensitivities are compared to 1e-4.
"""

import numpy as np
import pytest

import depsim
from depsim.errors import UsageError

from runtime_helpers import compile_text

RELATIVE_STEP = 1e-4
TOL = 1e-11
AGREEMENT = 1e-5  # of the history's largest |value| (module docstring)
EVENT_AGREEMENT = 1e-4  # relative, event times (module docstring)


@pytest.fixture(scope="module")
def pendulum():
    return depsim.load("examples/pendulum.dep").compile("c")


@pytest.fixture(scope="module")
def intelsat():
    return depsim.load("examples/intelsat5.dep").compile("c")


def step(sim, name, set=None):
    p0 = sim.parameters(set)[sim.parameter_names.index(name)]
    return p0, RELATIVE_STEP * max(abs(p0), 1e-3)


def finite_difference(sim, name, set=None, **run):
    """(d outputs / d p (n, NOUT), d event times / d p) by central differences."""
    p0, h = step(sim, name, set)
    ends = [sim.run(set={**(set or {}), name: p0 + sign * h}, **run) for sign in (1.0, -1.0)]
    assert [e.name for e in ends[0].events] == [e.name for e in ends[1].events], \
        "the step changed the events' order"
    times = np.array([a.t - b.t for a, b in zip(ends[0].events, ends[1].events)]) / (2 * h)
    return (ends[0].outputs - ends[1].outputs) / (2 * h), times


def assert_agrees(computed, reference, what, agreement=AGREEMENT):
    scale = np.max(np.abs(reference))
    error = np.max(np.abs(computed - reference))
    assert error <= agreement * scale, f"{what}: off by {error:.3g} of {scale:.3g}"


@pytest.mark.parametrize("name", ["L", "pivot.initial_angle", "gravity.y"])
def test_pendulum_angle_against_finite_differences(pendulum, name):
    run = dict(tol=TOL, t_end=3.0, dt_out=0.05)
    result = pendulum.run(sensitivities=[name], **run)
    reference, _ = finite_difference(pendulum, name, **run)
    for column, output in enumerate(result.output_names):
        assert_agrees(result.sensitivities.output(output, name), reference[:, column],
                      f"d {output} / d {name}")


def test_pendulum_does_not_depend_on_its_mass(pendulum):
    """A uniform bar's swing is the same for any mass (its inertia is m L^2 / 12): the
    sensitivity to m is zero, to the round-off of the tangent solves."""
    result = pendulum.run(tol=TOL, t_end=3.0, dt_out=0.05, sensitivities=["m"])
    assert np.max(np.abs(result.sensitivities.output("theta", "m"))) < 1e-8
    assert result.sensitivities.q.shape == (len(result.times), 1, len(result.coordinate_names))


def test_numpy_target_gives_the_c_targets_sensitivities(pendulum):
    """Both targets run the same core on the same generated tangents."""
    numpy = depsim.load("examples/pendulum.dep").compile("numpy")
    run = dict(tol=1e-9, t_end=1.0, dt_out=0.1, sensitivities=["L", "m"])
    a, b = numpy.run(**run).sensitivities, pendulum.run(**run).sensitivities
    assert np.allclose(a.outputs, b.outputs, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name", ["crank", "coupler", "ground_x"])
def test_fourbar_assembled_start_against_finite_differences(name):
    """A four-bar given its crank angle alone: the assembly closes the loop, and the initial
    state's sensitivities are the assembly's linearised (the free angles move with a link's
    length so that the loop stays closed)."""
    sim = depsim.load("examples/fourbar.dep").compile("c")
    run = dict(tol=TOL, t_end=1.0, dt_out=0.02)
    result = sim.run(sensitivities=[name], **run)
    reference, _ = finite_difference(sim, name, **run)
    assert_agrees(result.sensitivities.outputs[:, 0, :], reference, f"d outputs / d {name}")


def test_slider_crank_spring_against_finite_differences():
    sim = depsim.load("examples/slider_crank.dep").compile("c")
    run = dict(tol=TOL, t_end=1.0, dt_out=0.02)
    names = ["crank_pin.preload", "r"]
    result = sim.run(sensitivities=names, **run)
    for k, name in enumerate(names):
        reference, _ = finite_difference(sim, name, **run)
        assert_agrees(result.sensitivities.outputs[:, k, :], reference, f"d outputs / d {name}")


def test_intelsat_latch_times_through_the_latch_impacts(intelsat):
    """INTELSAT V's latch times' sensitivities to friction, preload, a hinge spring and the
    cable loops' stiffness: each latch's plastic impact and new lock row are crossed with
    the jump of the sensitivities (docs/method.md, 12)."""
    names = ["h1.friction", "h2.preload", "h3.stiffness", "cable_k"]
    run = dict(tol=1e-10, dt_out=0.5)
    result = intelsat.run(sensitivities=names, **run)
    assert [e.name for e in result.events] == ["h1.latch", "h2.latch", "h4.latch", "h3.latch"]
    for k, name in enumerate(names):
        outputs, times = finite_difference(intelsat, name, **run)
        computed = result.sensitivities.event_times[:, k]
        assert np.all(np.abs(computed - times) <= EVENT_AGREEMENT * np.abs(times)), \
            f"d t_latch / d {name}: {computed} against {times}"
        assert_agrees(result.sensitivities.outputs[:, k, :], outputs, f"d angles / d {name}",
                      agreement=1e-4)
    summary = result.summary()
    assert set(summary["events"][0]["dt_dp"]) == set(names)
    assert summary["events"][0]["dt_dp"]["h1.friction"] == pytest.approx(
        result.sensitivities.event_time(0, "h1.friction"))


def test_hold_down_release_time(tmp_path):
    """A panel held down until t_release, then driven by its hinge spring: shifting the
    release shifts the whole deployment, so d t_latch / d t_release = 1 exactly and every
    angle's sensitivity is minus its rate after the release."""
    sim = compile_text(tmp_path, "held", """
model held "a held panel"
param t_release = 0.5 s
bar panel { length = 1 m; mass = 2 kg; inertia = 0.2 kg*m^2 }
hinge h joins ground.origin to panel.a {
    angle = panel - ground
    preload = 1 N*m
    stiffness = 0.5 N*m/rad
    friction = 0.05 N*m
    latch = 90 deg
    release = t_release
}
simulate { t_end = 3 s; tol = 1e-10; dt_out = 0.01 s }
output theta = h
output rate = h.rate
""")
    result = sim.run(sensitivities=["t_release"])
    latch = [k for k, e in enumerate(result.events) if e.name == "h.latch"]
    assert len(latch) == 1
    assert result.sensitivities.event_time(latch[0], "t_release") == pytest.approx(1.0,
                                                                                    rel=1e-6)
    after = (result.times > 0.5) & (result.times < result.events[latch[0]].t)
    assert_agrees(result.sensitivities.output("theta", "t_release")[after],
                  -result.output("rate")[after], "d theta / d t_release")


def test_spatial_wing_against_finite_differences(tmp_path):
    """A spatial pendulum on a hinge skewed 20 deg from horizontal, spring and friction."""
    sim = compile_text(tmp_path, "skewed", """
model skewed spatial "a panel on a skewed hinge"
gravity = (0, 0, -9.81) m/s^2
param k = 2 N*m/rad
body panel {
    mass = 3 kg
    inertia = (0.5, 0.3, 0.25) kg*m^2
    point a = (-0.4, 0, 0) m
}
hinge h joins ground.origin to panel.a {
    axis = (0, sin(20 deg), cos(20 deg))
    stiffness = k
    friction = 0.1 N*m
}
initial { h = 30 deg }
simulate { t_end = 2 s; tol = 1e-10; dt_out = 0.02 s }
output theta = h
output z = panel.z
""")
    run = dict(tol=TOL)
    result = sim.run(sensitivities=["k", "h.friction"], **run)
    for j, name in enumerate(["k", "h.friction"]):
        reference, _ = finite_difference(sim, name, **run)
        assert_agrees(result.sensitivities.outputs[:, j, :], reference, f"d outputs / d {name}")


# ---- stick-slip and compliant latches ------------------------------------------------------

SPIN = """
model spin "a spinning bar that friction stops"
bar rod { length = 1 m; mass = 3 kg; inertia = 0.25 kg*m^2 }
hinge pivot joins ground.origin to rod.a {
    friction = 0.4 N*m
    static_friction = 0.5 N*m
}
initial { pivot.rate = 2 rad/s }
simulate { t_end = 7 s; tol = 1e-10; dt_out = 0.01 s }
output theta = pivot
"""


def test_sliding_to_a_stick_against_the_closed_form(tmp_path):
    """A bar spinning at w about its pivot (I_O = I + m (L/2)^2) under Coulomb friction F
    stops at t* = w I_O / F after turning w^2 I_O / 2F and sticks: d t*/dF = -w I_O / F^2,
    d t*/dw = I_O / F, d theta_final / dF = -w^2 I_O / 2 F^2 (the rate condition of the slip
    to stick transition, docs/method.md 12)."""
    sim = compile_text(tmp_path, "spin", SPIN)
    result = sim.run(sensitivities=["pivot.friction", "pivot.initial_rate"])
    inertia, w, friction = 0.25 + 3 * 0.5 ** 2, 2.0, 0.4
    stick = [k for k, e in enumerate(result.events) if e.name == "pivot.stick"]
    assert len(stick) == 1
    s = result.sensitivities
    assert s.event_time(stick[0], "pivot.friction") == pytest.approx(
        -w * inertia / friction ** 2, rel=1e-7)
    assert s.event_time(stick[0], "pivot.initial_rate") == pytest.approx(
        inertia / friction, rel=1e-7)
    assert s.output("theta", "pivot.friction")[-1] == pytest.approx(
        -w * w * inertia / (2 * friction ** 2), rel=1e-7)


def test_stuck_until_the_input_overcomes_static_friction():
    """Held by static friction until the input's torque T + T.rate t reaches it: the slip's
    time moves by 1 / T.rate per unit of static friction and by -t / T.rate per unit of
    T.rate (the multiplier's condition, its rate along the motion with the input's)."""
    sim = depsim.load("tests/runtime/models/stuck.dep").compile("c")
    base = {"T": 0.5, "T.rate": 1.0}
    names = ["pivot.static_friction", "T.rate", "pivot.friction"]
    result = sim.run(set=base, sensitivities=names)
    slip = [k for k, e in enumerate(result.events) if e.name == "pivot.slip" and e.t > 0]
    assert len(slip) == 1 and result.events[slip[0]].t == pytest.approx(0.5, rel=1e-9)
    s = result.sensitivities
    assert s.event_time(slip[0], "pivot.static_friction") == pytest.approx(1.0, rel=1e-7)
    assert s.event_time(slip[0], "T.rate") == pytest.approx(-0.5, rel=1e-7)
    for k, name in enumerate(names):
        reference, _ = finite_difference(sim, name, set=base)
        assert_agrees(s.outputs[:, k, :], reference, f"d theta / d {name}", agreement=1e-4)


# ---- what they do not follow: clear errors, never a wrong value -----------------------------

def test_unknown_parameter_is_refused(pendulum):
    with pytest.raises(ValueError, match="not a parameter"):
        pendulum.run(t_end=0.1, sensitivities=["nope"])


def test_an_event_callback_is_refused(pendulum):
    """A callback may change the run in any way: the sensitivities stop there, saying so."""
    from depsim.runtime import Event, EventResponse

    halfway = Event("halfway", lambda t, q, qd: t - 0.5,
                    callback=lambda hit: EventResponse(qd=hit.qd * 0.5))
    with pytest.raises(ValueError, match="t = 0.5.* callback"):
        depsim.runtime.simulate(pendulum.tangent_module(), t_end=1.0, events=[halfway],
                                sensitivities=["L"])


def test_compliant_latch_contact_is_refused(tmp_path):
    """A compliant latch's push switches inside a contact where no event marks it: the
    sensitivities stop at the contact, saying so."""
    sim = compile_text(tmp_path, "bounce", """
model bounce "a panel meeting a compliant latch"
bar panel { length = 1 m; mass = 2 kg; inertia = 0.2 kg*m^2 }
hinge h joins ground.origin to panel.a {
    angle = panel - ground
    preload = 1 N*m
    latch = 90 deg
    latch_stiffness = 200 N*m/rad
}
simulate { t_end = 4 s; tol = 1e-9; dt_out = 0.01 s }
""")
    with pytest.raises(ValueError, match="h.latch.* a compliant latch's contact"):
        sim.run(sensitivities=["h.preload"])


def test_one_sided_spring_is_refused():
    sim = depsim.load("examples/free_flyer.dep").compile("c")
    with pytest.raises(UsageError, match="kick"):
        sim.run(t_end=1.0, sensitivities=["h1.preload"])


def test_linearly_implicit_step_is_refused():
    sim = depsim.load("examples/two_link_flex.dep").compile("c")
    with pytest.raises(ValueError, match="linearly implicit"):
        sim.run(t_end=0.1, stepping="implicit", sensitivities=[sim.parameter_names[0]])


def test_flexible_pendulum_with_explicit_steps():
    """The two-link flexible pendulum (beams), its explicit steps held at DOPRI's stability
    bound by the axial modes: the sensitivities are then taken on the steps' own DOPRI stages
    (docs/method.md, 12). Its tip deflection's sensitivities are below the differences'
    noise; the chord angle's are compared."""
    sim = depsim.load("examples/two_link_flex.dep").compile("c")
    run = dict(tol=1e-10, t_end=0.1, dt_out=0.005, stepping="explicit")
    names = ["link2.mass_per_length", "h2.initial_angle"]
    result = sim.run(sensitivities=names, **run)
    for k, name in enumerate(names):
        reference, _ = finite_difference(sim, name, **run)
        assert_agrees(result.sensitivities.output("chord2", name), reference[:, 0],
                      f"d chord2 / d {name}", agreement=1e-4)


def test_multipliers_against_finite_differences(pendulum):
    """The model's rows' multipliers (the pivot's reaction) to the bar's length. The run's
    multipliers at an output time come from their interpolation over the step (method.md,
    5), good to the passes' tolerance, so their differences carry that over h as well: 1e-4
    of the history's scale."""
    run = dict(tol=TOL, t_end=2.0, dt_out=0.05)
    result = pendulum.run(sensitivities=["L"], **run)
    s = result.sensitivities
    p0, h = step(pendulum, "L")
    ends = [pendulum.run(set={"L": p0 + sign * h}, **run) for sign in (1.0, -1.0)]
    columns = [result.constraint_names.index(name) for name in s.constraint_names]
    reference = (ends[0].lam[:, columns] - ends[1].lam[:, columns]) / (2 * h)
    assert s.lam.shape == (len(result.times), 1, len(columns))
    assert_agrees(s.lam[:, 0, :], reference, "d lambda / d L", agreement=1e-4)
