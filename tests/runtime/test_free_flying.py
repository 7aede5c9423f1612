"""A free-flying spacecraft (examples/free_flyer.dep): a bus given its initial velocity and
spin by a free joint, a two-panel array held down until t_release, pushed off by a kick-off
spring, unfolded by its hinge springs and locked by two rigid latches. No external force or
torque acts, so the system's linear and angular momentum stay what they were at t = 0 through
the release, the spring's push and both latch impacts (plastic impacts by internal rows,
which move neither the centre of mass nor the angular momentum)."""

import math

import numpy as np
import pytest

import depsim
from depsim.runtime import simulate

EXAMPLE = "examples/free_flyer.dep"


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    sim = depsim.load(root / EXAMPLE).compile("c", out_dir=tmp_path_factory.mktemp("flyer"))
    return sim, sim.run()


def test_the_free_joint_starts_the_bus_with_its_given_velocity_and_spin(flight):
    sim, result = flight
    names = result.coordinate_names
    assert result.qd[0, names.index("bus.x")] == 0.01
    assert result.qd[0, names.index("bus.phi")] == pytest.approx(math.radians(0.5), rel=1e-15)
    assert not sim.model.ir.warnings  # W001 silenced: the bus is placed by its free joint
    assert {"flight.initial_vx", "spin", "t_release"} <= set(sim.parameter_names)


def test_the_array_deploys_after_its_release(flight):
    _, result = flight
    names = [(e.name, e.t) for e in result.events]
    assert names[:4] == [("h1.hold", 0.0), ("h2.hold", 0.0), ("h1.release", 2.0),
                         ("h2.release", 2.0)]
    held = result.times <= 2.0
    assert np.max(np.abs(result.output("h1_angle")[held])) < 1e-9
    assert result.deployment.deployed


def test_the_hold_down_carries_the_kick_off_spring_and_the_preload(flight):
    """While held (and the bus not spinning), h1's lock torque balances the hinge spring's
    preload and the spring's push on panel1 (its moment about the hinge):
    T = -(preload + F arm)."""
    sim, _ = flight
    result = sim.run(set={"spin": "0 rad/s"}, t_end=2.5)
    held = (result.times > 0.0) & (result.times < 2.0)
    arm = 1.1  # the pad is 1.1 m from the hinge along panel1, the push square to it
    torque = result.output("h1_torque")[held]
    push = result.output("kick_force")[held]
    np.testing.assert_allclose(torque, -(1.5 + push * arm), rtol=1e-9)
    assert push[0] == pytest.approx(5.0 + 1000 * 0.03, rel=1e-12)  # preload + k * squeeze


def test_linear_and_angular_momentum_hold_through_release_and_latches(flight):
    """Measured at tol 1e-8: momentum constant to 2e-14 (a linear invariant: exact but for
    round-off), angular momentum to 5.5e-8 of itself (quadratic: the method's error)."""
    _, result = flight
    for name in ("p_x", "p_y"):
        values = result.output(name)
        assert np.max(np.abs(values - values[0])) < 1e-12 * abs(result.output("p_x")[0])
    for name in ("H", "H_origin"):
        values = result.output(name)
        assert np.max(np.abs(values - values[0])) < 10 * result.tol * abs(values[0])


def test_the_system_outputs_agree_with_the_parts(flight):
    """p = sum m v over the members, the bus's 500 kg at 0.01 m/s; the energy balance:
    kinetic + potential + dissipated is constant (the spring's switch found by the step
    control: within 1e-5 of the energy)."""
    _, result = flight
    assert result.output("p_x")[0] == pytest.approx(520 * 0.01, rel=1e-12)
    total = result.output("energy") + result.output("dissipated")
    assert np.max(np.abs(total - total[0])) < 1e-5 * total[0]
    impacts = sum(e.data["impact_energy_loss"] for e in result.events if e.kind == "latch")
    assert result.output("dissipated")[-1] == pytest.approx(
        impacts + result.deployment.friction_energy, rel=1e-12)
