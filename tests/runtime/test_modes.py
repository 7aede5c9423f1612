"""Natural frequencies of the linearised constrained mechanism (depsim modes,
depsim.runtime.modes) against closed forms: Euler-Bernoulli beams clamped, pinned and free
(their frequency equations solved here by brentq), a cantilever with a tip mass, a rigid
pendulum's small oscillation, a compliant latch holding a deployed bar, and the rigid motions
of a free body (zero)."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import depsim

EI, RHO_A, L = 200.0, 0.5, 2.0  # N*m^2, kg/m, m

BEAM = """model beam "a beam"
beam boom {{ length = 2 m; EI = 200 N*m^2; EA = 1e7 N; mass_per_length = 0.5 kg/m
            elements = {elements} }}
{support}
simulate {{ t_end = 1 s }}
"""
SUPPORTS = {
    "clamped_tip": "particle tip { mass = 2 kg }\nweld root joins ground.origin to boom.a\n"
                   "weld end joins boom.b to tip.cm",
    "pinned": "hinge root joins ground.origin to boom.a",
    "free": "free flight joins ground.origin to boom.a",
}


@pytest.fixture(scope="module")
def compiled(tmp_path_factory):
    folder = tmp_path_factory.mktemp("modes")
    made = {}

    def get(text):
        if text not in made:
            path = folder / f"m{len(made)}.dep"
            path.write_text(text)
            made[text] = depsim.load(path).compile("c", out_dir=folder / f"c{len(made)}")
        return made[text]

    return get


def beam_frequency(beta_l: float) -> float:
    """Hz of a bending mode with beta L given: omega = (beta L / L)^2 sqrt(EI / rho A)."""
    return (beta_l / L) ** 2 * math.sqrt(EI / RHO_A) / (2 * math.pi)


def roots(equation, count: int) -> list[float]:
    """The first `count` positive roots of equation(beta L), bracketed on a fine grid."""
    grid = np.linspace(0.5, 20.0, 4000)
    values = [equation(x) for x in grid]
    found = [brentq(equation, a, b, xtol=1e-14) for a, b, fa, fb
             in zip(grid, grid[1:], values, values[1:]) if fa * fb < 0]
    return found[:count]


def test_cantilever_with_tip_mass_matches_its_frequency_equation(compiled):
    """1 + cos(bL) cosh(bL) + (M b / rho A)(cos(bL) sinh(bL) - sin(bL) cosh(bL)) = 0 with
    M = 2 kg: 0.92166 Hz, then 12.62 Hz (eight Hermite elements: within 1e-6 and 1e-4)."""
    mass_ratio = 2.0 / (RHO_A * L)

    def equation(x):
        return (1 + math.cos(x) * math.cosh(x)
                + mass_ratio * x * (math.cos(x) * math.sinh(x) - math.sin(x) * math.cosh(x)))

    exact = [beam_frequency(x) for x in roots(equation, 2)]
    found = compiled(BEAM.format(elements=8, support=SUPPORTS["clamped_tip"])).modes(count=2)
    assert exact[0] == pytest.approx(0.92166, abs=1e-5)
    assert found.frequencies[0] == pytest.approx(exact[0], rel=1e-6)
    assert found.frequencies[1] == pytest.approx(exact[1], rel=1e-4)
    assert found.locked == () and found.degrees_of_freedom == 9 * 4 + 2 - 3 - 2


def test_pinned_free_beam_has_a_rigid_rotation_then_its_bending_modes(compiled):
    """tan(bL) = tanh(bL), as sin(bL) cosh(bL) - cos(bL) sinh(bL) = 0: bL = 3.9266, 7.0686;
    the rotation about the pin is free (0 Hz). Eight elements: within 1e-4 and 1e-3."""
    exact = [beam_frequency(x) for x in roots(lambda x: math.sin(x) * math.cosh(x)
                                              - math.cos(x) * math.sinh(x), 2)]
    found = compiled(BEAM.format(elements=8, support=SUPPORTS["pinned"])).modes(count=3)
    assert abs(found.frequencies[0]) < 1e-4
    assert found.frequencies[1] == pytest.approx(exact[0], rel=1e-4)
    assert found.frequencies[2] == pytest.approx(exact[1], rel=1e-3)
    assert found.shapes[0][0] == pytest.approx(0.0, abs=1e-9)  # end a stays at the pin


def test_free_beam_has_three_rigid_motions_then_free_free_bending(compiled):
    """cos(bL) cosh(bL) = 1: bL = 4.7300, 7.8532; translations and rotation at 0 Hz. Eight
    elements: within 1e-4 and 1e-3 (measured 8e-5, 5.8e-4)."""
    exact = [beam_frequency(x) for x in roots(lambda x: math.cos(x) * math.cosh(x) - 1, 2)]
    found = compiled(BEAM.format(elements=8, support=SUPPORTS["free"])).modes(count=5)
    assert np.all(np.abs(found.frequencies[:3]) < 1e-4)
    assert found.frequencies[3] == pytest.approx(exact[0], rel=1e-4)
    assert found.frequencies[4] == pytest.approx(exact[1], rel=1e-3)


def test_rigid_pendulum_small_oscillation(compiled):
    """A bar hanging at rest: omega^2 = m g d / J_O, from the pivot's reaction alone (the
    constraint forces' stiffness)."""
    sim = compiled('model p "a pendulum"\ngravity = (0, -9.81) m/s^2\n'
                   'bar rod { length = 1.5 m; mass = 2 kg; inertia = 0.375 kg*m^2 }\n'
                   'hinge pivot joins ground.origin to rod.a { angle = rod - ground + 90 deg }\n')
    found = sim.modes()
    J_O = 0.375 + 2 * 0.75 ** 2
    assert found.degrees_of_freedom == 1
    assert found.frequencies[0] == pytest.approx(math.sqrt(2 * 9.81 * 0.75 / J_O)
                                                 / (2 * math.pi), rel=1e-7)
    assert found.hinge_motion[0][0] == pytest.approx(1 / 0.75, rel=1e-7)  # 1 m at the CM


def test_deployed_compliant_latch_is_a_spring_about_its_latch_angle(compiled):
    """A bar driven to a compliant latch (k = 50 N*m/rad): deployed, it vibrates at
    sqrt((k + hinge spring) / J_O); a rigid latch instead locks it (no mode)."""
    text = ('model d "a bar to a latch"\n'
            'bar arm { length = 1 m; mass = 1 kg; inertia = 0.0833 kg*m^2 }\n'
            'hinge h joins ground.origin to arm.a { preload = 0.5 N*m; stiffness = 0.1 N*m/rad\n'
            '    latch = 90 deg; {latch} }}\n'
            'simulate {{ t_end = 10 s }}\n')
    found = compiled(text.replace("{latch}", "latch_stiffness = 50 N*m/rad").replace("{{", "{")
                     .replace("}}", "}")).modes(at="deployed")
    J_O = 0.0833 + 0.25
    assert found.compliant == ("h",) and found.locked == ()
    assert found.frequencies[0] == pytest.approx(math.sqrt(50.1 / J_O) / (2 * math.pi),
                                                 rel=1e-6)
    rigid = compiled(text.replace("{latch}", "").replace("{{", "{").replace("}}", "}"))
    locked = rigid.modes(at="deployed")
    assert locked.locked == ("h",) and locked.degrees_of_freedom == 0
    assert len(locked.frequencies) == 0


def test_two_link_flexible_pendulum_modes_converge_with_the_mesh(compiled):
    """The example at its start, held straight (the 5 deg of link 2 taken out; the links
    horizontal, where gravity's moment does not change to first order: the two pendulum
    modes at 0 Hz): its first bending frequencies at 4 elements per link within 1e-3 of
    those at 8 (measured 3e-4, 8.5e-4; a finer mesh's run: bench/modes_spectrum.py)."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "examples" / "two_link_flex.dep").read_text()
    text = text.replace("h2 = 5 deg", "h2 = 0 deg")
    coarse = compiled(text.replace("elements        = 2", "elements = 4")).modes(count=4)
    fine = compiled(text.replace("elements        = 2", "elements = 8")).modes(count=4)
    assert np.all(np.abs(fine.frequencies[:2]) < 1e-6)
    np.testing.assert_allclose(coarse.frequencies[2:], fine.frequencies[2:], rtol=1e-3)


@pytest.mark.parametrize("item, message", [
    ("tip.mass", "tip.mass must be positive, got -2 kg"),
    ("boom.EI", "boom.EI must be positive, got -2 N*m^2")])
def test_modes_holds_set_to_the_ranges_of_run(compiled, item, message):
    """Simulator.modes(set=...) refuses a value out of the model's ranges as run(set=...)
    does: the same UsageError, before anything runs."""
    from depsim.errors import UsageError

    sim = compiled(BEAM.format(elements=2, support=SUPPORTS["clamped_tip"]))
    errors = []
    for call in (sim.run, sim.modes):
        with pytest.raises(UsageError) as caught:
            call(set={item: -2.0})
        errors.append(str(caught.value))
    assert errors[0] == errors[1] == f"{message} (from {item}=-2.0)"
