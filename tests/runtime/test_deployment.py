"""Hard stops, hinge loads and their sign convention, the deployment summary, the animation.

Each check is against a closed form or a hand-made geometry (docs/deployment.md)."""

import json

import numpy as np
import pytest
from runtime_helpers import load_handmade, variant

from depsim.runtime import simulate
from depsim.runtime.animation import Geometry, animate
from depsim.runtime.interface import initial_state

J_O = 0.25 + 3 * 0.5 ** 2  # the 1 m, 3 kg bar about its end, kg m^2

STOPS = """model stops "a sprung bar between two stops"
bar arm { length = 1 m; mass = 3 kg; inertia = 0.25 kg*m^2 }
hinge h joins ground.origin to arm.a {
    stiffness = 4 N*m/rad
    stop_min = -20 deg
    stop_max = 30 deg
}
initial { h.rate = 2 rad/s }
simulate { t_end = 3 s; tol = 1e-10; dt_out = 0.01 s }
output theta = h
output omega = h.rate
"""

PUSHED = """model pushed "a bar pushed into a stop"
bar arm { length = 1 m; mass = 3 kg; inertia = 0.25 kg*m^2 }
hinge h joins ground.origin to arm.a {
    preload = 0.7 N*m
    stop_max = 45 deg
}
simulate { t_end = 3 s; tol = 1e-10; dt_out = 0.01 s }
output theta = h
"""

HANGING = """model hanging "a bar hanging at rest"
gravity = (0, -9.81) m/s^2
bar arm { length = 1 m; mass = 3 kg; inertia = 0.25 kg*m^2 }
hinge h joins ground.origin to arm.a {
    angle = arm - ground + 90 deg
    stop_max = 10 deg
}
simulate { t_end = 0.5 s; tol = 1e-10; dt_out = 0.1 s }
output theta = h
"""

TWO_BARS = """model folding "two bars folding to a latch"
bar bar1 { length = 1 m; mass = 10 kg; inertia = 1 kg*m^2 }
bar bar2 { length = 0.8 m; mass = 1.5 kg; inertia = 0.1 kg*m^2 }
hinge h1 joins ground.origin to bar1.a
hinge h2 joins bar1.b to bar2.a {
    latch = 90 deg
}
initial { h1 = 30 deg
          h2.rate = 3 rad/s }
simulate { t_end = 1.5 s; tol = 1e-9; dt_out = 0.02 s }
output theta2 = h2
"""



def test_stops_stop_the_hinge_plastically_and_release_when_the_spring_pulls(build):
    """theta = (w0/w) sin(w t), w = sqrt(k/J_O) = 2/s: it reaches stop_max = 30 deg, stops
    (energy J_O rate^2 / 2 lost), the spring pulls it back at once (the stop releases at the
    same instant), it swings from rest to stop_min = -20 deg at t1 + acos(-2/3)/w and stops."""
    result = simulate(build(STOPS))
    w, S_max, S_min = 2.0, np.radians(30), np.radians(-20)
    t1 = np.arcsin(S_max * w / 2.0) / w
    t2 = t1 + np.arccos(S_min / S_max) / w
    rate1, rate2 = 2.0 * np.cos(w * t1), -S_max * w * np.sin(w * (t2 - t1))
    got = [(e.name, e.data["limit"], e.data["action"]) for e in result.events]
    assert got == [("h.stop", "max", "contact"), ("h.stop", "max", "release"),
                   ("h.stop", "min", "contact"), ("h.stop", "min", "release")]
    assert abs(result.events[0].t - t1) < 1e-9 and result.events[1].t == result.events[0].t
    assert abs(result.events[2].t - t2) < 1e-9
    assert result.events[0].data["rate"] == pytest.approx(rate1, rel=1e-9)
    assert result.events[2].data["rate"] == pytest.approx(rate2, rel=1e-8)
    for event, rate in ((result.events[0], rate1), (result.events[2], rate2)):
        assert event.data["impact_energy_loss"] == pytest.approx(0.5 * J_O * rate ** 2, rel=1e-8)
        assert event.data["impulse"] == pytest.approx(-J_O * rate, rel=1e-8)
    # afterwards it swings between stop_min (at rest) and +20 deg, never touching stop_max
    after = result.times > t2
    top = np.max(result.output("theta")[after])  # sampled every 0.01 s
    assert -S_min - 1e-4 < top < -S_min + 1e-9
    assert np.max(np.abs(result.total_energy() - result.total_energy()[0])) < 1e-9


def test_a_stop_holds_a_pushing_preload_with_the_lock_torque(build):
    result = simulate(build(PUSHED))
    (contact,) = result.events
    assert contact.data["action"] == "contact"
    assert contact.t == pytest.approx(np.sqrt(2 * np.radians(45) * J_O / 0.7), abs=1e-9)
    after = result.times > contact.t
    assert np.allclose(result.output("theta")[after], np.radians(45), atol=1e-12)
    # the stop pushes back on the arm with T = -P (N m), in theta's sense
    assert np.allclose(result.hinge_loads["h"].torque[after], -0.7, rtol=1e-9)
    assert np.all(np.isnan(result.hinge_loads["h"].torque[~after]))
    assert result.peak_loads["h"].torque == pytest.approx(0.7, rel=1e-9)


def test_hinge_force_is_the_force_on_member_b_from_member_a(build):
    """A bar hanging at rest from the ground: the pin holds it up, F = (0, +m g) on the bar."""
    result = simulate(build(HANGING))
    load = result.hinge_loads["h"]
    assert np.allclose(load.force_x, 0.0, atol=1e-9)
    assert np.allclose(load.force_y, 3 * 9.81, rtol=1e-9)
    assert np.allclose(load.force, 3 * 9.81, rtol=1e-9)
    peak = result.peak_loads["h"]
    assert peak.force == pytest.approx(3 * 9.81, rel=1e-9) and peak.torque == 0.0
    assert result.deployment.deployed is None  # no latch in this model


def test_summary_report_and_switch(build):
    module = build(TWO_BARS)
    result = simulate(module)
    summary = json.loads(json.dumps(result.summary(), allow_nan=False))
    assert summary["deployment"]["deployed"] is True
    (latch,) = summary["deployment"]["latches"]
    assert latch["hinge"] == "h2" and latch["rigid"] is True
    assert latch["t"] == summary["deployment"]["time_to_deploy"]
    assert set(summary["peak_hinge_loads"]) == {"h1", "h2"}
    assert {"force", "t_force", "torque", "t_torque"} <= set(summary["peak_hinge_loads"]["h1"])
    assert [e["name"] for e in summary["events"]] == ["h2.latch"]
    report = result.report()
    assert report.splitlines()[1].startswith("  DEPLOYED")
    assert "latch h2: t = " in report and "impulse" in report and "peak hinge loads" in report
    # mechanics=False: the same model folds through the latch angle
    free = simulate(module, mechanics=False)
    assert free.events == () and free.output("theta2")[-1] > np.pi / 2 + 0.5
    assert "NOT DEPLOYED" not in report and free.deployment.deployed is None


def test_the_summary_counts_one_latch_in_the_singular(build):
    """One latch: "1 latch latched", "1 of 1 latch open"; several keep "all 13 latches"
    (tests/examples/test_accordion.py)."""
    module = build(TWO_BARS)
    lines = simulate(module).report().splitlines()
    assert lines[1].startswith("  DEPLOYED: 1 latch latched; full deployment at t = ")
    early = simulate(module, t_end=0.05).report().splitlines()
    assert early[1] == "  NOT DEPLOYED by t = 0.05 s: 1 of 1 latch open (h2)"


def test_geometry_reconstructs_bar_ends_and_hinges(build):
    module = build(TWO_BARS)
    p = np.array(module.PARAMETER_DEFAULTS)
    q, _ = initial_state(module, p)
    members, hinges = Geometry(module, p).shapes(q)
    e1 = np.array([np.cos(np.radians(30)), np.sin(np.radians(30))])
    assert np.allclose(hinges, [[0.0, 0.0], e1], atol=1e-12)
    assert np.allclose(members[0], [[0.0, 0.0], e1], atol=1e-12)
    assert np.allclose(members[1], [e1, 1.8 * e1], atol=1e-12)


def test_animation_writes_a_gif_from_a_points_interface(pendulum, tmp_path):
    """A hand-made module with the preferred geometry interface: POINTS, points(q, p),
    MEMBER_POINTS, HINGE_POINTS."""
    from PIL import Image

    def points(q, p):
        L = p[0]
        half = L / 2 * np.array([np.cos(q[2]), np.sin(q[2])])
        return np.array([[0.0, 0.0], q[:2] - half, q[:2] + half])

    module = variant(load_handmade("pendulum"), POINTS=("ground.origin", "rod.a", "rod.b"),
                     points=points, MEMBERS=("rod",), MEMBER_POINTS=((1, 2),),
                     HINGE_POINTS=(0,))
    result = simulate(module, t_end=0.5, dt_out=0.05)
    frames = animate(result, module, tmp_path / "pendulum.gif", max_frames=6)
    image = Image.open(tmp_path / "pendulum.gif")
    assert image.format == "GIF" and frames == 6 and image.n_frames == 6
    assert not list(tmp_path.glob(".*tmp*"))


def test_animation_of_a_generated_model_marks_the_latch(build, tmp_path):
    from PIL import Image
    module = build(TWO_BARS)
    result = simulate(module)
    animate(result, module, tmp_path / "folding.gif", max_frames=5)
    image = Image.open(tmp_path / "folding.gif")
    assert image.n_frames == 5
    # the last frame is after the latch: a red square (tab:red) is drawn
    image.seek(4)
    pixels = np.asarray(image.convert("RGB")).reshape(-1, 3).astype(int)
    assert np.any((abs(pixels[:, 0] - 214) < 8) & (abs(pixels[:, 1] - 39) < 8)
                  & (abs(pixels[:, 2] - 40) < 8))
