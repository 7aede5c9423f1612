"""What a slider's toolkit (docs/language.md, slider) generates: the sliders the integrator
treats as hinge entries and how the generated tables and the FMU name them."""

import math

import numpy as np

from depsim.codegen.derive import derive
from depsim.codegen.fmu import fmu_sources
from depsim.dsl import parse_model
from depsim.dsl.attributes import HINGE_PROPERTIES

RAIL = """model rail
body block {{ mass = 2 kg; inertia = 0.1 kg*m^2 }}
body cart {{ mass = 1 kg; inertia = 0.1 kg*m^2 }}
hinge pin joins ground.origin to block.cm
slider sprung joins ground.origin to cart.cm {{
    axis = (0.6, 0.8)
    {sprung}
}}
slider latched joins block.cm to cart.cm {{
    axis = (1, 0)
    {latched}
}}
initial {{ sprung = 0.5 m }}
"""


def test_only_sliders_with_what_the_core_applies_are_hinge_entries():
    """A spring and a damper are forces of the model; friction, latches, stops and hold-downs
    make the slider an entry of the hinge tables, after the hinges, with its properties."""
    system = derive(parse_model(RAIL.format(
        sprung="stiffness = 10 N/m\n damping = 1 N*s/m",
        latched="friction = 2 N\n latch = 0.4 m"), "rail.dep"))
    assert system.hinge_names == ("pin", "latched")
    assert system.run_value_names[:2] == ("pin.torque", "latched.force")
    assert {"spring.sprung"} <= set(system.energy_names)
    assert system.dissipator_names == ("damping.sprung",)
    values = system.hinge_properties.subs(dict(zip(system.p, [1.0] * len(system.p))))
    given = [{name for k, name in enumerate(HINGE_PROPERTIES) if not math.isnan(row[k])}
             for row in values.tolist()]
    assert given == [{"slip_rate"}, {"latch", "friction", "slip_rate"}]


def test_sliders_without_toolkit_change_nothing():
    plain = derive(parse_model(RAIL.format(sprung="", latched=""), "rail.dep"))
    assert plain.hinge_names == ("pin",) and plain.energy_names == ("kinetic",)
    assert plain.run_value_names[0] == "pin.torque" and plain.dissipator_names == ()


def test_a_slider_entry_measures_its_displacement():
    """Its row of hinge_angles is s = axis_a . (r_b - r_a), of hinge_jacobian ds/dq, of
    hinge_gamma -(J qd)_q qd (block turning: the axis turns with it)."""
    system = derive(parse_model(RAIL.format(sprung="", latched="stop_max = 1 m"), "rail.dep"))
    assert system.hinge_names == ("pin", "latched")
    rng = np.random.default_rng(3)
    q = rng.normal(size=len(system.q))
    qd = rng.normal(size=len(system.q))
    values = {**dict(zip(system.q, q)), **dict(zip(system.qd, qd))}
    values.update({p: 1.0 if p.name.endswith(("axis_x", "mass", "inertia")) else 0.0
                   for p in system.p})
    bx, by, bphi, cx, cy, _ = q
    axis = np.array([math.cos(bphi), math.sin(bphi)])
    assert abs(float(system.hinge_angles[1].subs(values)) - axis @ [cx - bx, cy - by]) < 1e-12
    # s'' along the motion = J qdd - gamma_h: with qdd = 0, d^2 s / dt^2 = -gamma_h
    dbx, dby, dphi, dcx, dcy, _ = qd
    d = np.array([cx - bx, cy - by])
    dd = np.array([dcx - dbx, dcy - dby])
    normal = np.array([-math.sin(bphi), math.cos(bphi)])
    second = -dphi ** 2 * axis @ d + 2 * dphi * normal @ dd
    assert abs(-float(system.hinge_gamma[1].subs(values)) - second) < 1e-12


def test_the_fmu_names_a_slider_entry_in_linear_units():
    model = parse_model(RAIL.format(sprung="", latched="latch = 0.4 m"), "rail.dep")
    view, _ = fmu_sources(model)
    units = {var.name: var.unit for var in view.variables}
    assert units["latched.position"] == "m" and units["latched.rate"] == "m/s"
    assert units["latched.force"] == "N" and "latched.latched" in units
    assert "latched.torque" not in units and "latched.angle" not in units
    assert units["pin.angle"] == "rad"
