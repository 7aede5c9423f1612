"""Runs that would grind stop early with a SolverError that says why (docs/method.md, 6):
a stiff mode at the explicit method's stability bound, friction stiff on the constrained
mechanism, a motion too fast for the time asked, and the max_steps limit itself."""

import re

import numpy as np
import pytest

from depsim.runtime import SolverError, simulate

DOUBLE = """model stiff_pair "a double pendulum whose second hinge is stiff and heavily damped"
gravity = (0, -9.81) m/s^2
bar upper {{ length = 1 m; mass = 2 kg; inertia = 2 kg*m^2/12 }}
bar lower {{ length = 1 m; mass = 2 kg; inertia = 2 kg*m^2/12 }}
hinge h1 joins ground.origin to upper.a {{ }}
hinge h2 joins upper.b to lower.a {{ stiffness = {k} N*m/rad; damping = {c} N*m*s/rad }}
initial {{ h1 = 30 deg }}
simulate {{ t_end = {t_end} s; tol = 1e-8; dt_out = 0.01 s }}
output theta1 = h1
"""

SPRING = """model fast "a bar on an absurdly stiff hinge spring, released 10 degrees out"
bar rod { length = 1 m; mass = 2 kg; inertia = 2 kg*m^2/12 }
hinge pivot joins ground.origin to rod.a { stiffness = 1e16 N*m/rad }
initial { pivot = 10 deg }
simulate { t_end = 0.1 s; tol = 1e-8; dt_out = 0.01 s }
output theta = pivot
"""


CREEP = """model creep "a pendulum that comes to rest on its pivot's friction"
gravity = (0, -9.81) m/s^2
bar rod {{ length = 1 m; mass = 2 kg; inertia = 2 kg*m^2/12 }}
hinge pivot joins ground.origin to rod.a {{
    angle = rod - ground + 90 deg
    friction = 0.2 N*m
    slip_rate = {slip} rad/s
}}
initial {{ pivot = 10 deg }}
simulate {{ t_end = {t_end} s; tol = 1e-8; dt_out = 0.01 s }}
output theta = pivot
"""


@pytest.fixture(scope="module")
def build(tmp_path_factory):
    import depsim.codegen as codegen
    import depsim.dsl as dsl
    folder = tmp_path_factory.mktemp("budget")

    def get(text):
        source = folder / f"m{len(list(folder.glob('*.dep')))}.dep"
        source.write_text(text)
        return codegen.load_generated(codegen.compile_numpy(dsl.load_model(source),
                                                            folder / source.stem))

    return get


def test_a_stiff_mode_stops_the_run_at_once_naming_its_rate(build):
    # the relative rotation's damping acts on both bodies' rotation about their centres:
    # |lambda| = c (1/J_upper + 1/J_lower) = 1e5 * 12 = 1.2e6 1/s, far faster than the swing
    module = build(DOUBLE.format(k=1e6, c=1e5, t_end=10))
    with pytest.raises(SolverError) as caught:
        simulate(module)
    error = caught.value
    assert error.stage == "step size" and error.t < 1e-3  # within the first ~50 steps
    text = str(error)
    assert "the model is stiff here" in text and "over max_steps = 1000000" in text
    rate = float(text.split("rate about ")[1].split(" ")[0])
    assert rate == pytest.approx(1.2e6, rel=0.1)
    assert "phi most" in text  # the mode turns the bodies (upper.phi or lower.phi)
    assert "soften what moves it" in text and "raise max_steps" in text


def test_the_same_stiff_model_runs_when_its_steps_fit(build):
    module = build(DOUBLE.format(k=1e6, c=1e5, t_end=10))
    result = simulate(module, t_end=0.02)  # about 1e4 steps: within the default
    assert result.times[-1] == 0.02
    with pytest.raises(SolverError, match="stiff here"):
        simulate(module, t_end=0.02, max_steps=5000)


def test_friction_stiff_on_the_whole_mechanism_stops_the_run_naming_the_hinge(build):
    """Prescribed over the step, friction no longer bounds the explicit step by the rod's own
    rotation; what remains is its damping of the pendulum, up to friction / slip_rate / J_pivot
    = 0.2 / 1e-6 / (2/3) = 3e5 1/s once it creeps, which holds the step near 1e-5 s: 1000 s
    would take about 1e8 steps, so the run stops where the swing comes to rest."""
    module = build(CREEP.format(slip=1e-6, t_end=1000))
    with pytest.raises(SolverError) as caught:
        simulate(module)
    error = caught.value
    assert error.stage == "step size" and 0.5 < error.t < 10
    text = str(error)
    assert "hinge pivot's friction damps its motion" in text
    rate = float(text.split("rate of about ")[1].split(" ")[0])
    # C / J_pivot with the law's damping C = friction / slip_rate sech^2(rate / slip_rate)
    assert 0.2 * 3e5 < rate <= 3e5 * 1.001
    assert "friction / slip_rate = 2e+05 N m s/rad" in text
    assert "a larger slip_rate on pivot" in text and "raise max_steps" in text


def test_the_same_pendulum_with_the_default_slip_rate_comes_to_rest(build):
    """slip_rate 1e-3 rad/s: 300 1/s where it creeps, the steps fit; the rod ends at rest
    where gravity's torque is below the friction's (|m g d sin theta| <= 0.2 N m)."""
    module = build(CREEP.format(slip=1e-3, t_end=20))
    result = simulate(module)
    theta = result.hinge_angles[-1, 0]
    assert abs(2 * 9.81 * 0.5 * np.sin(theta)) <= 0.2 + 1e-9
    assert abs(result.hinge_rates[-1, 0]) < 1e-3


def test_a_motion_too_fast_for_the_time_asked_stops_after_a_thousand_steps(build):
    module = build(SPRING)
    with pytest.raises(SolverError) as caught:
        simulate(module)
    text = str(caught.value)
    assert "for 1000 steps" in text and "rod." in text  # the spring swings the rod
    steps_left = float(text.split("about ")[2].split(" ")[0])
    assert steps_left > 100 * 1e6
    assert caught.value.t < 1e-5


def test_max_steps_is_a_hard_limit(build):
    module = build(DOUBLE.format(k=1e3, c=0, t_end=2))
    with pytest.raises(SolverError, match=r"max_steps = 50 steps taken \(.*\), "
                       r"with [0-9.]+ s left") as caught:
        simulate(module, max_steps=50)
    counts = re.search(r"\((\d+) accepted, (\d+) rejected, (\d+) retried\)", str(caught.value))
    assert sum(int(n) for n in counts.groups()) == 50  # every attempt counts
    with pytest.raises(ValueError, match="max_steps must be"):
        simulate(module, max_steps=-1)
