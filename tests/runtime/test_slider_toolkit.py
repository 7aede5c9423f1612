"""A slider's springs, damping, friction, stops and latch along its axis (docs/language.md,
slider), each against an answer found without depsim: the closed-form response of a mass on a
spring, Coulomb friction's stopping distance and stick condition, the statics of a stop, and
a latch time from scipy's Radau at tight tolerances.

The core treats a slider with friction, a stop or a latch as one more hinge entry whose angle
is the displacement s (m), so these runs exercise its friction, stick-slip, stop and latch
code on a linear coordinate. Tolerances: the runs use tol = 1e-10; the largest error measured
against the closed forms below is 5e-11 m over 450 steps (the method's local error per step
is below tol times the model's length, 1 m here), and the bounds are 1e-9 m, twenty times
that, far below what a wrong law would give (a wrong sign or a missing term moves s by 1e-2).
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from depsim.runtime import simulate

M, K, P, G = 2.0, 50.0, 1.0, 9.81
ALPHA = math.radians(30)  # the rail's tilt above +x
S0, V0 = 0.1, 0.3  # m, m/s


def spring_model(damping: float, spatial: bool) -> str:
    """A block on a spring (stiffness K, preload P) along a tilted rail, in gravity."""
    if spatial:  # the rail along (1, 1, 1), gravity along -z: sin(tilt) = 1/sqrt(3)
        head, inertia, axis, gravity = ("model rail3 spatial", "(0.1, 0.12, 0.15) kg*m^2",
                                        "(1, 1, 1)", f"(0, 0, -{G})")
    else:
        head, inertia = "model rail", "0.1 kg*m^2"
        axis, gravity = f"({math.cos(ALPHA)}, {math.sin(ALPHA)})", f"(0, -{G})"
    return f"""{head}
gravity = {gravity} m/s^2
body block {{ mass = {M} kg; inertia = {inertia} }}
slider s joins ground.origin to block.cm {{
    axis = {axis}
    stiffness = {K} N/m
    preload = {P} N
    damping = {damping} N*s/m
}}
initial {{ s = {S0} m; s.rate = {V0} m/s }}
simulate {{ t_end = 3 s; tol = 1e-10; dt_out = 0.01 s }}
output x = s
output v = s.rate
output energy = system.energy
output dissipated = system.dissipated_damping
"""


def damped_response(t: np.ndarray, damping: float, sine: float) -> np.ndarray:
    """m s'' = P - K s - c s' - m g sine: s = s_eq + e^(-zeta w t) (A cos wd t + B sin wd t)."""
    s_eq = (P - M * G * sine) / K
    w = math.sqrt(K / M)
    zeta = damping / (2 * math.sqrt(K * M))
    wd = w * math.sqrt(1 - zeta ** 2)
    a = S0 - s_eq
    b = (V0 + zeta * w * a) / wd
    return s_eq + np.exp(-zeta * w * t) * (a * np.cos(wd * t) + b * np.sin(wd * t))


@pytest.mark.parametrize("spatial", [False, True], ids=["planar", "spatial"])
@pytest.mark.parametrize("damping", [0.0, 0.8])
def test_a_mass_on_a_spring_along_a_tilted_rail(build, spatial, damping):
    result = simulate(build(spring_model(damping, spatial)))
    sine = 1 / math.sqrt(3) if spatial else math.sin(ALPHA)
    expected = damped_response(result.times, damping, sine)
    assert np.max(np.abs(result.output("x") - expected)) < 1e-9
    # energy: what the damper removed is what the spring, gravity and motion lost
    balance = result.output("energy") + result.output("dissipated")
    assert np.max(np.abs(balance - balance[0])) < 1e-8
    if damping == 0.0:  # undamped: the amplitude of the closed form, reached and not passed
        s_eq = (P - M * G * sine) / K
        amplitude = math.hypot(S0 - s_eq, V0 / math.sqrt(K / M))
        assert np.max(np.abs(result.output("x") - s_eq)) == pytest.approx(amplitude, rel=1e-4)


def test_the_c_target_runs_the_spring_as_numpy_does(build, build_c):
    text = spring_model(0.8, False)
    numpy_run, c_run = simulate(build(text)), simulate(build_c(text))
    assert np.max(np.abs(numpy_run.output("x") - c_run.output("x"))) < 1e-12


SLIDING = """model rail
body block {{ mass = {m} kg; inertia = 0.1 kg*m^2 }}
slider s joins ground.origin to block.cm {{
    axis = (1, 0)
    friction = {f} N
    {more}
}}
initial {{ s = 0 m; s.rate = {v0} m/s }}
simulate {{ t_end = 1.5 s; tol = 1e-10; dt_out = 0.01 s }}
output x = s
"""


def test_coulomb_friction_stops_a_block_at_v0_squared_over_2a(build, build_c):
    """With static friction the block sticks where it stops: m v0^2 / (2 F) at t = m v0 / F
    (the law -F tanh(v / slip_rate) takes F until the rate is a few slip_rates)."""
    m, f, v0 = 2.0, 3.0, 1.2
    text = SLIDING.format(m=m, f=f, v0=v0, more=f"static_friction = {f} N")
    for module in (build(text), build_c(text)):
        result = simulate(module)
        (stick,) = result.events
        assert (stick.kind, stick.hinge) == ("stick", "s")
        assert stick.t == pytest.approx(m * v0 / f, abs=1e-9)
        assert result.output("x")[-1] == pytest.approx(m * v0 ** 2 / (2 * f), abs=1e-9)
        assert result.deployment.friction_energy == pytest.approx(m * v0 ** 2 / 2, rel=1e-9)


def test_regularised_friction_slides_on_by_its_slip_rate(build):
    """Without static friction the law stays -F tanh(v / v_s): the distance is
    m/F int_0^v0 v / tanh(v / v_s) dv = m v0^2 / (2F) + (m / F) v_s^2 pi^2 / 12."""
    m, f, v0, slip = 2.0, 3.0, 1.2, 1e-3
    result = simulate(build(SLIDING.format(m=m, f=f, v0=v0, more="")))
    expected = m * v0 ** 2 / (2 * f) + m / f * slip ** 2 * math.pi ** 2 / 12
    assert result.output("x")[-1] == pytest.approx(expected, abs=1e-9)


TILTED = """model tilted
gravity = (0, -9.81) m/s^2
body block {{ mass = 2 kg; inertia = 0.1 kg*m^2 }}
slider s joins ground.origin to block.cm {{
    axis = ({c}, {s})
    friction = 5 N
    static_friction = {fs} N
}}
simulate {{ t_end = 1 s; tol = 1e-10; dt_out = 0.01 s }}
output x = s
"""


@pytest.mark.parametrize("static", [8.0, 6.0])
def test_on_a_tilted_rail_a_block_sticks_or_slips_by_static_friction(build, static):
    """Gravity's pull along the rail, m g sin(20 deg) = 6.71 N: below static friction the
    block stays (a stick at t = 0, holding that force); above, it slides down with
    a = g sin - F/m against the kinetic friction F."""
    tilt = math.radians(20)
    result = simulate(build(TILTED.format(c=math.cos(tilt), s=math.sin(tilt), fs=static)))
    pull = 2.0 * 9.81 * math.sin(tilt)
    first = result.events[0]
    assert first.t == 0.0 and first.data["force"] == pytest.approx(pull, rel=1e-12)
    if pull < static:
        assert first.kind == "stick"
        assert np.max(np.abs(result.output("x"))) < 1e-12
    else:
        assert first.kind == "slip"
        down = 0.5 * (pull - 5.0) / 2.0 * result.times ** 2
        assert np.max(np.abs(result.output("x") + down)) < 1e-9


def test_a_preload_holds_the_block_on_its_stop_with_the_preload(build, build_c):
    """A preload P pushes a block from rest into stop_max = 0.25 m: it arrives at
    t = sqrt(2 * 0.25 m / (P / m)) with v = sqrt(2 P 0.25 m / m), the plastic stop takes its
    momentum (impulse -m v), and afterwards the stop's force on the block is -P (statics)."""
    m, preload, stop = 2.0, 4.0, 0.25
    text = f"""model pushed
body block {{ mass = {m} kg; inertia = 0.1 kg*m^2 }}
slider s joins ground.origin to block.cm {{
    axis = (0.6, 0.8)
    preload = {preload} N
    stop_max = {stop} m
}}
simulate {{ t_end = 1.5 s; tol = 1e-10; dt_out = 0.01 s }}
output x = s
output stop_force = s.force
"""
    for module in (build(text), build_c(text)):
        result = simulate(module)
        (hit,) = result.events
        assert (hit.kind, hit.hinge, hit.data["limit"]) == ("stop", "s", "max")
        assert hit.t == pytest.approx(math.sqrt(2 * stop * m / preload), abs=1e-9)
        speed = math.sqrt(2 * preload * stop / m)
        assert hit.data["rate"] == pytest.approx(speed, rel=1e-9)
        assert hit.data["position"] == stop and "angle" not in hit.data
        assert hit.data["impulse"] == pytest.approx(-m * speed, rel=1e-9)
        after = result.times > hit.t
        assert np.max(np.abs(result.output("x")[after] - stop)) < 1e-12
        force = result.hinge_loads["s"].torque[after]
        assert np.allclose(force, -preload, rtol=1e-12)
        assert np.allclose(result.output("stop_force")[after], -preload, rtol=1e-12)
        peak = result.peak_loads["s"]  # a slider's peak load: its lock force, along its axis
        assert peak.force == pytest.approx(preload, rel=1e-12) and peak.torque == 0.0
        assert result.summary()["peak_hinge_loads"]["s"]["force"] == peak.force


# A telescoping boom section pushed out of its tube by a preloaded spring, against damping and
# friction, latching at full extension.
MB, KB, PB, CB, FB, LB, SLIP = 0.8, 40.0, 12.0, 0.5, 0.3, 0.25, 1e-3
BOOM = f"""model boom_section{{spatial}}
body section {{{{ mass = {MB} kg; inertia = {{inertia}} }}}}
slider tube joins ground.origin to section.cm {{{{
    axis      = {{axis}}
    stiffness = {KB} N/m
    preload   = {PB} N
    damping   = {CB} N*s/m
    friction  = {FB} N
    stop_min  = 0 m
    latch     = {LB} m
}}}}
simulate {{{{ t_end = 0.5 s; tol = 1e-10; dt_out = 0.01 s }}}}
output x = tube
"""


def boom_reference() -> tuple[float, float]:
    """The latch time and rate of m s'' = P - K s - c s' - F tanh(s' / v_s) from rest at 0,
    by scipy's Radau at rtol 1e-12 (its error far below the bound)."""
    def rates(_, y):
        return [y[1], (PB - KB * y[0] - CB * y[1] - FB * math.tanh(y[1] / SLIP)) / MB]

    def extended(_, y):
        return y[0] - LB
    extended.terminal = True
    solution = solve_ivp(rates, (0.0, 1.0), [0.0, 0.0], method="Radau", rtol=1e-12,
                         atol=1e-14, events=extended)
    return float(solution.t_events[0][0]), float(solution.y_events[0][0][1])


@pytest.mark.parametrize("spatial", [False, True], ids=["planar", "spatial"])
def test_a_boom_section_latches_at_the_time_of_its_ode(build, spatial):
    text = BOOM.format(spatial=" spatial" if spatial else "",
                       inertia="(0.02, 0.02, 0.03) kg*m^2" if spatial else "0.02 kg*m^2",
                       axis="(0, 0.6, 0.8)" if spatial else "(1, 0)")
    result = simulate(build(text))
    t_latch, rate = boom_reference()
    (latch,) = [e for e in result.events if e.kind == "latch"]
    assert latch.hinge == "tube"
    assert latch.t == pytest.approx(t_latch, abs=1e-9)
    assert latch.data["rate"] == pytest.approx(rate, rel=1e-8)
    assert latch.data["impulse"] == pytest.approx(-MB * rate, rel=1e-8)  # plastic: m v
    assert result.deployment.deployed and result.deployment.time == latch.t
    after = result.times > latch.t
    assert np.max(np.abs(result.output("x")[after] - LB)) < 1e-12


def test_the_report_names_a_slider_by_its_units(build_c):
    """The deployment report (the core's text, both targets) gives a slider's latch rate in
    m/s, its impulse in N*s and its lock load as a force along the axis."""
    text = BOOM.format(spatial="", inertia="0.02 kg*m^2", axis="(1, 0)")
    report = simulate(build_c(text)).report()
    latch = next(line for line in report.splitlines() if "latch tube" in line)
    assert " m/s, impulse " in latch and " N*s, " in latch and "rad" not in latch
    assert "tube: force along the axis " in report and "N*m at" not in report
