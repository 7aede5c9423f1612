"""Closed loops assembled at t = 0 (docs/language.md, Assembly): examples/fourbar.dep gives only
the crank's angle and rate; the coupler and rocker are solved. Checked against the four-bar's
closed-form position and velocity analysis, and its motion against Lagrange's equation in the
crank angle alone."""

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import depsim
from depsim.runtime import SolverError, simulate

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "fourbar.dep"
A, CRANK, COUPLER, ROCKER = 0.28, 0.10, 0.25, 0.20  # ground_x and the three bar lengths
MASSES = (0.3, 0.6, 0.5)


def rocker_tip(theta):
    """The coupler-rocker pin C for crank angle theta: the circles about the crank tip B
    (radius COUPLER) and about the rocker pivot D = (A, 0) (radius ROCKER) meet at C, the
    intersection on the left of B -> D (the branch with C above the line of the pivots)."""
    b = CRANK * np.array([np.cos(theta), np.sin(theta)])
    d = np.array([A, 0.0]) - b
    distance = np.hypot(*d)
    along = (COUPLER ** 2 - ROCKER ** 2 + distance ** 2) / (2 * distance)
    height = np.sqrt(COUPLER ** 2 - along ** 2)
    unit = d / distance
    return b, b + along * unit + height * np.array([-unit[1], unit[0]])


def coordinates(theta):
    """All nine absolute coordinates (centre x, y and angle of crank, coupler, rocker)."""
    b, c = rocker_tip(theta)
    coupler = np.arctan2(*(c - b)[::-1])
    rocker = np.arctan2(c[1], c[0] - A)
    return np.array([*(b / 2), theta, *((b + c) / 2), coupler,
                     *((np.array([A, 0.0]) + c) / 2), rocker])


def derivative(f, x, h=1e-4):
    """Fourth-order central difference (error ~ h^4 f^(5) / 30)."""
    return (-f(x + 2 * h) + 8 * f(x + h) - 8 * f(x - h) + f(x - 2 * h)) / (12 * h)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    model = depsim.load(EXAMPLE)
    folder = tmp_path_factory.mktemp("fourbar")
    return {target: model.compile(target, out_dir=folder / target).run()
            for target in ("numpy", "c")}


@pytest.mark.parametrize("target", ["numpy", "c"])
def test_the_loop_is_assembled_from_the_crank_angle(runs, target):
    result = runs[target]
    theta, omega = np.radians(60), 2.0
    np.testing.assert_allclose(result.q[0], coordinates(theta), rtol=0, atol=1e-12)
    rates = derivative(coordinates, theta) * omega
    np.testing.assert_allclose(result.qd[0], rates, rtol=0, atol=1e-9)
    assembly = result.events[0]
    assert assembly.name == "assembly" and assembly.t == 0.0
    assert set(assembly.data["values"]) == {"knee", "rest"}  # drive is given: held
    angles = result.hinge_angles[0]
    assert angles[result.hinge_names.index("drive")] == pytest.approx(theta, abs=1e-15)
    assert assembly.data["values"]["rest"] == pytest.approx(coordinates(theta)[8], abs=1e-12)
    assert max(result.residual_pos[0], result.residual_vel[0]) < 1e-12


def test_the_motion_follows_the_crank_angle_equation(runs):
    """(g'^T M g') theta'' + (g'^T M g'') theta'^2 = preload - c theta' with g(theta) the
    coordinates above (derivatives by finite differences), DOP853 at rtol 1e-12."""
    m = [MASSES[0], MASSES[0], MASSES[0] * CRANK ** 2 / 12,
         MASSES[1], MASSES[1], MASSES[1] * COUPLER ** 2 / 12,
         MASSES[2], MASSES[2], MASSES[2] * ROCKER ** 2 / 12]
    mass = np.array(m)

    def rhs(t, y):
        theta, omega = y
        g1 = derivative(coordinates, theta)
        g2 = derivative(lambda x: derivative(coordinates, x, 1e-3), theta, 1e-3)
        torque = 0.2 - 0.02 * omega
        return [omega, (torque - (g1 @ (mass * g2)) * omega ** 2) / (g1 @ (mass * g1))]

    result = runs["c"]
    sol = solve_ivp(rhs, (0, 1.0), [np.radians(60), 2.0], method="DOP853", rtol=1e-12,
                    atol=1e-12, t_eval=result.times[result.times <= 1.0])
    crank = result.output("crank_angle")[result.times <= 1.0]
    assert np.max(np.abs(crank - sol.y[0])) < 1e-6  # the reference's differences: ~1e-8
    energy = result.total_energy()
    assert np.max(np.abs(energy - energy[0])) < 1e-7


def test_both_targets_assemble_alike(runs):
    np.testing.assert_array_equal(runs["numpy"].q[0], runs["c"].q[0])
    assert runs["numpy"].events[0].data == runs["c"].events[0].data


def model_with(tmp_path, initial: str, name="variant"):
    text = EXAMPLE.read_text()
    start = text.index("initial {")
    end = text.index("}", start) + 1
    path = tmp_path / f"{name}.dep"
    path.write_text(text[:start] + initial + text[end:])
    return depsim.load(path).compile("c", out_dir=tmp_path / name)


def test_a_loop_closing_hinge_given_an_angle_is_held(tmp_path):
    """elbow closes the loop (the tree is drive, rest, knee): giving only its angle drives
    the assembly, and --set elbow.initial_angle changes the run."""
    sim = model_with(tmp_path, "initial { elbow = -100 deg }")
    result = sim.run(t_end=0.01)
    elbow = result.hinge_names.index("elbow")
    assert result.hinge_angles[0, elbow] == pytest.approx(np.radians(-100), abs=1e-12)
    moved = sim.run(t_end=0.01, set={"elbow.initial_angle": "-110 deg"})
    assert moved.hinge_angles[0, elbow] == pytest.approx(np.radians(-110), abs=1e-12)
    assert not np.allclose(moved.q[0], result.q[0])


def test_values_that_cannot_all_hold_are_an_error_naming_them(tmp_path):
    sim = model_with(tmp_path, "initial { drive = 60 deg; rest = 10 deg }")
    with pytest.raises(SolverError) as caught:
        sim.run(t_end=0.01)
    text = str(caught.value)
    assert caught.value.stage == "initial state" and caught.value.t == 0.0
    assert "the given initial values cannot all hold: drive = 1.0472, rest = 0.174533" in text
    assert "give fewer initial values" in text


def test_rates_that_cannot_all_hold_are_an_error(tmp_path):
    sim = model_with(tmp_path, "initial { drive = 60 deg; drive.rate = 1 rad/s; "
                               "rest.rate = 5 rad/s }")
    with pytest.raises(SolverError, match="the given initial rates cannot all hold"):
        sim.run(t_end=0.01)


def test_simulate_of_a_tree_placement_that_closes_is_unchanged(pendulum):
    """A model without loops (or whose given values close them) starts at its placement."""
    result = simulate(pendulum, t_end=0.01)
    q0, qd0 = pendulum.initial_state(np.array(pendulum.PARAMETER_DEFAULTS))
    np.testing.assert_array_equal(result.q[0], q0)
    assert not any(e.name == "assembly" for e in result.events)
