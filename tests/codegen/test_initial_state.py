"""initial_state: the pose and velocities placed along the assembly tree reproduce the joints'
initial values and match hand-derived geometry; with the given values they close every loop,
and where joints are left free the core's assembly closes them (tests/runtime/test_assembly.py)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import sympy

import handmade
from fd_states import universal_axes_kept
from depsim.codegen import compile_numpy, load_generated
from depsim.codegen.expr import ConstantScope, to_sympy
from depsim.runtime import simulate
from depsim.runtime.interface import initial_state, outputs_at


def parameter_sets(module):
    defaults = np.array(module.PARAMETER_DEFAULTS, dtype=float)
    return [defaults, universal_axes_kept(module, defaults,
                                          defaults * np.linspace(0.93, 1.07, module.NP))]


def evaluate(expr, system, p) -> float:
    """An IR constant expression at parameter vector p (through sympy, independently of the
    generated code)."""
    value = to_sympy(expr, ConstantScope(system.p, system.t))
    return float(value.xreplace({s: sympy.Float(float(v)) for s, v in zip(system.p, p)}))


def start(m, p):
    """The run's initial state: the tree placement, assembled by the core where it leaves
    loops open (some tree joints free)."""
    result = simulate(m, p, t_end=1e-6, dt_out=1e-6)
    return result.q[0], result.qd[0]


def test_constraints_hold_at_the_initial_state(compiled):
    """At the model's own parameters: the placement itself when every tree joint is given
    (the loops close for consistent values), else the assembled state."""
    m = compiled.module
    p = np.array(m.PARAMETER_DEFAULTS, dtype=float)
    q0, qd0 = initial_state(m, p) if all(h & 1 for h in m.TREE_HELD) else start(m, p)
    jacobian = np.zeros((m.NC, m.NQ))
    jacobian[m.PHI_Q_ROWS, m.PHI_Q_COLS] = m.phi_q(q0, 0.0, p)
    np.testing.assert_allclose(m.phi(q0, 0.0, p), 0, atol=1e-12)
    np.testing.assert_allclose(jacobian @ qd0 + m.phi_t(q0, 0.0, p), 0, atol=1e-12)


def test_loops_stay_closed_for_other_geometry(compiled_cases):
    """The hand-built crank's initial angles are functions of r and l: any r, l close it."""
    m = compiled_cases("handmade:slider_crank_moving").module
    for scale in (0.8, 1.3):
        p = np.array(m.PARAMETER_DEFAULTS)
        p[0] *= scale
        q0, qd0 = initial_state(m, p)
        np.testing.assert_allclose(m.phi(q0, 0.0, p), 0, atol=1e-15)
        jacobian = np.zeros((m.NC, m.NQ))
        jacobian[m.PHI_Q_ROWS, m.PHI_Q_COLS] = m.phi_q(q0, 0.0, p)
        np.testing.assert_allclose(jacobian @ qd0, 0, atol=1e-14)


def test_hinges_start_at_their_initial_angles_and_rates(compiled):
    """Every hinge, loop-closing ones too, starts at its initial angle, and every placing hinge
    at its initial rate: for any parameters in a tree, at the defaults when there are loops."""
    m, model, system = compiled.module, compiled.model, compiled.system
    placing = {p.joint for p in model.placements if p.kind.value == "hinge"}
    for p in parameter_sets(m)[:1 if model.loop_joints else None]:
        q0, qd0 = initial_state(m, p) if all(h & 1 for h in m.TREE_HELD) else start(m, p)
        angles, rates = m.hinge_angles(q0, p), m.hinge_rates(q0, qd0, p)
        for index, hinge in enumerate(model.hinges):
            if model.loop_joints and not hinge.held & 1:
                continue  # free: the assembly solved it
            wrapped = angles[index] - evaluate(hinge.initial_angle, system, p)
            assert abs(math.remainder(wrapped, 2 * math.pi)) < 1e-12, hinge.name
            if index in placing and (hinge.held & 2 or not model.loop_joints):
                assert abs(rates[index] - evaluate(hinge.initial_rate, system, p)) < 1e-12


def test_pendulum_pose(compiled_cases):
    """examples/pendulum.dep: released at 60 deg from hanging, rod end a at the pivot."""
    m = compiled_cases("example:pendulum").module
    p = np.array(m.PARAMETER_DEFAULTS)
    p[m.PARAMETERS.index("L")] = 1.3
    q0, qd0 = initial_state(m, p)
    theta = math.radians(60)
    np.testing.assert_allclose(q0, [0.65 * math.sin(theta), -0.65 * math.cos(theta),
                                    theta - math.pi / 2], atol=1e-15)
    np.testing.assert_array_equal(qd0, 0)
    np.testing.assert_allclose(outputs_at(m, q0, qd0, 0.0, p),
                               [theta, 0, 1.3 * math.sin(theta), -1.3 * math.cos(theta)],
                               atol=1e-15)


def test_pendulum_written_child_first_moves(compiled_cases):
    """sign -1 with the ground as member b places the rod as the example does; the start rate
    is the parameter w0."""
    m = compiled_cases("handmade:pendulum_variant").module
    p = np.array([1.0, 2.0, 1.5])
    q0, qd0 = initial_state(m, p)
    theta = math.radians(60)
    np.testing.assert_allclose(q0, [0.5 * math.sin(theta), -0.5 * math.cos(theta),
                                    theta - math.pi / 2], atol=1e-15)
    np.testing.assert_allclose(m.hinge_rates(q0, qd0, p), [1.5], atol=1e-15)
    np.testing.assert_allclose(qd0, [0.75 * math.cos(theta), 0.75 * math.sin(theta), 1.5],
                               atol=1e-15)


def test_slider_crank_pose_and_stroke(compiled_cases):
    r, l = 0.1, 0.3
    stroke = math.sqrt(l**2 - r**2)
    for case in ("handmade:slider_crank", "handmade:slider_placed_crank"):
        m = compiled_cases(case).module
        p = np.array(m.PARAMETER_DEFAULTS)
        q0, qd0 = initial_state(m, p)
        crank, rod, piston = q0[0:3], q0[3:6], q0[6:9]
        np.testing.assert_allclose(crank, [0, r / 2, math.pi / 2], atol=1e-15)
        np.testing.assert_allclose(rod, [stroke / 2, r / 2, -math.asin(r / l)], atol=1e-15)
        np.testing.assert_allclose(piston, [stroke, 0, 0], atol=1e-15)
        np.testing.assert_allclose(outputs_at(m, q0, qd0, 0.0, p)[3], stroke, atol=1e-15)


def test_moving_slider_crank_velocities(compiled_cases):
    """Crank at 90 deg turning at w: the rod does not turn and the piston moves at -r w."""
    m = compiled_cases("handmade:slider_crank_moving").module
    p = np.array(m.PARAMETER_DEFAULTS)
    q0, qd0 = initial_state(m, p)
    np.testing.assert_allclose(m.hinge_rates(q0, qd0, p), [2.5, -2.5, 0], atol=1e-14)
    np.testing.assert_allclose(qd0[6:9], [-0.1 * 2.5, 0, 0], atol=1e-14)
    np.testing.assert_allclose(outputs_at(m, q0, qd0, 0.0, p)[4], -0.25, atol=1e-14)


def test_slider_angle_constant_is_exact(compiled_cases):
    """The slider keeps the assembled relative angle: here 0 exactly, so the row is phi_p."""
    system = compiled_cases("handmade:slider_crank").system
    row = system.constraint_names.index("guide.angle")
    assert system.phi[row] == system.q[8]  # the angle at the start is exactly 0


def test_floating_members_start_at_the_origin(tmp_path):
    """A tree with no path to the ground (the checker warns W001) is rooted at the origin."""
    model = handmade.cable_pair()
    hinges = (handmade.hinge("free", handmade.at(handmade.body(1), "a"),
                             handmade.at(handmade.body(0), "b"), math.pi / 2),)
    placements = (handmade.place(0, handmade.body(1), handmade.body(0)),)
    model = replace(model, hinges=hinges, cables=(), outputs=(), placements=placements)
    m = load_generated(compile_numpy(model, tmp_path))
    q0, qd0 = initial_state(m, np.array(m.PARAMETER_DEFAULTS))
    # panel at the origin along +x; the yoke turned +90 deg with its end b at panel end a
    np.testing.assert_allclose(q0[3:], [0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(q0[:3], [-1.965 / 2, -1.09 / 2, math.pi / 2], atol=1e-15)
    np.testing.assert_array_equal(qd0, 0)
    np.testing.assert_allclose(m.phi(q0, 0.0, np.array(m.PARAMETER_DEFAULTS)), 0, atol=1e-15)
