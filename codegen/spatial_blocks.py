"""The repeated blocks of a spatial model's functions (codegen/blocks.py): each body's six
frame rows and each hinge's five rows in phi, phi_q and gamma, and each hinge's angle, rate,
gradient and gamma in the hinge functions."""

from __future__ import annotations

import sympy

from depsim.dsl import ir

from .blocks import Block, member_roles, multiplier_roles, named_roles
from .spatial import SpatialKinematics


RowPart = tuple[str, list[int], tuple[ir.Member, ...], tuple[str, ...]]


def row_parts(model: ir.Model, kin: SpatialKinematics, row_joints: tuple[str, ...]
              ) -> list[RowPart]:
    """The rows' blocks: (label, rows, members, name prefixes) of each body's frame rows and
    each hinge's rows (`row_joints`: each row's joint or body name)."""
    rows_of: dict[str, list[int]] = {}
    for index, joint in enumerate(row_joints):
        rows_of.setdefault(joint, []).append(index)
    parts = [("frame", rows_of.get(body.name, []), (ir.Member(ir.MemberKind.BODY, index),), ())
             for index, body in enumerate(model.bodies)]
    parts += [("hinge_rows", rows_of.get(hinge.name, []), (hinge.a.member, hinge.b.member),
               _prefixes(kin, hinge)) for hinge in model.hinges]
    return [part for part in parts if part[1]]


def row_derivatives(parts: list[RowPart], kin: SpatialKinematics, phi
                    ) -> tuple[dict[tuple[int, int], sympy.Expr], dict[int, sympy.Expr]]:
    """Phi_q's entries ((row, coordinate) -> entry) and gamma (row -> entry) of the rows of
    `parts`, each kind of block differentiated once: its rows over placeholders (its members'
    coordinates and named constants, codegen/blocks.py), d/dq and the second rate along qd
    (derive.second_rate) taken of the first block of the kind and renamed for the others."""
    from .derive import second_rate  # derive imports this module

    rates = dict(zip(kin.symbols.q, kin.symbols.qd))
    column_of = {s: j for j, s in enumerate(kin.symbols.q)}
    derived: dict[tuple, tuple] = {}
    entries: dict[tuple[int, int], sympy.Expr] = {}
    gamma: dict[int, sympy.Expr] = {}
    for label, rows, members, prefixes in parts:
        residuals = [phi[i] for i in rows]
        roles = block_roles(kin, members, prefixes, set().union(
            *(r.free_symbols for r in residuals)), rates)
        template = tuple(r.xreplace(dict(roles)) for r in residuals)
        if template not in derived:
            coordinates = [x for _, x in roles if x.name[1] in "ab"]
            moving = {x: sympy.Symbol(f"#d{x.name[1:]}") for x in coordinates}
            gradients = [{x: row.diff(x) for x in coordinates if x in row.free_symbols}
                         for row in template]
            derived[template] = ([{x: d for x, d in found.items() if d != 0}
                                  for found in gradients],
                                 [-second_rate(row, moving)[1] for row in template])
        gradients, second = derived[template]
        back = {x: symbol for symbol, x in roles}
        for row, gradient, value in zip(rows, gradients, second):
            for x, d in gradient.items():
                entries[(row, column_of[back[x]])] = d.xreplace(back)
            gamma[row] = value.xreplace(back)
    return entries, gamma


def spatial_blocks(model: ir.Model, kin: SpatialKinematics, parts: list[RowPart],
                   phi_q_pattern, hinge_jacobian_pattern, system_values: dict, transpose
                   ) -> tuple[tuple[str, tuple[Block, ...]], ...]:
    """Per function name, its blocks (`parts`: row_parts); `system_values`: per function,
    its entries' expressions by place (to find each block's named symbols); `transpose`:
    (Phi_q, its entries' names as steps, the multipliers) of Phi_q^T lambda."""
    rates = dict(zip(kin.symbols.q, kin.symbols.qd))
    entries_of = _entries_by_row(phi_q_pattern)
    blocks: dict[str, list[Block]] = {"phi": [], "phi_q": [], "gamma": []}
    for label, rows, members, prefixes in parts:
        places = {"phi": [(0, i, 0) for i in rows], "gamma": [(0, i, 0) for i in rows],
                  "phi_q": [(0, k, 0) for i in rows for k in entries_of.get(i, ())]}
        for name, found in places.items():
            blocks[name].append(_block(kin, label, tuple(found), (), members, prefixes,
                                       system_values[name], rates))
    phi_q, named, lam = transpose
    by_row: dict[int, list] = {}
    for (i, j), value in sorted(phi_q.todok().items()):
        by_row.setdefault(i, []).append((j, value))
    transpose = (by_row, dict(named), lam)
    blocks["phi_q_transpose_times"] = [
        _transpose_block(kin, label, rows, members, prefixes, transpose, rates)
        for label, rows, members, prefixes in parts]
    gradient_of = _entries_by_row(hinge_jacobian_pattern)
    for name in ("hinge_angles", "hinge_rates", "hinge_jacobian", "hinge_gamma"):
        blocks[name] = []
    for index, hinge in enumerate(model.hinges):
        members, prefixes = (hinge.a.member, hinge.b.member), _prefixes(kin, hinge)
        steps = kin.hinge_steps[index]
        for name in ("hinge_angles", "hinge_rates", "hinge_gamma"):
            blocks[name].append(_block(kin, "hinge", ((0, index, 0),), steps, members,
                                       prefixes, system_values[name], rates))
        blocks["hinge_jacobian"].append(_block(
            kin, "hinge", tuple((0, k, 0) for k in gradient_of.get(index, ())), steps, members,
            prefixes, system_values["hinge_jacobian"], rates))
    return tuple((name, tuple(found)) for name, found in blocks.items())


def _prefixes(kin: SpatialKinematics, hinge: ir.Hinge) -> tuple[str, ...]:
    """The name prefixes of a hinge's named constants and steps: its own, and its members'
    relative orientation's."""
    a, b = kin.member_name(hinge.a.member), kin.member_name(hinge.b.member)
    return (f"{hinge.name}.", f"{a}.{b}.")


def _entries_by_row(pattern) -> dict[int, list[int]]:
    """Row -> the flat indices of its entries in a row-major pattern."""
    found: dict[int, list[int]] = {}
    for k, (i, _) in enumerate(pattern):
        found.setdefault(i, []).append(k)
    return found


def _transpose_block(kin: SpatialKinematics, label: str, rows, members, prefixes, transpose,
                     rates) -> Block:
    """A row block's terms of Phi_q^T lambda: per column its rows touch, the sum of their
    entries (named steps, derive._transpose_times) times their multipliers; `transpose`:
    (row -> its (column, entry) pairs, entry name -> value, the multipliers)."""
    by_row, names, lam = transpose
    symbols = set().union(*(names.get(sympy.Symbol(f"@Phi_q{i},{j}"), value).free_symbols
                            for i in rows for j, value in by_row.get(i, ())))
    roles = block_roles(kin, members, prefixes, symbols, rates)
    roles += multiplier_roles([lam[i] for i in rows])
    column_role = dict(roles)
    terms: dict[int, list[sympy.Expr]] = {}
    steps = []
    for k, i in enumerate(rows):
        for j, value in by_row.get(i, ()):
            name = sympy.Symbol(f"@Phi_q{i},{j}")
            if name in names:
                steps.append((name, names[name]))
                roles.append((name, sympy.Symbol(
                    f"#c.Phi_q{k},{column_role[kin.symbols.q[j]].name[1:]}")))
                value = name
            terms.setdefault(j, []).append(value * lam[i])
    places = tuple((0, j, 0) for j in sorted(terms))
    return Block(label, places, (tuple(steps),) if steps else (), tuple(roles),
                 tuple(sympy.Add(*terms[j]) for j in sorted(terms)))


def block_roles(kin: SpatialKinematics, members, prefixes, symbols, rates
                ) -> list[tuple[sympy.Symbol, sympy.Symbol]]:
    """The roles of a block's symbols (codegen/blocks.py): its members' coordinates and rates
    as sides a, b (the ground has none), its named symbols among `symbols` (`prefixes`)."""
    roles = []
    for side, member in zip("ab", members):
        if member.kind is ir.MemberKind.GROUND:
            continue
        coordinates = kin.member_symbols(member)
        roles += member_roles(side, coordinates, [rates[s] for s in coordinates])
    return roles + named_roles(symbols, prefixes)


def _block(kin: SpatialKinematics, label: str, places, steps, members, prefixes,
           values: dict, rates: dict) -> Block:
    """A block of `places` (of the function whose entries are `values`) with its steps, its
    members' coordinates as sides a, b and its named symbols (`prefixes`)."""
    symbols: set[sympy.Symbol] = set()
    for place in places:
        symbols |= values[place].free_symbols
    for group in steps:
        for symbol, value in group:
            symbols.add(symbol)
            symbols |= value.free_symbols
    assert places, f"a {label} block without entries"
    return Block(label, tuple(places), tuple(steps),
                 tuple(block_roles(kin, members, prefixes, symbols, rates)))


def tree_blocks(assembly, placings, q, qd) -> tuple[tuple[str, tuple[Block, ...]], ...]:
    """tree_pose's and tree_tangent's blocks: each hinge's placement of its child
    (`placings`: spatial_assembly.assemble_spatial's, its group's index and roles), the
    child's coordinates (their rates) as the block's entries and its pose (tangent) group as
    its steps. A kernel of such a block reads its parent's coordinates (rates) from the
    results the blocks before it wrote (lower.FunctionSpec.reads_results)."""
    column = {symbol: j for j, symbol in enumerate(q)}
    column.update({symbol: j for j, symbol in enumerate(qd)})
    found: dict[str, list[Block]] = {"tree_pose": [], "tree_tangent": []}
    for name, groups in (("tree_pose", assembly.pose), ("tree_tangent", assembly.tangent)):
        for index, roles in placings:
            group = groups[index]
            places = tuple((0, column[symbol], 0) for symbol, _ in group)
            found[name].append(Block("hinge", places, (group,), roles))
    return tuple((name, tuple(blocks)) for name, blocks in found.items())


def sum_blocks(values, members) -> tuple[Block, ...]:
    """The blocks of a function whose entries are sums over the bodies (system_state: the
    momenta, the angular momentum about the origin): each body's terms of each entry, those
    terms of the entry's sum that hold its coordinates or rates (member side a) and no other
    member's; `members`: each body's (coordinates, rates). A kernel's call adds its body's
    terms; the rest of each entry (terms of no body or of several) stays inline."""
    owner = {}
    for index, (coordinates, rates) in enumerate(members):
        owner.update({symbol: index for symbol in (*coordinates, *rates)})
    found: dict[int, dict[int, list[sympy.Expr]]] = {}
    for row, value in enumerate(values):
        if not isinstance(value, sympy.Add):
            continue
        for term in value.args:
            bodies = {owner[s] for s in term.free_symbols if s in owner}
            if len(bodies) == 1:
                found.setdefault(bodies.pop(), {}).setdefault(row, []).append(term)
    blocks = []
    for index, terms in sorted(found.items()):
        rows = sorted(terms)
        blocks.append(Block("body", tuple((0, row, 0) for row in rows), (),
                            tuple(member_roles("a", *members[index])),
                            tuple(sympy.Add(*terms[row]) for row in rows)))
    return tuple(blocks)
