"""Energies, dissipation and the generalized applied force.

Potentials (hinge and slider springs, cable loops, gravity, beam elasticity) give f = -dV/dq
exactly, so a free conservative model conserves energy. Hinge damping is a torque tau on the
hinge angle theta, mapped to the generalized force Q = (d theta/dq)^T tau, and a slider's a
force F on its displacement s, Q = (ds/dq)^T F; so is an input torque, and an input force F at
a point r(q) gives Q = (dr/dq)^T F. A point-to-point spring-damper's force F along its line
gives Q = F dL/dq (`spring_law`, its one definition). Coulomb friction (a hinge's or a
slider's) is not here: its torque depends on the joint's mode (sliding, stuck, locked by a
latch or stop), so the integrator applies it from hinge_properties (docs/deployment.md)."""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from depsim.dsl import ir

from .kinematics import Kinematics
from .spatial import spatial_gravity


@dataclass(frozen=True)
class Loads:
    """Named energy terms (J), dissipated powers (W) and the applied force f (NQ)."""

    energy_names: tuple[str, ...]
    energies: tuple[sympy.Expr, ...]
    dissipator_names: tuple[str, ...]
    dissipation: tuple[sympy.Expr, ...]
    force: tuple[sympy.Expr, ...]
    stiffness: Stiffness
    springs: tuple = ()  # SpringLaw of each point-to-point spring


@dataclass(frozen=True)
class Stiffness:
    """The stiff forces' Jacobian, for the linearly implicit step of a model with beams:
    K ~ -df/dq and D ~ -df/dqd on one structural pattern (row-major), each a sum of symmetric
    positive semi-definite terms (docs/method.md, 10). Empty for a model without beams."""

    pattern: tuple[tuple[int, int], ...]
    K: tuple[sympy.Expr, ...]
    D: tuple[sympy.Expr, ...]


def sparse_rows(matrix: sympy.SparseMatrix) -> list[dict[int, sympy.Expr]]:
    """Each row's non-zeros, column -> value, columns ascending."""
    rows: list[dict[int, sympy.Expr]] = [{} for _ in range(matrix.rows)]
    for (i, j), value in sorted(matrix.todok().items()):
        rows[i][j] = value
    return rows


def implicit_stiffness(model: ir.Model, kin: Kinematics, jacobian: sympy.SparseMatrix,
                       springs=()) -> Stiffness:
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

    def outer(target: dict, coefficient: sympy.Expr, gradient: dict[int, sympy.Expr]) -> None:
        present = sorted((j, g) for j, g in gradient.items() if g != 0)
        for i, gi in present:
            for j, gj in present:
                target.setdefault((i, j), []).append(coefficient * gi * gj)

    rows = sparse_rows(jacobian)
    for index, hinge in enumerate(model.hinges):
        if hinge.stiffness is not None:
            outer(K, kin.const(hinge.stiffness), rows[index])
        if hinge.damping is not None:
            outer(D, kin.const(hinge.damping), rows[index])
    for index, slider in enumerate(model.sliders):  # k g g^T, c g g^T, g = ds/dq
        if slider.stiffness is not None or slider.damping is not None:
            gradient_s = slider_gradient(kin, index)
            if slider.stiffness is not None:
                outer(K, kin.const(slider.stiffness), gradient_s)
            if slider.damping is not None:
                outer(D, kin.const(slider.damping), gradient_s)
    for cable in model.cables:
        gradient: dict[int, list[sympy.Expr]] = {}
        for term in cable.terms:
            for j, value in rows[term.hinge].items():
                gradient.setdefault(j, []).append(kin.const(term.coefficient) * value)
        outer(K, kin.const(cable.stiffness), {j: sympy.Add(*v) for j, v in gradient.items()})
    for spring, law in zip(model.springs, springs):  # k g g^T, c g g^T, g = dL/dq
        if spring.stiffness is not None:
            outer(K, kin.const(spring.stiffness), law.gradient)
        if spring.damping is not None:
            outer(D, kin.const(spring.damping), law.gradient)
    pattern = tuple(sorted(set(K) | set(D)))
    zero = sympy.Integer(0)
    return Stiffness(pattern, tuple(sympy.Add(*K.get(place, [zero])) for place in pattern),
                     tuple(sympy.Add(*D.get(place, [zero])) for place in pattern))


@dataclass(frozen=True)
class SpringLaw:
    """A point-to-point spring-damper at the state (ir.Spring): its length L (m) and rate
    dL/dt (m/s), its force along the line (N, positive pushing the points apart), its
    gradient dL/dq (coordinate index -> entry), its potential (J) and the power it removes
    (W, >= 0).

        F_both = preload - stiffness (L - free_length) - damping dL/dt
        acts both: F = F_both;  push: F = max(F_both, 0) while L < free_length, else 0;
        pull: F = min(F_both, 0) while L > free_length, else 0
        V = stiffness (L - free_length)^2 / 2 - preload (L - free_length) where it acts
        removed = (F_elastic - F) dL/dt, F_elastic the part without damping where it acts

    so that d(T + V)/dt + removed = 0 for the spring alone."""

    length: sympy.Expr
    rate: sympy.Expr
    force: sympy.Expr
    gradient: dict[int, sympy.Expr]
    potential: sympy.Expr
    removed: sympy.Expr
    dissipates: bool  # damping, or a one-sided range (its force may be clipped)


def spring_law(kin: Kinematics, index: int) -> SpringLaw:
    """The law of the model's spring `index` (its one definition: forces, energy, outputs)."""
    spring = kin.model.springs[index]
    q = kin.symbols.q
    position = {s: j for j, s in enumerate(q)}
    length = kin.spring_length(index)
    gradient = {position[s]: length.diff(s)
                for s in sorted(length.free_symbols & position.keys(), key=position.get)}
    rate = sympy.Add(*(g * kin.symbols.qd[j] for j, g in gradient.items()))
    const = {name: kin.const(getattr(spring, name)) if getattr(spring, name) is not None
             else sympy.Integer(0) for name in ("stiffness", "preload", "damping")}
    stretch = length - kin.const(spring.free_length) if spring.free_length is not None \
        else length
    elastic = const["preload"] - const["stiffness"] * stretch
    potential = const["stiffness"] * stretch**2 / 2 - const["preload"] * stretch
    both = elastic - const["damping"] * rate
    if spring.acts is ir.SpringActs.BOTH:
        force, removed = both, const["damping"] * rate**2
    else:
        push = spring.acts is ir.SpringActs.PUSH
        acting = stretch < 0 if push else stretch > 0
        clipped = sympy.Max(both, 0) if push else sympy.Min(both, 0)
        zero = sympy.Integer(0)
        force = sympy.Piecewise((clipped, acting), (zero, True))
        potential = sympy.Piecewise((potential, acting), (zero, True))
        removed = sympy.Piecewise(((elastic - clipped) * rate, acting), (zero, True))
    return SpringLaw(length, rate, force, gradient, potential, removed,
                     spring.damping is not None or spring.acts is not ir.SpringActs.BOTH)


def derive_loads(model: ir.Model, kin: Kinematics, mass_matrix: sympy.SparseMatrix,
                 thetas, jacobian: sympy.SparseMatrix) -> Loads:
    """Energies, dissipators and f for a model whose hinge angles (a sequence, indexed only
    where a spring or a cable needs an angle) and d theta/dq are given."""
    qd = kin.symbols.qd
    kinetic = sympy.Add(*(value * qd[i] * qd[j] / 2
                          for (i, j), value in sorted(mass_matrix.todok().items())))
    potentials = _potentials(model, kin, thetas)
    force = _potential_force(kin, potentials)
    springs = [spring_law(kin, index) for index in range(len(model.springs))]
    for law in springs:  # the springs' whole force: their potentials are not differentiated
        for j, g in law.gradient.items():
            force[j] += law.force * g
    potentials += [(f"spring.{s.name}", law.potential) for s, law in zip(model.springs, springs)]
    rows = sparse_rows(jacobian)
    dissipators = _hinge_dissipators(model, kin, rows) + _slider_dissipators(model, kin) \
        + _beam_dissipators(model, kin) + _input_loads(model, kin, rows)
    for _, generalized, _power in dissipators:
        for j, g in generalized.items():
            force[j] += g
    dissipators += [(f"damping.{s.name}", {}, law.removed)
                    for s, law in zip(model.springs, springs) if law.dissipates]
    return Loads(
        energy_names=("kinetic",) + tuple(name for name, _ in potentials),
        energies=(kinetic,) + tuple(energy for _, energy in potentials),
        dissipator_names=tuple(name for name, _, _ in dissipators),
        dissipation=tuple(power for _, _, power in dissipators),
        force=tuple(force),
        stiffness=implicit_stiffness(model, kin, jacobian, springs),
        springs=tuple(springs),
    )


def _potential_force(kin: Kinematics, potentials: list[tuple[str, sympy.Expr]]) -> list:
    """-dV/dq of all potentials; beam elasticity uses the element's own exact gradient."""
    beam_forces = {f"elastic.{beam.name}": (element, symbols) for beam, element, symbols
                   in zip(kin.model.beams, kin.beams, kin.symbols.beam_q)
                   if hasattr(element, "elastic_force")}
    total = sympy.Add(*(energy for name, energy in potentials if name not in beam_forces))
    coordinates = set(kin.symbols.q)
    parts: dict[sympy.Symbol, list[sympy.Expr]] = {s: [] for s in kin.symbols.q}
    for term in sympy.Add.make_args(total):  # each term by the coordinates it holds
        for s in term.free_symbols & coordinates:
            parts[s].append(term.diff(s))
    force = {s: -sympy.Add(*parts[s]) for s in kin.symbols.q}
    for element, symbols in beam_forces.values():
        for s, value in zip(symbols, element.elastic_force()):
            force[s] += value
    return [force[s] for s in kin.symbols.q]


def _potentials(model: ir.Model, kin: Kinematics, thetas) -> list[tuple[str, sympy.Expr]]:
    """(name, V) of each potential, in the order of the ENERGIES contract."""
    terms = []
    def sprung(joint) -> bool:
        return joint.stiffness is not None or joint.preload is not None

    joints = [(hinge, thetas[i]) for i, hinge in enumerate(model.hinges) if sprung(hinge)]
    joints += [(slider, kin.slider_s(index)) for index, slider in enumerate(model.sliders)
               if sprung(slider)]
    for joint, x in joints:  # V = stiffness x^2 / 2 - preload x, x the angle or s
        energy = sympy.Integer(0)
        if joint.preload is not None:
            energy -= kin.const(joint.preload) * x
        if joint.stiffness is not None:
            energy += kin.const(joint.stiffness) * x**2 / 2
        terms.append((f"spring.{joint.name}", energy))
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
    if model.spatial:
        return spatial_gravity(model, kin)
    gx, gy = (kin.const(g) for g in model.gravity)
    energy = sympy.Integer(0)
    for index, body in enumerate(model.bodies):
        x, y, _ = kin.body_symbols(index)
        energy -= kin.const(body.mass) * (gx * x + gy * y)
    for index, particle in enumerate(model.particles):
        x, y = kin.particle_symbols(index)
        energy -= kin.const(particle.mass) * (gx * x + gy * y)
    for element in kin.beams:
        energy += element.gravity_energy(gx, gy)
    return energy


# name, generalized force (coordinate index -> its non-zero entries), power removed
Dissipator = tuple[str, dict[int, sympy.Expr], sympy.Expr]


def _hinge_dissipators(model: ir.Model, kin: Kinematics,
                       rows: list[dict[int, sympy.Expr]]) -> list[Dissipator]:
    """Viscous damping torques on hinge angles."""
    qd = kin.symbols.qd
    found = []
    for hinge, row in zip(model.hinges, rows):
        if hinge.damping is not None:
            rate = sympy.Add(*(g * qd[j] for j, g in row.items()))
            damping = kin.const(hinge.damping)
            found.append((f"damping.{hinge.name}", {j: -damping * rate * g for j, g in row.items()},
                          damping * rate**2))
    return found


def slider_gradient(kin: Kinematics, index: int) -> dict[int, sympy.Expr]:
    """d s / dq of slider `index`'s displacement (coordinate index -> its non-zero entries)."""
    position = {symbol: j for j, symbol in enumerate(kin.symbols.q)}
    s = kin.slider_s(index)
    gradient = {position[symbol]: s.diff(symbol) for symbol in
                sorted(s.free_symbols & position.keys(), key=position.get)}
    return {j: g for j, g in gradient.items() if g != 0}


def _slider_dissipators(model: ir.Model, kin: Kinematics) -> list[Dissipator]:
    """Viscous damping forces along slider axes: -damping * s_rate on s."""
    qd = kin.symbols.qd
    found = []
    for index, slider in enumerate(model.sliders):
        if slider.damping is not None:
            row = slider_gradient(kin, index)
            rate = sympy.Add(*(g * qd[j] for j, g in row.items()))
            damping = kin.const(slider.damping)
            found.append((f"damping.{slider.name}",
                          {j: -damping * rate * g for j, g in row.items()}, damping * rate**2))
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
        generalized = {start + k: value for k, value in enumerate(local)}
        power = element.damping_power(rates) if hasattr(element, "damping_power") \
            else -sympy.Add(*(r * f for r, f in zip(rates, local)))
        found.append((f"damping.{beam.name}", generalized, power))
    return found


def _input_loads(model: ir.Model, kin: Kinematics,
                 jacobian_rows: list[dict[int, sympy.Expr]]) -> list[Dissipator]:
    """Each input's generalized force and the power it removes (negative while it drives):
    u(t) = p[slot] + p[slot + 1] t per component (ir.Input)."""
    p, t, q, qd = kin.symbols.p, kin.symbols.t, kin.symbols.q, kin.symbols.qd
    index = {s: j for j, s in enumerate(q)}
    found = []
    for put in model.inputs:
        values = [p[slot] + p[slot + 1] * t for slot in put.slots]
        if put.kind is ir.InputKind.TORQUE:
            rows = [jacobian_rows[put.hinge]]
        else:
            position = kin.point_position(put.point.member, put.point.point)
            rows = [{index[s]: coordinate.diff(s)
                     for s in sorted(coordinate.free_symbols & index.keys(), key=index.get)}
                    for coordinate in position]
        generalized: dict[int, sympy.Expr] = {}
        power = sympy.Integer(0)
        for value, row in zip(values, rows):
            for j, r in row.items():
                generalized[j] = generalized.get(j, sympy.Integer(0)) + value * r
            power -= value * sympy.Add(*(r * qd[j] for j, r in row.items()))
        found.append((f"input.{put.name}", generalized, power))
    return found
