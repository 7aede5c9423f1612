"""Welds and the loads outputs name (`h.force_x`, `w.torque`, ...), against statics and the
run's own hinge loads; the hold-down release (`release`) against its holding torque."""

import numpy as np
import pytest

from depsim.runtime import simulate

CANTILEVER = """model cantilever "a bar welded to the ground at one end, in gravity"
gravity = (0, -9.81) m/s^2
bar arm { length = 2 m; mass = 3 kg; inertia = 1 kg*m^2 }
weld root joins ground.origin to arm.a { angle = 30 deg }
simulate { t_end = 1 s; dt_out = 0.5 s }
output fx = root.force_x
output fy = root.force_y
output f = root.force
output torque = root.torque
output tip_y = arm.b.y
"""


def test_a_weld_holds_its_member_and_carries_its_weight_and_moment(build_c):
    """At rest at 30 deg: the force on the bar from the ground is (0, m g) and the moment
    m g (L/2) cos 30 deg, counter-clockwise."""
    result = simulate(build_c(CANTILEVER))
    m, g = 3.0, 9.81
    np.testing.assert_allclose(result.output("fx"), 0.0, atol=1e-9)
    np.testing.assert_allclose(result.output("fy"), m * g, rtol=1e-9)
    np.testing.assert_allclose(result.output("f"), m * g, rtol=1e-9)
    np.testing.assert_allclose(result.output("torque"), m * g * np.cos(np.pi / 6), rtol=1e-9)
    np.testing.assert_allclose(result.output("tip_y"), 2 * np.sin(np.pi / 6), atol=1e-9)


PENDULUM = """model loads "a pendulum with a latch: its loads as outputs"
gravity = (0, -9.81) m/s^2
bar rod { length = 1 m; mass = 2 kg; inertia = 0.1667 kg*m^2 }
hinge pivot joins ground.origin to rod.a { angle = rod - ground + 90 deg; latch = 0 deg
                                           release = 0.5 s }
initial { pivot = 60 deg }
simulate { t_end = 2 s; dt_out = 0.01 s }
output fx = pivot.force_x
output fy = pivot.force_y
output f = pivot.force
output torque = pivot.torque
"""


@pytest.fixture(scope="module")
def latched(build_c):
    return simulate(build_c(PENDULUM))


def test_hinge_load_outputs_are_the_runs_hinge_loads(latched):
    loads = latched.hinge_loads["pivot"]
    np.testing.assert_array_equal(latched.output("fx"), loads.force_x)
    np.testing.assert_array_equal(latched.output("fy"), loads.force_y)
    np.testing.assert_allclose(latched.output("f"), loads.force, rtol=1e-15)
    locked = np.isfinite(loads.torque)
    np.testing.assert_array_equal(latched.output("torque")[locked], loads.torque[locked])
    assert np.all(latched.output("torque")[~locked] == 0.0)  # 0 while nothing holds it


def test_a_hold_down_holds_until_its_release_then_lets_the_hinge_go(latched):
    """Held at 60 deg until 0.5 s, its lock torque balances gravity's moment, -m g (L/2)
    sin 60 deg; released, the pendulum swings down to its latch at 0 deg."""
    t = latched.times
    held = (t > 0) & (t < 0.5)
    angle = latched.hinge_angles[:, 0]
    np.testing.assert_allclose(angle[held], np.pi / 3, atol=1e-10)
    np.testing.assert_allclose(latched.output("torque")[held],
                               -2 * 9.81 * 0.5 * np.sin(np.pi / 3) * -1, rtol=1e-9)
    kinds = [(e.kind, e.t) for e in latched.events]
    assert kinds[:2] == [("hold", 0.0), ("release", 0.5)]
    assert latched.events[1].data["torque"] == pytest.approx(9.81 * np.sin(np.pi / 3),
                                                             rel=1e-9)
    assert [e.kind for e in latched.events][2] == "latch"


def test_the_release_time_is_a_parameter(build_c):
    module = build_c(PENDULUM)
    p = np.array(module.PARAMETER_DEFAULTS)
    p[list(module.PARAMETERS).index("pivot.release")] = 1.0
    result = simulate(module, p)
    assert [(e.kind, e.t) for e in result.events][:2] == [("hold", 0.0), ("release", 1.0)]
