"""Energies, dissipation and the generalized applied force.

Potentials (hinge springs, cable loops, gravity, beam elasticity) give f = -dV/dq exactly, so
a free conservative model conserves energy. Hinge damping is a torque tau on the hinge angle
theta, mapped to the generalized force Q = (d theta/dq)^T tau; so is an input torque, and an
input force F at a point r(q) gives Q = (dr/dq)^T F. Hinge Coulomb friction is not
here: its torque depends on the hinge's mode (sliding, stuck, locked by a latch or stop), so
the integrator applies it from hinge_properties (docs/deployment.md)."""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from depsim.dsl import ir

from .kinematics import Kinematics


@dataclass(frozen=True)
class Loads:
    """Named energy terms (J), dissipated powers (W) and the applied force f (NQ)."""

    energy_names: tuple[str, ...]
    energies: tuple[sympy.Expr, ...]
    dissipator_names: tuple[str, ...]
    dissipation: tuple[sympy.Expr, ...]
    force: tuple[sympy.Expr, ...]
    stiffness: Stiffness


@dataclass(frozen=True)
class Stiffness:
    """The stiff forces' Jacobian, for the linearly implicit step of a model with beams:
    K ~ -df/dq and D ~ -df/dqd on one structural pattern (row-major), each a sum of symmetric
    positive semi-definite terms (docs/method.md, 10). Empty for a model without beams."""

    pattern: tuple[tuple[int, int], ...]
    K: tuple[sympy.Expr, ...]
    D: tuple[sympy.Expr, ...]


def implicit_stiffness(model: ir.Model, kin: Kinematics, jacobian: sympy.Matrix) -> Stiffness:
    """Each beam's J^T K J (BeamSymbolic.stiffness) placed at its coordinates and beta times
    it for a damped beam (its damping force is exactly -beta J^T K J qd); each hinge spring
    and damper k g g^T, c g g^T with g = d theta / dq; each cable k g g^T with g the gradient
    of its stretch. These leave out the terms in the deformation, angle or stretch itself
    (the strain-weighted curvature), so each is positive semi-definite in every pose."""
    if not model.beams:
        return Stiffness((), (), ())
    K: dict[tuple[int, int], list[sympy.Expr]] = {}
    D: dict[tuple[int, int], list[sympy.Expr]] = {}
    for element, symbols in zip(kin.beams, kin.symbols.beam_q):
        if not symbols or not hasattr(element, "stiffness"):
            continue
        start = kin.symbols.q.index(symbols[0])
        for (a, b), value in element.stiffness().items():
            K.setdefault((start + a, start + b), []).append(value)
            if element.damping is not None:
                D.setdefault((start + a, start + b), []).append(element.damping * value)

    def outer(target: dict, coefficient: sympy.Expr, gradient: list[sympy.Expr]) -> None:
        present = [(j, g) for j, g in enumerate(gradient) if g != 0]
        for i, gi in present:
            for j, gj in present:
                target.setdefault((i, j), []).append(coefficient * gi * gj)

    for index, hinge in enumerate(model.hinges):
        gradient = list(jacobian[index, :])
        if hinge.stiffness is not None:
            outer(K, kin.const(hinge.stiffness), gradient)
        if hinge.damping is not None:
            outer(D, kin.const(hinge.damping), gradient)
    for cable in model.cables:
        gradient = [sympy.Add(*(kin.const(term.coefficient) * jacobian[term.hinge, j]
                                for term in cable.terms)) for j in range(jacobian.cols)]
        outer(K, kin.const(cable.stiffness), gradient)
    pattern = tuple(sorted(set(K) | set(D)))
    zero = sympy.Integer(0)
    return Stiffness(pattern, tuple(sympy.Add(*K.get(place, [zero])) for place in pattern),
                     tuple(sympy.Add(*D.get(place, [zero])) for place in pattern))


def derive_loads(model: ir.Model, kin: Kinematics, mass_matrix: sympy.Matrix,
                 thetas: list[sympy.Expr], jacobian: sympy.Matrix) -> Loads:
    """Energies, dissipators and f for a model whose hinge angles and d theta/dq are given."""
    qd = kin.symbols.qd
    kinetic = sympy.Add(*(mass_matrix[i, j] * qd[i] * qd[j] / 2
                          for i, j in _nonzero(mass_matrix)))
    potentials = _potentials(model, kin, thetas)
    force = _potential_force(kin, potentials)
    dissipators = _hinge_dissipators(model, kin, jacobian) + _beam_dissipators(model, kin) \
        + _input_loads(model, kin, jacobian)
    for _, generalized, _power in dissipators:
        force = [f + g for f, g in zip(force, generalized)]
    return Loads(
        energy_names=("kinetic",) + tuple(name for name, _ in potentials),
        energies=(kinetic,) + tuple(energy for _, energy in potentials),
        dissipator_names=tuple(name for name, _, _ in dissipators),
        dissipation=tuple(power for _, _, power in dissipators),
        force=tuple(force),
        stiffness=implicit_stiffness(model, kin, jacobian),
    )


def _potential_force(kin: Kinematics, potentials: list[tuple[str, sympy.Expr]]) -> list:
    """-dV/dq of all potentials; beam elasticity uses the element's own exact gradient."""
    beam_forces = {f"elastic.{beam.name}": (element, symbols) for beam, element, symbols
                   in zip(kin.model.beams, kin.beams, kin.symbols.beam_q)
                   if hasattr(element, "elastic_force")}
    total = sympy.Add(*(energy for name, energy in potentials if name not in beam_forces))
    force = {s: -total.diff(s) for s in kin.symbols.q}
    for element, symbols in beam_forces.values():
        for s, value in zip(symbols, element.elastic_force()):
            force[s] += value
    return [force[s] for s in kin.symbols.q]


def _nonzero(matrix: sympy.Matrix) -> list[tuple[int, int]]:
    return [(i, j) for i in range(matrix.rows) for j in range(matrix.cols) if matrix[i, j] != 0]


def _potentials(model: ir.Model, kin: Kinematics,
                thetas: list[sympy.Expr]) -> list[tuple[str, sympy.Expr]]:
    """(name, V) of each potential, in the order of the ENERGIES contract."""
    terms = []
    for hinge, theta in zip(model.hinges, thetas):
        if hinge.stiffness is None and hinge.preload is None:
            continue
        energy = sympy.Integer(0)
        if hinge.preload is not None:
            energy -= kin.const(hinge.preload) * theta
        if hinge.stiffness is not None:
            energy += kin.const(hinge.stiffness) * theta**2 / 2
        terms.append((f"spring.{hinge.name}", energy))
    for cable in model.cables:
        stretch = sympy.Add(*(kin.const(term.coefficient) * thetas[term.hinge]
                              for term in cable.terms))
        terms.append((f"cable.{cable.name}", kin.const(cable.stiffness) * stretch**2 / 2))
    if not all(isinstance(g, ir.Num) and g.value == 0 for g in model.gravity):
        terms.append(("gravity", _gravity(model, kin)))
    for beam, element in zip(model.beams, kin.beams):
        terms.append((f"elastic.{beam.name}", element.elastic_energy))
    return terms


def _gravity(model: ir.Model, kin: Kinematics) -> sympy.Expr:
    """V = -sum m g . r over rigid bodies, plus each beam's integral over its mass."""
    gx, gy = (kin.const(g) for g in model.gravity)
    energy = sympy.Integer(0)
    for index, body in enumerate(model.bodies):
        x, y, _ = kin.body_symbols(index)
        energy -= kin.const(body.mass) * (gx * x + gy * y)
    for element in kin.beams:
        energy += element.gravity_energy(gx, gy)
    return energy


Dissipator = tuple[str, list[sympy.Expr], sympy.Expr]  # name, generalized force, power removed


def _hinge_dissipators(model: ir.Model, kin: Kinematics,
                       jacobian: sympy.Matrix) -> list[Dissipator]:
    """Viscous damping torques on hinge angles."""
    qd = sympy.Matrix(kin.symbols.qd)
    found = []
    for index, hinge in enumerate(model.hinges):
        row = jacobian[index, :]
        rate = (row * qd)[0, 0]
        if hinge.damping is not None:
            damping = kin.const(hinge.damping)
            found.append((f"damping.{hinge.name}", list(-damping * rate * row),
                          damping * rate**2))
    return found


def _beam_dissipators(model: ir.Model, kin: Kinematics) -> list[Dissipator]:
    """Each damped beam's element damping force (when the element provides one)."""
    found = []
    for beam, element, symbols in zip(model.beams, kin.beams, kin.symbols.beam_q):
        if beam.damping is None or not symbols or not hasattr(element, "damping_force"):
            continue
        start = kin.symbols.q.index(symbols[0])
        rates = kin.symbols.qd[start:start + len(symbols)]
        local = list(element.damping_force(rates))
        generalized = [sympy.Integer(0)] * len(kin.symbols.q)
        generalized[start:start + len(symbols)] = local
        power = element.damping_power(rates) if hasattr(element, "damping_power") \
            else -sympy.Add(*(r * f for r, f in zip(rates, local)))
        found.append((f"damping.{beam.name}", generalized, power))
    return found


def _input_loads(model: ir.Model, kin: Kinematics, jacobian: sympy.Matrix) -> list[Dissipator]:
    """Each input's generalized force and the power it removes (negative while it drives):
    u(t) = p[slot] + p[slot + 1] t per component (ir.Input)."""
    p, t, q = kin.symbols.p, kin.symbols.t, kin.symbols.q
    qd = sympy.Matrix(kin.symbols.qd)
    found = []
    for put in model.inputs:
        values = [p[slot] + p[slot + 1] * t for slot in put.slots]
        if put.kind is ir.InputKind.TORQUE:
            rows = [jacobian[put.hinge, :]]
        else:
            position = kin.point_position(put.point.member, put.point.point)
            rows = [sympy.Matrix([[coordinate.diff(s) for s in q]]) for coordinate in position]
        generalized = [sympy.Integer(0)] * len(q)
        power = sympy.Integer(0)
        for value, row in zip(values, rows):
            generalized = [g + value * r for g, r in zip(generalized, row)]
            power -= value * (row * qd)[0, 0]
        found.append((f"input.{put.name}", generalized, power))
    return found
