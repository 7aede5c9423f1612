"""The shipped examples check clean, and their IR says what docs/examples.md says."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from depsim.dsl import evaluate, load_model, summary
from depsim.dsl.ir import Num

EXAMPLES = sorted((Path(__file__).parents[2] / "examples").glob("*.dep"))


def values(model):
    return [p.default for p in model.params]


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_checks_clean(path):
    model = load_model(path)
    assert model.warnings == ()
    assert model.name == path.stem
    assert summary(model).startswith(f"model {model.name}")


def test_there_are_examples():
    assert {p.stem for p in EXAMPLES} >= {"intelsat5", "two_link_flex", "pendulum",
                                          "slider_crank"}


def test_intelsat5_matches_models_md():
    m = load_model(EXAMPLES[0].with_name("intelsat5.dep"))
    p = values(m)
    assert [b.name for b in m.bodies] == ["yoke", "panel1", "panel2", "panel3"]
    assert [evaluate(b.mass, p) for b in m.bodies] == [2.222, 12.377, 9.982, 8.920]
    assert [(h.sign, round(evaluate(h.offset, p), 12)) for h in m.hinges] == \
        [(1, 0.0), (1, round(math.pi, 12)), (-1, round(math.pi, 12)), (1, round(math.pi, 12))]
    assert [evaluate(h.latch, p) for h in m.hinges] == \
        pytest.approx([math.pi / 2, math.pi, math.pi, math.pi])
    assert [evaluate(h.friction, p) for h in m.hinges] == [0.68, 0.64, 0.69, 0.70]
    kc = 4500 * 0.01835**2
    assert [evaluate(c.stiffness, p) for c in m.cables] == pytest.approx([kc] * 3)
    combos = [[(t.hinge, evaluate(t.coefficient, p)) for t in c.terms] for c in m.cables]
    assert combos == [[(0, 2.0), (1, -1.0)], [(1, 1.0), (2, -1.0)], [(2, 1.0), (3, -1.0)]]
    assert m.gravity == (Num(0.0), Num(0.0))  # in orbit
    assert (m.simulation.t_end, m.simulation.dt_out) == (80.0, 0.05)  # runs to full deployment


def test_two_link_flex_matches_models_md():
    m = load_model(EXAMPLES[0].with_name("two_link_flex.dep"))
    p = values(m)
    assert [b.elements for b in m.beams] == [2, 2]
    assert evaluate(m.beams[0].EI, p) == pytest.approx(1000.0)
    assert evaluate(m.beams[1].EA, p) == pytest.approx(2e11 * 2.449e-4)
    assert evaluate(m.beams[0].mass_per_length, p) == 5.0
    assert evaluate(m.gravity[1], p) == pytest.approx(-9.81)
    assert evaluate(m.hinges[1].initial_angle, p) == pytest.approx(math.radians(5))
    assert [o.unit for o in m.outputs] == ["rad", "m"]


def test_canted_wing_matches_models_md():
    m = load_model(EXAMPLES[0].with_name("canted_wing.dep"))
    p = values(m)
    assert m.spatial and m.gravity == (Num(0.0), Num(0.0), Num(0.0))  # in orbit
    assert [b.name for b in m.bodies] == ["yoke", "panel1", "panel2"]
    assert [evaluate(b.mass, p) for b in m.bodies] == [1.6, 5.2, 5.2]
    assert [evaluate(x, p) for x in m.bodies[1].principal] == [1.8417, 0.73261, 1.10961]
    assert [h.name for h in m.hinges] == ["root", "inner", "outer"]
    assert [[evaluate(x, p) for x in h.axis] for h in m.hinges] == \
        [[0, 0, -1], [0, 0, 1], [0, 0, -1]]
    assert [math.degrees(evaluate(h.latch, p)) for h in m.hinges] == \
        pytest.approx([90, 176, 179])
    assert [evaluate(h.friction, p) for h in m.hinges] == [0.2, 0.1, 0.1]
    assert [evaluate(c.stiffness, p) for c in m.cables] == pytest.approx([30.0, 30.0])


def test_reflector_arm_matches_models_md():
    m = load_model(EXAMPLES[0].with_name("reflector_arm.dep"))
    p = values(m)
    assert [(b.name, evaluate(b.mass, p)) for b in m.bodies] == [("boom", 1.6),
                                                               ("reflector", 8.5)]
    assert [evaluate(x, p) for x in m.bodies[1].principal] == [2.033, 1.068, 1.152]
    shoulder, elbow = m.hinges
    assert [evaluate(x, p) for x in shoulder.axis] == [0, -1, 0]
    assert [evaluate(x, p) for x in elbow.axis] == [-1, 0, 0]
    assert [evaluate(h.damping, p) for h in m.hinges] == [40, 25]
    assert [evaluate(h.latch_stiffness, p) for h in m.hinges] == [5000, 3000]
