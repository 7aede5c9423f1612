"""IR models built by hand, for what the examples do not cover: a slider-crank assembled through
its hinges (loop closed for any r, l) or through its slider, non-zero initial rates, friction
and damping, a hinge written child-first, a cable loop, a time-dependent output, a floating
tree, and a damped beam placed from its end b (with tests/codegen/fake_beam.py)."""

from __future__ import annotations

import math
from dataclasses import replace

from depsim.dsl import ir

SPAN = ir.Span("handmade.dep", 1, 1, 1, 2)
GROUND = ir.Member(ir.MemberKind.GROUND, 0)
ZERO = ir.Num(0.0)


def body(index: int) -> ir.Member:
    return ir.Member(ir.MemberKind.BODY, index)


def beam(index: int) -> ir.Member:
    return ir.Member(ir.MemberKind.BEAM, index)


def param(name: str, default: float, unit: str = "1",
          kind: ir.ParamKind = ir.ParamKind.DECLARED) -> ir.Param:
    return ir.Param(name, default, ir.Dim(), unit, kind, SPAN)


def mul(*factors: ir.Expr) -> ir.Expr:
    result = factors[0]
    for factor in factors[1:]:
        result = ir.Binary("*", result, factor)
    return result


def div(left: ir.Expr, right: ir.Expr) -> ir.Expr:
    return ir.Binary("/", left, right)


def hinge(name: str, a: ir.Attachment, b: ir.Attachment, initial: float, **options) -> ir.Hinge:
    fields = dict(sign=1, offset=ZERO, stiffness=None, preload=None, friction=None,
                  static_friction=None, slip_rate=ir.Num(1e-3), damping=None, latch=None,
                  latch_stiffness=None, latch_damping=None, stop_min=None, stop_max=None,
                  initial_angle=ir.Num(initial), initial_rate=ZERO, span=SPAN)
    fields.update(options)
    return ir.Hinge(name, a, b, **fields)


def at(member: ir.Member, point: str) -> ir.Attachment:
    return ir.Attachment(member, point, SPAN)


def bar(name: str, length: ir.Expr, mass: ir.Expr, inertia: ir.Expr) -> ir.Body:
    return ir.Body(name, "bar", mass, inertia, length, (), SPAN)


def model(name: str, **fields) -> ir.Model:
    defaults = dict(
        description=name, source_file=f"examples/{name}.dep", source_sha256="0" * 64,
        params=(), derived=(), gravity=(ZERO, ZERO),
        ground=ir.Ground((ir.Point("origin", ZERO, ZERO, SPAN),)), bodies=(), beams=(),
        hinges=(), sliders=(), cables=(), outputs=(),
        simulation=ir.Simulation(1.0, 1e-9, 0.01), placements=(), loop_joints=(), warnings=(),
    )
    defaults.update(fields)
    return ir.Model(name=name, **defaults)


def output(name: str, expr: ir.Expr, unit: str = "1") -> ir.Output:
    return ir.Output(name, expr, ir.Dim(), unit, SPAN)


def place(joint: int, parent: ir.Member, child: ir.Member,
          kind: ir.JointKind = ir.JointKind.HINGE) -> ir.Placement:
    return ir.Placement(kind, joint, parent, child)


def pendulum() -> ir.Model:
    """examples/pendulum.dep: a bar of length L, mass m, hinged at end a to the ground."""
    length, mass = ir.ParamRef(0), ir.ParamRef(1)
    rod = bar("rod", length, mass, div(mul(mass, length, length), ir.Num(12)))
    pivot = hinge("pivot", at(GROUND, "origin"), at(body(0), "a"), math.pi / 3,
                  offset=ir.Num(math.pi / 2))
    return model(
        "pendulum", description="Rigid bar pendulum released at 60 degrees",
        params=(param("L", 1.0, "m"), param("m", 2.0, "kg")),
        gravity=(ZERO, ir.Num(-9.81)), bodies=(rod,), hinges=(pivot,),
        outputs=(output("theta", ir.HingeAngle(0), "rad"),
                 output("omega", ir.HingeAngle(0, rate=True), "rad/s"),
                 output("tip_x", ir.PointCoord(body(0), "b", "x"), "m"),
                 output("tip_y", ir.PointCoord(body(0), "b", "y"), "m")),
        simulation=ir.Simulation(10.0, 1e-9, 0.01),
        placements=(place(0, GROUND, body(0)),),
    )


def pendulum_variant() -> ir.Model:
    """The pendulum written child-first (`joins rod.a to ground.origin`, sign -1), with a
    moving start, friction, damping, a spring and a time-dependent output."""
    base = pendulum()
    pivot = replace(base.hinges[0], a=at(body(0), "a"), b=at(GROUND, "origin"), sign=-1,
                    initial_rate=ir.ParamRef(2), friction=ir.Num(0.3), damping=ir.Num(0.05),
                    stiffness=ir.Num(2.0), preload=ir.Num(0.5), slip_rate=ir.Num(0.1))
    outputs = base.outputs + (output("phase", ir.Binary("*", ir.Time(), ir.BodyCoord(0, "omega"))),)
    return replace(base, name="pendulum_variant", hinges=(pivot,), outputs=outputs,
                   params=base.params + (param("w0", 1.5, "rad/s"),))


def slider_crank(crank_rate: float = 0.0) -> ir.Model:
    """examples/slider_crank.dep. With crank_rate, the loop-consistent wrist rate is set too
    (at crank 90 deg the rod does not turn: wrist rate = -crank rate, gudgeon rate = 0)."""
    r, l = ir.ParamRef(0), ir.ParamRef(1)
    crank_mass, rod_mass = ir.ParamRef(2), ir.ParamRef(3)
    crank = bar("crank", r, crank_mass, div(mul(crank_mass, r, r), ir.Num(12)))
    rod = bar("rod", l, rod_mass, div(mul(rod_mass, l, l), ir.Num(12)))
    piston = ir.Body("piston", "body", ir.ParamRef(4), ir.ParamRef(5), None,
                     (ir.Point("pin", ZERO, ZERO, SPAN),), SPAN)
    asin = ir.Call("asin", (div(r, l),))
    hinges = (
        hinge("crank_pin", at(GROUND, "origin"), at(body(0), "a"), math.pi / 2,
              stiffness=ir.ParamRef(6), preload=ir.ParamRef(7), damping=ir.ParamRef(8),
              initial_rate=ir.Num(crank_rate)),
        replace(hinge("wrist", at(body(0), "b"), at(body(1), "a"), 0.0,
                      initial_rate=ir.Num(-crank_rate)),
                initial_angle=ir.Binary("-", ir.Num(-math.pi / 2), asin)),
        replace(hinge("gudgeon", at(body(1), "b"), at(body(2), "pin"), 0.0), initial_angle=asin),
    )
    guide = ir.Slider("guide", at(GROUND, "origin"), at(body(2), "pin"), (ir.Num(1), ZERO),
                      ZERO, ZERO, SPAN)
    attribute = ir.ParamKind.ATTRIBUTE
    params = (param("r", 0.1, "m"), param("l", 0.3, "m"),
              param("crank.mass", 0.5, "kg", attribute), param("rod.mass", 1.0, "kg", attribute),
              param("piston.mass", 2.0, "kg", attribute),
              param("piston.inertia", 0.01, "kg*m^2", attribute),
              param("crank_pin.stiffness", 2.0, "N*m/rad", attribute),
              param("crank_pin.preload", 5.0, "N*m", attribute),
              param("crank_pin.damping", 0.01, "N*m*s/rad", attribute))
    return model(
        "slider_crank", description="Slider-crank mechanism with a spring-driven crank",
        params=params, bodies=(crank, rod, piston), hinges=hinges, sliders=(guide,),
        outputs=(output("crank_angle", ir.HingeAngle(0), "rad"),
                 output("piston_x", ir.BodyCoord(2, "x"), "m"),
                 output("rod_angle", ir.BodyCoord(1, "phi"), "rad"),
                 output("stroke", ir.SliderPosition(0), "m"),
                 output("stroke_rate", ir.SliderPosition(0, rate=True), "m/s")),
        simulation=ir.Simulation(2.0, 1e-9, 0.005),
        placements=(place(0, GROUND, body(0)), place(1, body(0), body(1)),
                    place(2, body(1), body(2))),
        loop_joints=((ir.JointKind.SLIDER, 0),),
    )


def slider_placed_crank() -> ir.Model:
    """The slider-crank assembled through the slider (which places the piston at
    sqrt(l^2 - r^2)); the gudgeon hinge closes the loop."""
    base = slider_crank()
    r, l = ir.ParamRef(0), ir.ParamRef(1)
    stroke = ir.Call("sqrt", (ir.Binary("-", mul(l, l), mul(r, r)),))
    guide = replace(base.sliders[0], initial_position=stroke)
    return replace(base, name="slider_placed_crank", sliders=(guide,),
                   placements=base.placements[:2]
                   + (place(0, GROUND, body(2), ir.JointKind.SLIDER),),
                   loop_joints=((ir.JointKind.HINGE, 2),))


def cable_pair() -> ir.Model:
    """Two bars in a chain with springs and a cable loop 2*h1 - h2 (the intelsat5 pattern)."""
    bars = (bar("yoke", ir.Num(1.09), ir.Num(2.222), ir.Num(0.2798)),
            bar("panel", ir.Num(1.965), ir.Num(12.377), ir.Num(4.2009)))
    hinges = (
        hinge("h1", at(GROUND, "origin"), at(body(0), "a"), 0.2, stiffness=ir.Num(0.1273),
              preload=ir.Num(1.7), friction=ir.Num(0.68), initial_rate=ir.Num(0.3)),
        hinge("h2", at(body(0), "b"), at(body(1), "a"), 0.1, sign=-1, offset=ir.Num(math.pi),
              preload=ir.Num(0.85), initial_rate=ir.Num(-0.2)),
    )
    k = mul(ir.ParamRef(0), ir.Binary("^", ir.ParamRef(1), ir.Num(2)))
    cable = ir.Cable("loop1", k, (ir.CableTerm(0, ir.Num(2)), ir.CableTerm(1, ir.Num(-1))), SPAN)
    return model("cable_pair", params=(param("cable_k", 4500.0, "N/m"),
                                       param("pulley_r", 0.01835, "m")),
                 bodies=bars, hinges=hinges, cables=(cable,),
                 outputs=(output("theta1", ir.HingeAngle(0), "rad"),),
                 placements=(place(0, GROUND, body(0)), place(1, body(0), body(1))))


def beam_chain() -> ir.Model:
    """A rigid bar hanging from the ground, a damped beam hinged to its end b at the beam's end
    b (so the beam is placed backwards), in gravity. Needs the fake beam element."""
    link = ir.Beam("link", ir.Num(0.8), ir.Num(1000.0), ir.Num(5e7), ir.Num(5.0), 2,
                   ir.Num(1e-3), SPAN)
    hinges = (hinge("h1", at(GROUND, "origin"), at(body(0), "a"), 0.3, initial_rate=ir.Num(0.4)),
              hinge("h2", at(body(0), "b"), at(beam(0), "b"), 0.5, initial_rate=ir.Num(-0.7),
                    stiffness=ir.Num(3.0)))
    return model("beam_chain", gravity=(ZERO, ir.Num(-9.81)),
                 bodies=(bar("arm", ir.Num(0.5), ir.Num(1.0), ir.Num(0.02)),), beams=(link,),
                 hinges=hinges,
                 outputs=(output("chord", ir.BeamQuantity(0, "chord"), "rad"),
                          output("tip", ir.BeamQuantity(0, "tip_deflection"), "m"),
                          output("end_vy", ir.PointCoord(beam(0), "a", "vy"), "m/s")),
                 placements=(place(0, GROUND, body(0)), place(1, body(0), beam(0))))
