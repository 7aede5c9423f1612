"""examples/canted_wing.dep and examples/reflector_arm.dep (docs/examples.md, the spatial
deployables) deploying as the page says, on the C target.

Reference numbers and where they come from:
* the statics at the end (latched, at rest): closed forms from the models' data, each lock
  torque the spring's torque at the latch angle, T = -(preload - k theta) (the wing's cable
  loops are slack there: their pulley ratios are the hinges' travels); a compliant latch
  pressed in by T / latch_stiffness;
* the synchronisation, the sequence and its margin under +-20 % friction: the page's claims,
  with room: the wing's loops stretch at most 3.8 and 4.6 deg (bound 5 deg); the reflector's
  elbow latches at least 9.7 s after the shoulder at every corner (bound 8 s);
* the energy balance: kinetic + potential + dissipated stays within 1.7e-8 J (wing) and
  3.5e-7 J (reflector) of its start; bound 1e-6 J, of 9.2 and 7.9 J released.
The latch times and loads themselves are the stored outputs' (test_stored_outputs.py).
"""

import itertools
import math

import numpy as np
import pytest

import depsim
from e2e import EXAMPLES


@pytest.fixture(scope="module")
def wing(tmp_path_factory):
    sim = depsim.load(EXAMPLES / "canted_wing.dep").compile(
        "c", out_dir=tmp_path_factory.mktemp("wing"))
    return sim, sim.run()


@pytest.fixture(scope="module")
def reflector(tmp_path_factory):
    sim = depsim.load(EXAMPLES / "reflector_arm.dep").compile(
        "c", out_dir=tmp_path_factory.mktemp("reflector"))
    return sim, sim.run()


def balance_drift(result) -> float:
    balance = result.output("energy_balance")
    return float(np.max(np.abs(balance - balance[0])))


def test_the_wing_deploys_in_step_root_first(wing):
    _, result = wing
    assert result.deployment.deployed is True
    assert [x.hinge for x in result.deployment.latches] == ["root", "inner", "outer"]
    assert all(x.rigid for x in result.deployment.latches)
    for loop in ("root_loop_stretch", "outer_loop_stretch"):
        assert np.max(np.abs(result.output(loop))) < math.radians(5)
    assert balance_drift(result) < 1e-6


def test_the_deployed_wing_points_15_deg_off_the_face_normal(wing):
    _, result = wing
    root = np.array([0.05, 0.0, 0.0])  # the root bracket (examples/canted_wing.dep)
    tip = np.array([result.output(f"tip_{c}")[-1] for c in "xyz"])
    span = tip - root
    assert math.degrees(math.acos(span[0] / np.linalg.norm(span))) == pytest.approx(15, abs=1)


def test_the_latched_wing_holds_its_springs(wing):
    _, result = wing
    latch = {"root": math.pi / 2, "inner": math.radians(176), "outer": math.radians(179)}
    preload = {"root": 2.0, "inner": 1.2, "outer": 1.2}
    for k, hinge in enumerate(result.hinge_names):
        assert result.hinge_angles[-1, k] == pytest.approx(latch[hinge], abs=1e-9)
        spring = preload[hinge] - 0.13 * latch[hinge]
        assert result.hinge_torque[-1, k] == pytest.approx(-spring, abs=1e-6)


def test_the_wing_deploys_with_its_friction_20_percent_off(wing):
    sim, _ = wing
    hinges = ("root", "inner", "outer")
    nominal = {"root": 0.2, "inner": 0.1, "outer": 0.1}
    for factors in itertools.product((0.8, 1.2), repeat=3):
        result = sim.run(set={f"{h}.friction": f * nominal[h]
                              for h, f in zip(hinges, factors)})
        assert result.deployment.deployed is True, factors
        assert [x.hinge for x in result.deployment.latches] == list(hinges), factors


def test_the_reflector_latches_shoulder_then_elbow_and_faces_the_earth(reflector):
    _, result = reflector
    assert result.deployment.deployed is True
    first, second = result.deployment.latches
    assert (first.hinge, second.hinge) == ("shoulder", "elbow")
    assert not first.rigid and not second.rigid
    boresight = [result.output(f"boresight_{c}")[-1] for c in "xyz"]
    np.testing.assert_allclose(boresight, [0, 0, 1], atol=1e-3)
    assert balance_drift(result) < 1e-6


def test_the_reflector_rests_pressed_into_its_compliant_latches(reflector):
    _, result = reflector
    data = {"shoulder": (4.0, 0.5, 5000.0), "elbow": (1.6, 0.2, 3000.0)}
    for k, hinge in enumerate(result.hinge_names):
        preload, stiffness, latch_stiffness = data[hinge]
        theta = result.hinge_angles[-1, k]
        assert result.hinge_torque[-1, k] == pytest.approx(
            -(preload - stiffness * theta), rel=1e-5)
        assert theta - math.pi / 2 == pytest.approx(
            (preload - stiffness * theta) / latch_stiffness, rel=1e-4)


def test_the_reflector_sequence_holds_with_its_friction_20_percent_off(reflector):
    sim, _ = reflector
    for shoulder, elbow in itertools.product((0.32, 0.48), (0.16, 0.24)):
        result = sim.run(set={"shoulder.friction": shoulder, "elbow.friction": elbow})
        times = {x.hinge: x.t for x in result.deployment.latches}
        assert result.deployment.deployed is True
        assert times["elbow"] - times["shoulder"] > 8.0, (shoulder, elbow, times)
