"""Syntax tree -> IR: parameters, units, members, joints, cables, initial values, outputs,
settings and the assembly order."""

from __future__ import annotations

import hashlib
import math

import pytest

from depsim.dsl import ModelError, evaluate, parse_model
from depsim.dsl.ir import (BeamQuantity, Binary, BodyCoord, Dim, HingeAngle, JointKind, Member,
                           MemberKind, Num, ParamKind, ParamRef, Placement, PointCoord,
                           SliderPosition, Time)

GROUND = Member(MemberKind.GROUND, 0)


def body(index: int) -> Member:
    return Member(MemberKind.BODY, index)


def bar(name: str, length: str = "1 m") -> str:
    return f"bar {name} {{ length = {length}; mass = 1 kg; inertia = 0.1 kg*m^2 }}\n"


def model(text: str):
    return parse_model("model m\n" + text, "t.dep")


def value(m, expr) -> float:
    return evaluate(expr, [p.default for p in m.params])


def param(m, name: str):
    (found,) = [p for p in m.params if p.name == name]
    return found


# --- parameters -------------------------------------------------------------------------------


def test_declared_params_come_first_then_attributes_in_file_order():
    m = model(bar("yoke") + "param k = 2 N*m/rad\n"
              "hinge h joins ground.origin to yoke.a { stiffness = k; friction = 1 N*m }\n"
              "param late = 1 s\n")
    assert [p.name for p in m.params] == [
        "k", "late", "yoke.length", "yoke.mass", "yoke.inertia", "h.friction", "h.slip_rate"]
    assert [p.kind for p in m.params[:2]] == [ParamKind.DECLARED] * 2
    assert {p.kind for p in m.params[2:]} == {ParamKind.ATTRIBUTE}


def test_param_defaults_are_si_with_dimension_and_unit_text():
    m = model("param k = 4500 * 0.01835^2 N*m/rad\nparam d = 30 mm\nparam n = 3\n"
              + bar("b") + "hinge h joins ground.origin to b.a { stiffness = k }\n"
              "output o = d * n\n")
    k = param(m, "k")
    assert k.default == pytest.approx(4500 * 0.01835**2)
    assert (k.dim, k.unit) == (Dim(mass=1, length=2, time=-2, angle=-1), "N*m/rad")
    assert param(m, "d").default == pytest.approx(0.03)
    assert param(m, "n").unit == "1"


def test_derived_param_is_inlined_and_recorded():
    m = model("param a = 2 m\nparam b = 3 * a\n" + bar("r", "b")
              + "hinge h joins ground.origin to r.a\n")
    assert [p.name for p in m.params][:1] == ["a"]
    assert "b" not in [p.name for p in m.params]
    derived = {d.name: d.depends_on for d in m.derived}
    assert derived == {"b": ("a",), "r.length": ("a",)}
    assert m.bodies[0].length == Binary("*", Num(3.0), ParamRef(0))
    assert value(m, m.bodies[0].length) == pytest.approx(6.0)


def test_attribute_written_with_params_is_derived_not_an_entry():
    m = parse_model(open_example("pendulum.dep"), "pendulum.dep")
    names = [p.name for p in m.params]
    assert "rod.inertia" not in names
    assert {d.name: d.depends_on for d in m.derived}["rod.inertia"] == ("L", "m")
    assert value(m, m.bodies[0].inertia) == pytest.approx(2 * 1 / 12)


def test_parameter_may_shadow_a_unit_name():
    m = model("param m = 2 kg\n" + "bar rod { length = 3 m; mass = m; inertia = m * (1 m)^2 }\n"
              "hinge h joins ground.origin to rod.a\n")
    assert value(m, m.bodies[0].mass) == 2.0
    assert value(m, m.bodies[0].length) == 3.0


@pytest.mark.parametrize("text, si", [
    ("90 deg", math.pi / 2), ("1 rev", 2 * math.pi), ("60 rpm", 2 * math.pi),
    ("1 km", 1000.0), ("5 cm", 0.05), ("2 min", 120.0), ("1 h", 3600.0), ("3 ms", 3e-3),
    ("2 kN", 2000.0), ("4 mN", 4e-3), ("1 GPa", 1e9), ("2 kPa", 2e3), ("3 MPa", 3e6),
    ("1 Hz", 1.0), ("2 J", 2.0), ("5 W", 5.0), ("2 N*m", 2.0), ("1 kg*m^2", 1.0),
    ("1 rad / 1 s", 1.0), ("2 m * 3 m", 6.0), ("pi / 2", math.pi / 2),
])
def test_units_convert_to_si(text, si):
    m = model(f"param x = {text}\noutput o = x\n")
    assert m.params[0].default == pytest.approx(si)


def test_unit_alone_in_an_expression_is_one_of_that_unit():
    m = model("param k = 4500 N/m\nparam r = 0.01835 m\n" + bar("b")
              + "hinge h joins ground.origin to b.a\n"
              "cable c { stiffness = k * r^2 / rad; angles = h }\n")
    assert value(m, m.cables[0].stiffness) == pytest.approx(4500 * 0.01835**2)


# --- members ----------------------------------------------------------------------------------


def test_bar_points_are_at_minus_and_plus_half_length():
    m = model(bar("yoke", "1.09 m") + "hinge h joins ground.origin to yoke.a\n")
    (yoke,) = m.bodies
    assert (yoke.kind, [p.name for p in yoke.points]) == ("bar", ["a", "b"])
    assert value(m, yoke.points[0].x) == pytest.approx(-0.545)
    assert value(m, yoke.points[1].x) == pytest.approx(0.545)
    assert yoke.points[1].y == Num(0.0)


def test_body_points_are_parameter_entries():
    m = model("body piston { mass = 2 kg; inertia = 0.01 kg*m^2; point pin = (10, -5) mm }\n"
              "slider s joins ground.origin to piston.pin { axis = (1, 0) }\n")
    (piston,) = m.bodies
    assert piston.kind == "body" and piston.length is None
    (pin,) = piston.points
    assert param(m, "piston.pin.local_x").default == pytest.approx(0.01)
    assert param(m, "piston.pin.local_y").default == pytest.approx(-0.005)
    assert value(m, pin.y) == pytest.approx(-0.005)


def test_ground_has_origin_and_declared_points():
    m = model("ground { point base = (1, 2) m }\n" + bar("b")
              + "hinge h joins ground.base to b.a\n")
    assert [p.name for p in m.ground.points] == ["origin", "base"]
    assert m.ground.points[0].x == Num(0.0)
    assert param(m, "ground.base.local_y").default == 2.0
    assert model(bar("b") + "hinge h joins ground.origin to b.a\n").ground.points[0].name \
        == "origin"


def test_beam():
    m = model("beam link { length = 1 m; EI = 1000 N*m^2; EA = 5e7 N; mass_per_length = 5 kg/m;"
              " elements = 3; damping = 0.001 s }\nhinge h joins ground.origin to link.a\n")
    (beam,) = m.beams
    assert beam.elements == 3 and isinstance(beam.elements, int)
    assert value(m, beam.EI) == 1000.0 and value(m, beam.damping) == 0.001
    assert m.hinges[0].b.member == Member(MemberKind.BEAM, 0)
    assert model("beam l { length = 1 m; EI = 1 N*m^2; EA = 1 N; mass_per_length = 1 kg/m; "
                 "elements = 1 }\n").beams[0].damping is None


def test_bodies_and_beams_are_indexed_separately():
    m = model(bar("a") + "beam l { length = 1 m; EI = 1 N*m^2; EA = 1 N; mass_per_length = "
              "1 kg/m; elements = 1 }\n" + bar("b") + "hinge h1 joins ground.origin to a.a\n"
              "hinge h2 joins a.b to l.a\nhinge h3 joins l.b to b.a\n")
    assert [h.b.member for h in m.hinges] == [body(0), Member(MemberKind.BEAM, 0), body(1)]


def test_gravity():
    m = model("gravity = (0, -9.81) m/s^2\n")
    assert [p.name for p in m.params] == ["gravity.x", "gravity.y"]
    assert value(m, m.gravity[1]) == pytest.approx(-9.81)
    assert model("").gravity == (Num(0.0), Num(0.0))
    assert value(model("gravity = (1 m/s^2, 2 m/s^2)\n"), ParamRef(1)) == 2.0


# --- hinges -----------------------------------------------------------------------------------


def hinge_with(angle: str):
    m = model(bar("a1") + bar("a2") + "hinge h0 joins ground.origin to a1.a\n"
              f"hinge h joins a1.b to a2.a {{ angle = {angle} }}\n")
    h = m.hinges[1]
    return h.sign, value(m, h.offset)


@pytest.mark.parametrize("angle, sign, offset", [
    ("a2 - a1", 1, 0.0),
    ("a2 - a1 + 180 deg", 1, math.pi),
    ("-(a2 - a1) + 180 deg", -1, math.pi),
    ("a1 - a2", -1, 0.0),
    ("-(a2 - a1 + 90 deg)", -1, -math.pi / 2),
    ("a2 + pi - a1", 1, math.pi),
    ("+a2 - a1 - 0.5", 1, -0.5),
    ("a2 - a1 + a1 - a1", 1, 0.0),
])
def test_hinge_angle_sign_and_offset(angle, sign, offset):
    assert hinge_with(angle) == (sign, pytest.approx(offset))


@pytest.mark.parametrize("angle, sign", [
    ("yoke - ground", 1), ("yoke", 1), ("-(yoke - ground)", -1), ("ground - yoke", -1),
    ("-yoke + 90 deg", -1),
])
def test_hinge_angle_with_the_ground_term_optional(angle, sign):
    m = model(bar("yoke") + f"hinge h joins ground.origin to yoke.a {{ angle = {angle} }}\n")
    assert m.hinges[0].sign == sign


def test_hinge_to_the_ground_second():
    m = model(bar("yoke") + "hinge h joins yoke.a to ground.origin { angle = -yoke }\n")
    assert m.hinges[0].sign == 1  # theta = sign * (0 - yoke)


def test_hinge_offset_entry_only_when_written():
    m = parse_model(open_example("intelsat5.dep"), "intelsat5.dep")
    names = [p.name for p in m.params]
    assert "h1.offset" not in names and m.hinges[0].offset == Num(0.0)
    assert param(m, "h2.offset").default == pytest.approx(math.pi)
    assert m.hinges[2].sign == -1


def test_hinge_attributes_and_defaults():
    m = model(bar("yoke") + "hinge h joins ground.origin to yoke.a {\n"
              "stiffness = 0.1273 N*m/rad; preload = 1.7 N*m; friction = 0.68 N*m\n"
              "static_friction = 0.8 N*m; damping = 0.01 N*m*s/rad; latch = 90 deg\n"
              "latch_stiffness = 1e4 N*m/rad; latch_damping = 5 N*m*s/rad\n"
              "stop_min = -10 deg; stop_max = pi }\n")
    h = m.hinges[0]
    assert value(m, h.latch) == pytest.approx(math.pi / 2)
    assert value(m, h.stop_min) == pytest.approx(-math.pi / 18)
    assert value(m, h.stop_max) == pytest.approx(math.pi)
    assert value(m, h.slip_rate) == pytest.approx(1e-3)
    assert param(m, "h.slip_rate").unit == "rad/s"
    assert value(m, h.latch_damping) == 5.0
    assert (h.a.member, h.a.point, h.b.member, h.b.point) == (GROUND, "origin", body(0), "a")
    bare = model(bar("yoke") + "hinge h joins ground.origin to yoke.a\n").hinges[0]
    assert (bare.sign, bare.offset, bare.stiffness, bare.latch) == (1, Num(0.0), None, None)
    assert bare.initial_angle == Num(0.0) and bare.initial_rate == Num(0.0)


def test_plain_number_is_an_angle_in_radians():
    m = model(bar("yoke") + "hinge h joins ground.origin to yoke.a { latch = pi / 2 }\n")
    assert value(m, m.hinges[0].latch) == pytest.approx(math.pi / 2)
    assert param(m, "h.latch").unit == "rad"


# --- sliders, cables, initial values ---------------------------------------------------------


def test_slider_axis_and_initial_values():
    m = model("body p { mass = 1 kg; inertia = 1 kg*m^2; point c = (0, 0) m }\n"
              "slider s joins ground.origin to p.c { axis = (0, 2) }\n"
              "initial { s = 20 cm; s.rate = 1 m/s }\n")
    (s,) = m.sliders
    assert [value(m, c) for c in s.axis] == [0.0, 2.0]
    assert value(m, s.initial_position) == pytest.approx(0.2)
    assert value(m, s.initial_rate) == 1.0
    assert [p.name for p in m.params][-2:] == ["s.initial_position", "s.initial_rate"]


def test_cable_terms():
    m = model(bar("a") + bar("b") + bar("c") + "hinge h1 joins ground.origin to a.a\n"
              "hinge h2 joins a.b to b.a\nhinge h3 joins b.b to c.a\nparam n = 3\n"
              "cable loop { stiffness = 2 N*m/rad; angles = 2*h1 - h2 + h3/2 - h1 + n*h3 }\n")
    (cable,) = m.cables
    terms = {t.hinge: value(m, t.coefficient) for t in cable.terms}
    assert terms == {0: 1.0, 1: -1.0, 2: pytest.approx(3.5)}
    assert param(m, "loop.stiffness").default == 2.0


def test_initial_values_and_entries():
    m = parse_model(open_example("pendulum.dep"), "pendulum.dep")
    (h,) = m.hinges
    assert value(m, h.initial_angle) == pytest.approx(math.pi / 3)
    assert param(m, "pivot.initial_angle").unit == "rad"
    assert param(m, "pivot.initial_rate").unit == "rad/s"


def test_initial_blocks_merge():
    m = model(bar("a") + "hinge h joins ground.origin to a.a\n"
              "initial { h = 10 deg }\ninitial { h.rate = 1 rad/s }\n")
    assert value(m, m.hinges[0].initial_rate) == 1.0


# --- simulation, outputs ---------------------------------------------------------------------


def test_simulation_settings_and_defaults():
    m = model("simulate { t_end = 2 min; dt_out = 50 ms }\n")
    assert (m.simulation.t_end, m.simulation.tol, m.simulation.dt_out) == \
        (120.0, 1e-8, pytest.approx(0.05))
    assert model("").simulation.t_end == 10.0 and model("").simulation.dt_out == 0.01
    assert isinstance(m.simulation.t_end, float)


def test_outputs_of_every_kind():
    m = model(bar("rod") + "beam l { length = 1 m; EI = 1 N*m^2; EA = 1 N; mass_per_length = "
              "1 kg/m; elements = 1 }\n"
              "body p { mass = 1 kg; inertia = 1 kg*m^2; point c = (0, 0) m }\n"
              "hinge h joins ground.origin to rod.a\nhinge h2 joins rod.b to l.a\n"
              "slider s joins ground.origin to p.c { axis = (1, 0) }\n"
              "output a = h\noutput b = h.rate\noutput c = s\noutput d = s.rate\n"
              "output e = rod.omega\noutput f = rod.b.vx\noutput g = l.tip_deflection\n"
              "output i = l.chord + 90 deg\noutput j = t\noutput k = l.b.y\n"
              "output q = ground.origin.x\noutput r = h / deg\n")
    exprs = {o.name: o.expr for o in m.outputs}
    units = {o.name: o.unit for o in m.outputs}
    assert exprs["a"] == HingeAngle(0) and exprs["b"] == HingeAngle(0, True)
    assert exprs["c"] == SliderPosition(0) and exprs["d"] == SliderPosition(0, True)
    assert exprs["e"] == BodyCoord(0, "omega")
    assert exprs["f"] == PointCoord(body(0), "b", "vx")
    assert exprs["g"] == BeamQuantity(0, "tip_deflection")
    assert exprs["i"] == Binary("+", BeamQuantity(0, "chord"), Num(math.pi / 2))
    assert exprs["j"] == Time()
    assert exprs["k"] == PointCoord(Member(MemberKind.BEAM, 0), "b", "y")
    assert exprs["q"] == PointCoord(GROUND, "origin", "x")
    assert units == {"a": "rad", "b": "rad/s", "c": "m", "d": "m/s", "e": "rad/s", "f": "m/s",
                     "g": "m", "i": "rad", "j": "s", "k": "m", "q": "m", "r": "1"}


# --- assembly ---------------------------------------------------------------------------------


def test_placements_breadth_first_hinges_before_sliders_and_loops():
    m = parse_model(open_example("slider_crank.dep"), "slider_crank.dep")
    assert m.placements == (
        Placement(JointKind.HINGE, 0, GROUND, body(0)),
        Placement(JointKind.SLIDER, 0, GROUND, body(2)),
        Placement(JointKind.HINGE, 1, body(0), body(1)))
    assert m.loop_joints == ((JointKind.HINGE, 2),)


def test_floating_members_form_their_own_tree_with_one_warning():
    m = model(bar("a") + bar("loose") + bar("rider") + "hinge h1 joins ground.origin to a.a\n"
              "hinge h2 joins loose.b to rider.a\n")
    assert m.placements[-1] == Placement(JointKind.HINGE, 1, body(1), body(2))
    assert [(w.code, w.span.line) for w in m.warnings] == [("W001", 3)]
    assert "with bar 'rider', from the origin, at rest" in m.warnings[0].message
    assert m.warnings[0].hint.endswith("in `initial`")


def test_a_free_joint_places_a_floating_member_and_silences_the_warning():
    m = model(bar("loose") + bar("rider") + "hinge h2 joins loose.b to rider.a\n"
              "free fly joins ground.origin to loose.cm\n"
              "initial { fly.x = 2 m; fly.angle = 30 deg; fly.omega = 0.5 rad/s }\n")
    assert not m.warnings
    assert m.placements[0] == Placement(JointKind.FREE, 0, Member(MemberKind.GROUND, 0),
                                        body(0))
    assert m.free_joints[0].held == (1, 0, 3)
    names = [p.name for p in m.params]
    assert {"fly.initial_x", "fly.initial_angle", "fly.initial_omega"} <= set(names)


def test_model_identity():
    text = 'model pend "A pendulum"\n'
    m = parse_model(text, "dir/pend.dep")
    assert (m.name, m.description, m.source_file) == ("pend", "A pendulum", "dir/pend.dep")
    assert m.source_sha256 == hashlib.sha256(text.encode()).hexdigest()


def test_no_model_on_error():
    with pytest.raises(ModelError):
        model("param x = y\n")


def open_example(name: str) -> str:
    from pathlib import Path

    return (Path(__file__).parents[2] / "examples" / name).read_text(encoding="utf-8")
