"""The connectors and outputs of deployment analysis in the checked IR: particles, welds, free
joints, spring-dampers, hold-downs, loads and the system's quantities (docs/language.md)."""

from __future__ import annotations

import pytest

from depsim.dsl import ModelError, parse_model, summary
from depsim.dsl.ir import (JointKind, JointLoad, Member, MemberKind, Placement, PointCoord,
                           SpringActs, SystemQuantity)

GROUND = Member(MemberKind.GROUND, 0)
BAR = "bar rod { length = 1 m; mass = 1 kg; inertia = 0.1 kg*m^2 }\n"


def model(text: str):
    return parse_model("model m\n" + text, "t.dep")


def test_a_particle_is_a_member_with_one_point_and_no_angle():
    m = model(BAR + "particle bob { mass = 2 kg }\n"
              "hinge h joins ground.origin to rod.a\nweld w joins rod.b to bob.cm\n"
              "output x = bob.x\noutput y = bob.cm.vy\n")
    assert [p.name for p in m.particles] == ["bob"]
    assert m.welds[0].rotational is False  # a particle: the points only
    assert m.outputs[0].expr == PointCoord(Member(MemberKind.PARTICLE, 0), "cm", "x")
    assert m.placements[-1] == Placement(JointKind.WELD, 0, Member(MemberKind.BODY, 0),
                                         Member(MemberKind.PARTICLE, 0))


def test_a_hinge_at_a_particle_may_leave_out_the_particles_angle():
    m = model(BAR + "particle bob { mass = 2 kg }\nhinge h0 joins ground.origin to rod.a\n"
              "hinge h joins rod.b to bob.cm { angle = rod + 10 deg }\n")
    assert m.hinges[1].sign == -1


def test_every_rigid_member_has_its_centre_of_mass_as_point_cm():
    m = model(BAR + "hinge h joins ground.origin to rod.cm\noutput x = rod.cm.x\n")
    assert m.hinges[0].b.point == "cm"
    with pytest.raises(ModelError, match="duplicate point 'cm'"):
        model("body b { mass = 1 kg; inertia = 1 kg*m^2; point cm = (0, 0) m }\n")


def test_a_spring_reads_its_attributes_as_parameters_and_its_range():
    m = model(BAR + "hinge h joins ground.origin to rod.a\n"
              "spring k joins ground.origin to rod.b { stiffness = 10 N/m; free_length = 0.2 m"
              "; preload = 3 N; damping = 0.5 N*s/m; acts = push }\n")
    (spring,) = m.springs
    assert spring.acts is SpringActs.PUSH
    names = [p.name for p in m.params]
    assert ["k.stiffness", "k.free_length", "k.preload", "k.damping"] == names[-4:]


def test_springs_repeat_in_for_loops_with_their_own_parameters():
    m = model("for i in 1..3 {\n"
              "    bar link[i] { length = 1 m; mass = 1 kg; inertia = 0.1 kg*m^2 }\n"
              "    spring k[i] joins ground.origin to link[i].b { damping = 0.1 * i N*s/m }\n"
              "}\nhinge h joins ground.origin to link[1].a\n"
              "for i in 2..3 {\n    hinge g[i] joins link[i-1].b to link[i].a\n}\n")
    assert [s.name for s in m.springs] == ["k[1]", "k[2]", "k[3]"]
    assert [p.default for p in m.params if p.name.endswith(".damping")] == \
        pytest.approx([0.1, 0.2, 0.3])


def test_a_free_joint_takes_six_initial_values_as_parameters():
    m = model("body bus { mass = 100 kg; inertia = 10 kg*m^2 }\n"
              "free fly joins ground.origin to bus.cm\n"
              "initial { fly.x = 1 m; fly.y = 2 m; fly.angle = 30 deg; fly.vx = 0.1 m/s\n"
              "          fly.vy = 0.2 m/s; fly.omega = 1 deg/s }\n")
    (free,) = m.free_joints
    assert free.held == (3, 3, 3) and free.turns
    assert [p.name for p in m.params][-6:] == [
        "fly.initial_x", "fly.initial_y", "fly.initial_angle", "fly.initial_vx",
        "fly.initial_vy", "fly.initial_omega"]


def test_a_hinges_release_is_a_hold_down_parameter():
    m = model("param t_pyro = 3 s\n" + BAR + "hinge h joins ground.origin to rod.a { "
              "release = t_pyro }\n")
    assert m.hinges[0].release is not None
    assert "t_pyro" in [p.name for p in m.params]


def test_loads_and_system_quantities_in_outputs():
    m = model(BAR + "hinge h joins ground.origin to rod.a\n"
              "weld w joins rod.b to ground.origin\n"
              "output a = h.force_x\noutput b = w.torque\noutput c = system.momentum_y\n"
              "output d = angular_momentum(rod.b)\n")
    exprs = [o.expr for o in m.outputs]
    assert exprs[:3] == [JointLoad("hinge", 0, "force_x"), JointLoad("weld", 0, "torque"),
                         SystemQuantity("momentum_y")]
    assert exprs[3].quantity == "angular_momentum" and exprs[3].point.point == "b"
    assert [o.unit for o in m.outputs] == ["N", "N*m", "kg*m/s", "N*m*s"]


def test_the_floating_warning_is_given_once_per_tree_with_a_whole_hint():
    m = model(BAR + "bar other { length = 1 m; mass = 1 kg; inertia = 0.1 kg*m^2 }\n"
              "hinge h joins rod.b to other.a\n")
    (warning,) = m.warnings
    assert warning.code == "W001" and "with bar 'other'" in warning.message
    assert "free rod_motion joins ground.origin to rod.cm" in warning.hint
    assert warning.hint.endswith("in `initial`")


def test_the_summary_lists_the_new_elements():
    text = summary(model(BAR + "particle bob { mass = 1 kg }\n"
                         "hinge h joins ground.origin to rod.a\nweld w joins rod.b to bob.cm\n"
                         "spring k joins ground.origin to bob.cm { damping = 1 N*s/m }\n"))
    assert "particles (1)" in text and "welds (1)" in text and "springs (1)" in text
    assert "coordinates 5 (3 per rigid body, 2 per particle)" in text


@pytest.mark.parametrize("word", ["particle", "weld", "free", "spring"])
def test_the_new_statement_words_are_keywords(word):
    with pytest.raises(ModelError, match=f"'{word}' is a keyword"):
        model(f"param {word} = 1 m\n")
