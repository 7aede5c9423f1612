"""derive: a checked IR Model to a SymbolicSystem (pure mathematics, no strings of code).

Equations (docs/generated-module.md, docs/method.md section 1):
    M q'' + Phi_q^T lambda = f(q, q', t),   Phi(q, t) = 0,
    Phi_q q'' = gamma = -(Phi_q q')_q q' - 2 Phi_qt q' - Phi_tt.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy
from sympy import ImmutableMatrix, ImmutableSparseMatrix

from depsim.dsl import ir
from depsim.dsl.attributes import HINGE_PROPERTIES

from .assembly import Group, assemble
from .blocks import Block
from .errors import CodegenError
from .expr import to_sympy
from .kinematics import Coordinates, Kinematics, core_sliders
from .layout import build_coordinates
from .loads import derive_loads
from .spatial import SYSTEM_STATE as SPATIAL_SYSTEM_STATE
from .spatial import (SpatialKinematics, spatial_coordinate_scales, spatial_mass_matrix,
                      spatial_rows)
from .spatial_assembly import assemble_spatial, hinge_turns
from .spatial_hinges import HingeDerivatives
from .spatial_blocks import (row_derivatives, row_parts, spatial_blocks, sum_blocks,
                             tree_blocks)
from .system import SYSTEM_STATE, OutputScope, RowIndex, run_value_names



@dataclass(frozen=True)
class SymbolicSystem:
    """A model's equations as sympy objects over the ordered symbols q, qd, p, t.

    Column vectors are (n, 1) ImmutableMatrix; names tuples give each row's meaning.
    """

    name: str
    # constant geometry named while deriving (a spatial model's unit axes, normals, relative
    # orientations: codegen/spatial.py), each a step of its own computed from p and the
    # ones before it at the start of every generated function that uses it
    constants: tuple[Group, ...]
    # a spatial model's hinges' vectors, S, C and their rates named while deriving
    # (codegen/spatial_hinges.py): steps of q, qd and the constants, in order
    hinge_steps: tuple[Group, ...]
    coordinates: tuple[str, ...]  # NQ names, e.g. "yoke.phi"
    q: tuple[sympy.Symbol, ...]
    qd: tuple[sympy.Symbol, ...]
    p: tuple[sympy.Symbol, ...]  # named after Model.params
    t: sympy.Symbol
    mass_matrix: ImmutableSparseMatrix  # (NQ, NQ), a function of p only
    mass_pattern: tuple[tuple[int, int], ...]  # its structural non-zeros, row-major
    constraint_names: tuple[str, ...]  # NC rows, "<joint>.<component>"
    constraint_joints: tuple[str, ...]
    constraint_hinges: tuple[int, ...]  # each row's hinge (index), -1 for none
    constraint_sliders: tuple[int, ...]  # each row's slider (index), -1 for none
    phi: ImmutableMatrix  # (NC, 1)
    phi_q: ImmutableSparseMatrix  # (NC, NQ)
    phi_q_pattern: tuple[tuple[int, int], ...]  # structural non-zeros of phi_q, row-major
    lam: tuple[sympy.Symbol, ...]  # NC multipliers, for phi_q_lam
    phi_q_entries: Group  # Phi_q's non-constant non-zeros as symbols := their expressions
    phi_q_lam: ImmutableMatrix  # (NQ, 1) Phi_q^T lam over those symbols and lam
    phi_t: ImmutableMatrix  # (NC, 1)
    gamma: ImmutableMatrix  # (NC, 1)
    force: ImmutableMatrix  # (NQ, 1)
    hinge_names: tuple[str, ...]
    # per entry of hinge_names: 1 where its angle is measured by atan2 within half a turn of
    # the middle of its travel (a spatial hinge), 0 where it is continuous
    hinge_wraps: tuple[int, ...]
    slider_names: tuple[str, ...]
    hinge_angles: ImmutableMatrix  # (NH, 1)
    hinge_rates: ImmutableMatrix  # (NH, 1)
    hinge_jacobian: ImmutableSparseMatrix  # (NH, NQ)
    hinge_jacobian_pattern: tuple[tuple[int, int], ...]  # its structural non-zeros, row-major
    hinge_gamma: ImmutableMatrix  # (NH, 1), -(J qd)_q qd: a lock J qdd = hinge_gamma
    hinge_properties: ImmutableMatrix  # (NH, len(HINGE_PROPERTIES)), nan where not given
    coordinate_scales: ImmutableMatrix  # (NQ, 1): the model's length for a position, else 1
    output_names: tuple[str, ...]
    outputs: ImmutableMatrix  # (NOUT, 1), of q, qd, t, p, lam and w
    w: tuple[sympy.Symbol, ...]  # NW run values an output may use (the core supplies them)
    system_state: ImmutableMatrix  # (NSYS, 1): system_state_names of q, qd, p
    system_state_names: tuple[str, ...]  # SYSTEM_STATE (planar) or spatial.SYSTEM_STATE
    run_value_names: tuple[str, ...]  # their names (RUN_VALUES)
    energy_names: tuple[str, ...]
    energy: ImmutableMatrix  # (NE, 1), J
    dissipator_names: tuple[str, ...]
    dissipation: ImmutableMatrix  # (ND, 1), W
    tree_joints: tuple[str, ...]  # NV joints placing the members, in placement order
    tree_held: tuple[int, ...]  # NV: 1 value given, 2 rate given (held by the assembly)
    v: tuple[sympy.Symbol, ...]  # their values (rad or m)
    vd: tuple[sympy.Symbol, ...]  # their rates
    tree_v0: ImmutableMatrix  # (NV, 1) given values, else 0; a function of p
    tree_vd0: ImmutableMatrix  # (NV, 1) given rates, else 0
    tree_pose: tuple[Group, ...]  # per member: its q := expressions of earlier q, v and p
    tree_tangent: tuple[Group, ...]  # per member: its qd := d pose / d(earlier q, v) . rates
    loop_angles: ImmutableMatrix  # (NH, 1) given initial angle of a loop-closing hinge, else nan
    loop_rates: ImmutableMatrix  # (NH, 1) its given rate, else nan
    stiffness_pattern: tuple[tuple[int, int], ...]  # NKZ structural non-zeros, row-major
    stiffness: ImmutableMatrix  # (NKZ, 1) K ~ -df/dq of the beams' elasticity there (N/m)
    stiffness_damping: ImmutableMatrix  # (NKZ, 1) D = -df/dqd of their damping there (N s/m)
    limit_values: ImmutableMatrix  # (NLIM, 1) each range check's value (Model.limits)
    limit_bounds: ImmutableMatrix  # (NLIM, 1) its bound (an ordered pair), else 0
    # per function name, the repeated parts of its results (codegen/blocks.py: a spatial
    # model's frame rows, hinge rows and hinge functions); none for a planar model
    blocks: tuple[tuple[str, tuple[Block, ...]], ...] = ()


def column(values) -> ImmutableMatrix:
    """An (n, 1) immutable column, also for n = 0."""
    values = list(values)
    return ImmutableMatrix(len(values), 1, values)


def jacobian(vector: ImmutableMatrix, symbols: tuple[sympy.Symbol, ...]
             ) -> ImmutableSparseMatrix:
    """d vector / d symbols, (rows, len(symbols)), sparse, also for empty vectors. Each entry
    is differentiated only by the symbols it contains (a joint's rows touch two members), so
    the cost follows the non-zeros, not rows x symbols."""
    index = {s: j for j, s in enumerate(symbols)}
    entries = {}
    for i in range(vector.rows):
        for s in sorted(vector[i].free_symbols & index.keys(), key=index.get):
            derivative = vector[i].diff(s)
            if derivative != 0:
                entries[(i, index[s])] = derivative
    return ImmutableSparseMatrix(vector.rows, len(symbols), entries)


def times(matrix: ImmutableSparseMatrix, vector) -> ImmutableMatrix:
    """matrix . vector as a column, summing each row's non-zeros only."""
    terms: list[list[sympy.Expr]] = [[] for _ in range(matrix.rows)]
    for (i, j), value in sorted(matrix.todok().items()):
        terms[i].append(value * vector[j])
    return column(sympy.Add(*row) for row in terms)


def _transpose_times(phi_q: ImmutableSparseMatrix
                     ) -> tuple[tuple[sympy.Symbol, ...], Group, ImmutableMatrix]:
    """Multiplier symbols lam, Phi_q's non-constant non-zeros named as steps, and Phi_q^T lam
    in those names: each entry computed once and multiplied by its row's multiplier, as a
    product with the Jacobian's values would (the names keep sympy from distributing an
    entry's factors over the sum). '@' keeps the names apart from the parameters'."""
    lam = tuple(sympy.Symbol(f"@lambda{i}") for i in range(phi_q.rows))
    entries: list[tuple[sympy.Symbol, sympy.Expr]] = []
    terms: list[list[sympy.Expr]] = [[] for _ in range(phi_q.cols)]
    for (i, j), value in sorted(phi_q.todok().items()):
        if not value.is_Number:
            name = sympy.Symbol(f"@Phi_q{i},{j}")
            entries.append((name, value))
            value = name
        terms[j].append(value * lam[i])
    return lam, tuple(entries), column(sympy.Add(*column_terms) for column_terms in terms)


def acceleration_rhs(vector: ImmutableMatrix, vector_q: ImmutableSparseMatrix,
                     symbols: Coordinates) -> ImmutableMatrix:
    """gamma = -(V_q qd)_q qd - 2 V_qt qd - V_tt of a vector V(q, t): V_q qdd = gamma is
    d^2 V / dt^2 = 0 along the motion (equation 2c)."""
    qd, t = symbols.qd, symbols.t
    return ImmutableMatrix(-times(jacobian(times(vector_q, qd), symbols.q), qd)
                           - 2 * times(vector_q.diff(t), qd) - vector.diff(t, 2))


def second_rate(expr: sympy.Expr, rates: dict[sympy.Symbol, sympy.Symbol]
                ) -> tuple[sympy.Expr, sympy.Expr]:
    """(V', V'') of V(q) along q(t) = q + t qd (qdd = 0), by the sum and product rules on V's
    tree (`rates`: q -> qd): for V without t, V'' = (V_q qd)_q qd, so -V'' is V's gamma.
    A spatial model's rows are sums of products of coordinates and constants (bilinear or
    quadratic in q): a product's V'' is its factors' pairwise products of rates (the
    hinge axis row (R_B a) . (R_A e) gives 2 (R_B' a) . (R_A' e)), where differentiating
    V_q qd again writes out every term of the row twice. Any other node (a function of q)
    is differentiated as it is."""
    zero = sympy.Integer(0)
    if expr in rates:
        return rates[expr], zero
    if not expr.free_symbols & rates.keys():
        return zero, zero
    if expr.is_Add:
        parts = [second_rate(term, rates) for term in expr.args]
        return sympy.Add(*(d for d, _ in parts)), sympy.Add(*(dd for _, dd in parts))
    if expr.is_Mul:
        factors = expr.args
        parts = [second_rate(factor, rates) for factor in factors]
        moving = [k for k, (d, _) in enumerate(parts) if d != 0]

        def others(*left_out: int) -> list[sympy.Expr]:
            return [f for k, f in enumerate(factors) if k not in left_out]

        first = sympy.Add(*(sympy.Mul(parts[k][0], *others(k)) for k in moving))
        second = sympy.Add(*(sympy.Mul(parts[k][1], *others(k)) for k in moving
                             if parts[k][1] != 0),
                           *(2 * sympy.Mul(parts[k][0], parts[l][0], *others(k, l))
                             for a, k in enumerate(moving) for l in moving[a + 1:]))
        return first, second
    if expr.is_Pow and expr.exp.is_Integer and expr.exp > 1:
        base, n = expr.base, expr.exp
        d, dd = second_rate(base, rates)
        return n * base**(n - 1) * d, n * (n - 1) * base**(n - 2) * d**2 + n * base**(n - 1) * dd
    present = sorted(expr.free_symbols & rates.keys(), key=lambda s: s.name)
    first = sympy.Add(*(expr.diff(s) * rates[s] for s in present))
    return first, sympy.Add(*(first.diff(s) * rates[s] for s in present))


def _rows_gamma(phi: ImmutableMatrix, phi_q: ImmutableSparseMatrix,
                symbols: Coordinates, spatial: bool) -> ImmutableMatrix:
    """gamma of the rows: a spatial model's rows without t by second_rate, every other
    model's by acceleration_rhs."""
    if not spatial or phi.has(symbols.t):
        return acceleration_rhs(phi, phi_q, symbols)
    rates = dict(zip(symbols.q, symbols.qd))
    return column(-second_rate(row, rates)[1] for row in phi)


def _rows_derivatives(phi: ImmutableMatrix, parts, kin, symbols: Coordinates, spatial: bool
                      ) -> tuple[ImmutableSparseMatrix, ImmutableMatrix]:
    """Phi_q and gamma of the rows: a spatial model's rows without t by blocks of a kind
    (spatial_blocks.row_derivatives: each kind's rows differentiated once), the rows of no
    block and every other model's as they are (jacobian, _rows_gamma)."""
    if not parts or phi.has(symbols.t):
        phi_q = jacobian(phi, symbols.q)
        return phi_q, _rows_gamma(phi, phi_q, symbols, spatial)
    entries, gamma = row_derivatives(parts, kin, phi)
    rest = [i for i in range(phi.rows) if i not in gamma]
    rest_phi = column(phi[i] for i in rest)
    rest_q = jacobian(rest_phi, symbols.q)
    entries.update({(rest[i], j): value for (i, j), value in rest_q.todok().items()})
    gamma.update(zip(rest, _rows_gamma(rest_phi, rest_q, symbols, True)))
    return (ImmutableSparseMatrix(phi.rows, len(symbols.q), entries),
            column(gamma[i] for i in range(phi.rows)))


def derive(model: ir.Model) -> SymbolicSystem:
    """Derive the symbolic system of a checked model (parameters stay symbols)."""
    symbols, beams = build_coordinates(model)
    if model.spatial:
        placing = SpatialKinematics(model, symbols)
        placings: list = []
        assembly = assemble_spatial(model, placing, placings)
        kin = SpatialKinematics(model, symbols, hinge_turns(model, placing, assembly))
        rows = [_Row(*row) for row in spatial_rows(model, kin)]
        mass = spatial_mass_matrix(model, kin)
        scales = column(spatial_coordinate_scales(model, kin))
        state_names = SPATIAL_SYSTEM_STATE
    else:
        assembly = assemble(model, Kinematics(model, symbols, beams))
        kin = Kinematics(model, symbols, beams, assembly.beam_angles)
        rows = _constraints(model, kin, assembly.at_start)
        mass = _mass_matrix(model, kin)
        scales = _coordinate_scales(model, kin)
        state_names = SYSTEM_STATE
    q, qd, t = symbols.q, column(symbols.qd), symbols.t
    phi = column(row.residual for row in rows)
    parts = row_parts(model, kin, tuple(row.joint for row in rows)) if model.spatial else []
    phi_q, gamma = _rows_derivatives(phi, parts, kin, symbols, model.spatial)
    lam, entries, phi_q_lam = _transpose_times(phi_q)
    phi_t = phi.diff(t)
    sliding = core_sliders(model)  # the sliders after the hinges in the hinge tables
    if model.spatial:  # a hinge written out in q (atan2 of S, C) only where a load needs it
        thetas = _Angles(kin, len(model.hinges), [kin.slider_s(i) for i in sliding])
        hinge_jacobian, angles, rates, hinge_gamma = _spatial_hinge_derivatives(
            model, kin, thetas, symbols)
    else:
        thetas = column([kin.hinge_theta(i) for i in range(len(model.hinges))]
                        + [kin.slider_s(i) for i in sliding])
        hinge_jacobian = jacobian(thetas, q)
        hinge_gamma = acceleration_rhs(thetas, hinge_jacobian, symbols)
        angles, rates = thetas, times(hinge_jacobian, symbols.qd)
    loads = derive_loads(model, kin, mass, thetas, hinge_jacobian)
    run_values = run_value_names(model, loads.dissipator_names)
    w = tuple(sympy.Symbol(f"@w{i}") for i in range(len(run_values)))
    scope = OutputScope(kin, mass, lam, w,
                        RowIndex({(row.joint, row.name.rsplit(".", 1)[1]): i
                                  for i, row in enumerate(rows)}),
                        loads.energies, loads.dissipator_names, loads.springs)
    system_state = column(scope.system_quantity(name, None) for name in state_names)
    constants = {}  # the spatial geometry's named constants, in the order they were named
    phi_q_pattern, hinge_jacobian_pattern = _pattern(phi_q), _pattern(hinge_jacobian)
    blocks = ()
    if model.spatial:
        rate_of = dict(zip(symbols.q, symbols.qd))
        constants = {**placing.constants, **kin.constants}
        values = {"phi": _places(phi), "gamma": _places(gamma),
                  "phi_q": _places([phi_q[i, j] for i, j in phi_q_pattern]),
                  "hinge_angles": _places(angles), "hinge_rates": _places(rates),
                  "hinge_gamma": _places(hinge_gamma),
                  "hinge_jacobian": _places([hinge_jacobian[i, j]
                                             for i, j in hinge_jacobian_pattern])}
        blocks = spatial_blocks(model, kin, parts, phi_q_pattern, hinge_jacobian_pattern,
                                values, (phi_q, entries, lam)) \
            + tree_blocks(assembly, placings, symbols.q, symbols.qd) \
            + (("system_state", sum_blocks(system_state, [
                (kin.body_symbols(i), [rate_of[s] for s in kin.body_symbols(i)])
                for i in range(len(model.bodies))])),)
    system = SymbolicSystem(
        name=model.name,
        constants=tuple(((symbol, value),) for symbol, value in constants.items()),
        hinge_steps=tuple(group for index in sorted(getattr(kin, "hinge_steps", {}))
                          for group in kin.hinge_steps[index]),
        coordinates=symbols.names, q=q, qd=symbols.qd, p=symbols.p, t=t,
        mass_matrix=mass, mass_pattern=_pattern(mass),
        constraint_names=tuple(row.name for row in rows),
        constraint_joints=tuple(row.joint for row in rows),
        constraint_hinges=tuple(row.hinge for row in rows),
        constraint_sliders=tuple(row.slider for row in rows),
        phi=phi, phi_q=phi_q, phi_q_pattern=phi_q_pattern, lam=lam,
        phi_q_entries=entries, phi_q_lam=phi_q_lam, phi_t=phi_t,
        gamma=gamma, force=column(loads.force),
        hinge_names=tuple(h.name for h in model.hinges)
        + tuple(model.sliders[i].name for i in sliding),
        slider_names=tuple(s.name for s in model.sliders),
        hinge_wraps=_hinge_wraps(model, thetas) + tuple(0 for _ in sliding),
        hinge_angles=angles, hinge_rates=rates,
        hinge_jacobian=hinge_jacobian, hinge_jacobian_pattern=hinge_jacobian_pattern,
        hinge_gamma=hinge_gamma,
        hinge_properties=_hinge_properties(model, kin),
        coordinate_scales=scales,
        output_names=tuple(o.name for o in model.outputs),
        outputs=column(_output(o, scope) for o in model.outputs), w=w,
        system_state=system_state,
        system_state_names=state_names,
        run_value_names=run_values,
        energy_names=loads.energy_names, energy=column(loads.energies),
        dissipator_names=loads.dissipator_names, dissipation=column(loads.dissipation),
        tree_joints=assembly.tree_joints, tree_held=assembly.held, v=assembly.v,
        vd=assembly.vd, tree_v0=column(assembly.v0), tree_vd0=column(assembly.vd0),
        tree_pose=assembly.pose, tree_tangent=assembly.tangent,
        loop_angles=_loop_targets(model, kin, 1), loop_rates=_loop_targets(model, kin, 2),
        stiffness_pattern=loads.stiffness.pattern, stiffness=column(loads.stiffness.K),
        stiffness_damping=column(loads.stiffness.D),
        limit_values=column(kin.const(limit.expr) for limit in model.limits),
        limit_bounds=column(kin.const(limit.bound) if limit.bound is not None else 0
                            for limit in model.limits),
        blocks=blocks,
    )
    return system


def _places(values) -> dict[tuple[int, int, int], sympy.Expr]:
    """A column's entries by their place (0, row, 0) in a function's one result."""
    return {(0, i, 0): value for i, value in enumerate(values)}


def _coordinate_scales(model: ir.Model, kin: Kinematics) -> ImmutableMatrix:
    """Per coordinate, the size its errors are measured against (docs/method.md, 6a): for a
    position the model's length, the size of its largest part (a bar's or beam's length, a
    body's largest distance from its centre of mass to a point, or its radius of gyration, a
    spring's free length); 1 for an angle or a beam node's slope vector. So a mechanism scaled in size is integrated to the same relative
    accuracy."""
    sizes = [kin.const(beam.length) for beam in model.beams]
    for body in model.bodies:
        if body.length is not None:
            sizes.append(kin.const(body.length))
        sizes.append(sympy.sqrt(kin.const(body.inertia) / kin.const(body.mass)))
        sizes += [sympy.sqrt(kin.const(point.x) ** 2 + kin.const(point.y) ** 2)
                  for point in body.points]
    sizes += [kin.const(spring.free_length) for spring in model.springs
              if spring.free_length is not None]
    sizes = [size for size in sizes if size != 0]
    length = sympy.Max(*sizes) if sizes else sympy.Integer(1)
    scales = [length, length, sympy.Integer(1)] * len(model.bodies)
    scales += [length, length] * len(model.particles)  # the bodies' order of coordinates
    for beam in kin.beams:
        scales += beam.coordinate_sizes(length)
    return column(scales)


def _loop_targets(model: ir.Model, kin: Kinematics, held: int) -> ImmutableMatrix:
    """Per hinge: the given initial angle (held = 1) or rate (2) of a hinge that closes a loop
    and was given it; nan for every other hinge."""
    loops = {index for kind, index in model.loop_joints if kind is ir.JointKind.HINGE}
    return column([kin.const(h.initial_angle if held == 1 else h.initial_rate)
                   if i in loops and h.held & held else sympy.nan
                   for i, h in enumerate(model.hinges)]
                  + [sympy.nan] * len(core_sliders(model)))


_NOT_FINITE = (sympy.zoo, sympy.oo, -sympy.oo, sympy.nan)


def _output(output: ir.Output, kin: OutputScope) -> sympy.Expr:
    """An output's expression; E905 when it has no finite value in any state (the checker
    folds constants, but `1 / (h1 - h1)` becomes 1/0 only here, where h1 - h1 cancels)."""
    expr = to_sympy(output.expr, kin)
    if expr.has(*_NOT_FINITE):
        raise CodegenError("E905", f"output '{output.name}' has no finite value in any state: "
                           "it divides by zero or takes a function outside its domain once "
                           "its terms cancel", output.span,
                           hint="check the output's expression for a difference of equal terms")
    return expr


@dataclass(frozen=True)
class _Row:
    """A constraint row: its name, its joint's name and index among the hinges or the sliders
    (-1 for the other kind), and its residual."""

    name: str
    joint: str
    hinge: int
    slider: int
    residual: sympy.Expr


def _constraints(model: ir.Model, kin: Kinematics, at_start) -> list[_Row]:
    """Every constraint row, hinges, sliders, then welds; a hinge's (and a weld's) x, y rows
    are its reaction force (`at_start`: an expression at the initial placement, for a
    slider's relative angle). A slider moving a particle has no angle row, nor a weld to
    one: a particle has no angle."""
    rows = []
    for index, hinge in enumerate(model.hinges):
        ra, rb = kin.attachment_position(hinge.a), kin.attachment_position(hinge.b)
        rows += [_Row(f"{hinge.name}.x", hinge.name, index, -1, ra[0] - rb[0]),
                 _Row(f"{hinge.name}.y", hinge.name, index, -1, ra[1] - rb[1])]
    for index, slider in enumerate(model.sliders):
        (ux, uy), (dx, dy) = kin.slider_axis(index), kin.slider_offset(index)
        relative = kin.attachment_angle(slider.b) - kin.attachment_angle(slider.a)
        rows.append(_Row(f"{slider.name}.normal", slider.name, -1, index, ux * dy - uy * dx))
        if slider.b.member.kind is not ir.MemberKind.PARTICLE:
            rows.append(_Row(f"{slider.name}.angle", slider.name, -1, index,
                             relative - at_start(relative)))
    for weld in model.welds:
        ra, rb = kin.attachment_position(weld.a), kin.attachment_position(weld.b)
        rows += [_Row(f"{weld.name}.x", weld.name, -1, -1, ra[0] - rb[0]),
                 _Row(f"{weld.name}.y", weld.name, -1, -1, ra[1] - rb[1])]
        if weld.rotational:
            relative = kin.attachment_angle(weld.b) - kin.attachment_angle(weld.a)
            rows.append(_Row(f"{weld.name}.angle", weld.name, -1, -1,
                             relative - kin.const(weld.angle)))
    return rows


def _hinge_properties(model: ir.Model, kin: Kinematics) -> ImmutableMatrix:
    """HINGE_PROPERTIES of each hinge, then of each slider of core_sliders (SI), sympy.nan
    for an attribute the model leaves out."""
    joints = model.hinges + tuple(model.sliders[i] for i in core_sliders(model))
    return ImmutableMatrix(len(joints), len(HINGE_PROPERTIES), [
        sympy.nan if getattr(joint, name) is None else kin.const(getattr(joint, name))
        for joint in joints for name in HINGE_PROPERTIES])


def _hinge_wraps(model: ir.Model, thetas) -> tuple[int, ...]:
    """Per hinge, 1 where its angle is measured within half a turn of the middle of its
    travel (atan2: a spatial hinge) and the motion depends on it: a load (a spring, a
    cable) or the integrator's latch or stops; else 0 (a planar hinge is continuous; a
    spatial crank, shaft or wheel that nothing loads by its angle turns freely, its angle
    read within half a turn)."""
    if not model.spatial:
        return tuple(0 for _ in model.hinges)
    return tuple(int(i in thetas.found or any(x is not None for x in (
        h.latch, h.stop_min, h.stop_max))) for i, h in enumerate(model.hinges))


class _Angles:
    """A spatial model's hinge angles (kin.hinge_theta), each written out when first asked
    for, then its sliders' displacements (`displacements`)."""

    def __init__(self, kin, hinges: int, displacements: list[sympy.Expr]) -> None:
        self.kin, self.hinges, self.displacements = kin, hinges, displacements
        self.found: dict[int, sympy.Expr] = {}

    def __len__(self) -> int:
        return self.hinges + len(self.displacements)

    def __getitem__(self, index: int) -> sympy.Expr:
        if index < 0 or index >= len(self):
            raise IndexError(index)
        if index >= self.hinges:
            return self.displacements[index - self.hinges]
        if index not in self.found:
            self.found[index] = self.kin.hinge_theta(index)
        return self.found[index]


def _spatial_hinge_derivatives(model: ir.Model, kin, thetas: _Angles,
                               symbols: Coordinates
                               ) -> tuple[ImmutableSparseMatrix, ImmutableMatrix,
                                          ImmutableMatrix, ImmutableMatrix]:
    """d theta/dq, theta, theta' and -(d theta/dq qd)_q qd of a spatial model's hinge
    entries: a hinge's from its turn written out over named steps
    (spatial_hinges: each kind of hinge derived once), a slider's displacement, bilinear in q,
    differentiated as it is."""
    nh = len(model.hinges)
    hinges = HingeDerivatives(kin)
    parts = [hinges.of(i) for i in range(nh)]
    entries = {(i, j): value for i, (gradient, *_) in enumerate(parts)
               for j, value in gradient.items()}
    displacements = column(thetas.displacements)
    slider_jacobian = jacobian(displacements, symbols.q)
    entries.update({(nh + i, j): value for (i, j), value in slider_jacobian.todok().items()})
    angles = [theta for _, theta, _, _ in parts] + list(displacements)
    rates = [rate for _, _, rate, _ in parts] + list(times(slider_jacobian, symbols.qd))
    gammas = [gamma for *_, gamma in parts] \
        + list(acceleration_rhs(displacements, slider_jacobian, symbols))
    return (ImmutableSparseMatrix(len(thetas), len(symbols.q), entries), column(angles),
            column(rates), column(gammas))


def _mass_matrix(model: ir.Model, kin: Kinematics) -> ImmutableSparseMatrix:
    """Constant M: diag(m, m, J) per rigid body, diag(m, m) per particle, then each beam's
    element mass matrix."""
    entries, start = {}, 0
    for b in model.bodies:
        for k, value in enumerate((b.mass, b.mass, b.inertia)):
            entries[(start + k, start + k)] = kin.const(value)
        start += 3
    for particle in model.particles:
        for k in range(2):
            entries[(start + k, start + k)] = kin.const(particle.mass)
        start += 2
    for element in kin.beams:
        block = sympy.Matrix(element.mass_matrix)
        for (a, b), value in block.todok().items():
            entries[(start + a, start + b)] = value
        start += block.rows
    size = len(kin.symbols.q)
    return ImmutableSparseMatrix(size, size, {k: v for k, v in entries.items() if v != 0})


def _pattern(matrix: ImmutableSparseMatrix) -> tuple[tuple[int, int], ...]:
    """Structural non-zeros, row-major."""
    return tuple(sorted(k for k, v in matrix.todok().items() if v != 0))
