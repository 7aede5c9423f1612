"""Repeated blocks of a model function: the same few expressions once per hinge or per body.

A spatial chain's hinges are alike: each one's rows, angle, rate, gradient and gamma are the
same expressions of its two members' coordinates and its own named constants, only the
symbols differ. derive marks each such part of a function's results as a `Block`: where its
entries are (`places`), its own steps (a hinge's vectors, S, C) and `roles`, each of its
symbols with the placeholder it stands for in the block's `template` (member A's coordinates
`#a0`.., their rates `#da0`.., B's `#b0`.., `#db0`.., its rows' multipliers `#lam0`.., its
named constants and steps `#c.<name>`). A block of a sum (Phi_q^T lambda: each row block's
terms of each column) gives its terms, which its kernel's call adds to the entries.
Blocks whose templates are equal are of one kind (`kinds`): lowering writes a kind used
twice or more once, as a kernel (a C function called per block), instead of one copy per
block. Pure mathematics: symbols and expressions, no code."""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from .assembly import Group
from .tangent import needed_steps

Place = tuple[int, int, int]  # (result, row, column) of one entry of a function's results
# The placeholder groups of a kernel's arguments, in order: member A's coordinates and their
# rates, member B's, then the constants (the named ones, the steps' inputs and parameters).
COORDINATE_GROUPS = ("a", "da", "b", "db", "lam")
CONSTANTS = "c"


@dataclass(frozen=True)
class Block:
    """One part of a function's results: its entries' places, the steps only it uses, and
    each symbol of its entries and steps that names it (a coordinate, a named constant, a
    step) with the placeholder it stands for; `label` names its kind ("hinge", "frame")."""

    label: str
    places: tuple[Place, ...]
    steps: tuple[Group, ...]
    roles: tuple[tuple[sympy.Symbol, sympy.Symbol], ...]
    # a block of a sum: its terms of each place's entry (the entry is the sum of its blocks'
    # terms and the rest); None: the block's entries are the places' entries whole
    terms: tuple[sympy.Expr, ...] | None = None


@dataclass(frozen=True)
class Kind:
    """The template of a kind of blocks: its steps and entries over placeholders, and its
    arguments: per group (COORDINATE_GROUPS that it uses, then CONSTANTS) the placeholders, in
    order (a coordinate group whole: an instance passes its member's coordinates)."""

    label: str
    steps: tuple[Group, ...]
    outputs: tuple[sympy.Expr, ...]
    groups: tuple[tuple[str, tuple[sympy.Symbol, ...]], ...]


@dataclass(frozen=True)
class Instance:
    """A block as a use of its kind: the kind's index, the actual value of each of its
    argument groups' placeholders, and where its outputs go."""

    kind: int
    args: tuple[tuple[sympy.Expr, ...], ...]
    places: tuple[Place, ...]
    terms: tuple[sympy.Expr, ...] | None = None  # a block of a sum's terms (Block.terms)


def kinds(blocks: tuple[Block, ...], values: dict[Place, sympy.Expr], repeated: int = 2
          ) -> tuple[tuple[Kind, ...], tuple[Instance, ...]]:
    """The kinds used by `repeated` blocks or more and those blocks as their instances
    (`values`: each place's entry); a block of a kind used fewer times is left out (its
    entries stay in the function as they are). One pass: each block's template is built once
    and looked up in a dictionary."""
    found: dict[tuple, list] = {}
    for block in blocks:
        roles = dict(block.roles)
        entries = block.terms if block.terms is not None \
            else [values[place] for place in block.places]
        outputs = tuple(value.xreplace(roles) for value in entries)
        steps = tuple(tuple((symbol.xreplace(roles), value.xreplace(roles))
                            for symbol, value in group)
                      for group in needed_steps(block.steps, entries))
        key = (block.label, block.terms is not None, steps, outputs)
        found.setdefault(key, []).append(block)
    result_kinds: list[Kind] = []
    instances: list[Instance] = []
    for (label, _, steps, outputs), members in found.items():
        if len(members) < repeated:
            continue
        kind = Kind(label, steps, outputs, _groups(steps, outputs, members[0]))
        for block in members:
            actual = {placeholder: symbol for symbol, placeholder in block.roles}
            args = tuple(tuple(actual.get(x, x) for x in placeholders)
                         for _, placeholders in kind.groups)
            instances.append(Instance(len(result_kinds), args, block.places, block.terms))
        result_kinds.append(kind)
    instances.sort(key=lambda instance: instance.places[0])
    return tuple(result_kinds), tuple(instances)


def _groups(steps: tuple[Group, ...], outputs: tuple[sympy.Expr, ...], block: Block
            ) -> tuple[tuple[str, tuple[sympy.Symbol, ...]], ...]:
    """A kind's argument groups: each coordinate group it uses whole, in the order of
    `block`'s roles, then its other inputs (named constants and parameters) by name."""
    defined = {symbol for group in steps for symbol, _ in group}
    used = set().union(*(value.free_symbols for group in steps for _, value in group),
                       *(value.free_symbols for value in outputs)) - defined
    placeholders = [placeholder for _, placeholder in block.roles]
    groups = []
    for name in COORDINATE_GROUPS:
        members = tuple(x for x in placeholders if _group(x) == name)
        if any(x in used for x in members):
            groups.append((name, members))
    coordinates = {x for _, members in groups for x in members}
    constants = tuple(sorted(used - coordinates, key=lambda s: s.name))
    if constants:
        groups.append((CONSTANTS, constants))
    return tuple(groups)


def _group(placeholder: sympy.Symbol) -> str:
    """The group of a coordinate placeholder (`#da3` -> "da"), or CONSTANTS."""
    name = placeholder.name
    if name.startswith("#c."):
        return CONSTANTS
    return name[1:].rstrip("0123456789")


def renamed(value, roles: dict) -> sympy.Expr:
    """A vector entry (a sympy expression, or a plain int or float of the kinematics) with its
    symbols renamed by `roles`: the key of a block's kind. Numbers become sympy numbers by
    their type; nothing is parsed."""
    if isinstance(value, sympy.Basic):
        return value.xreplace(roles)
    if isinstance(value, int):
        return sympy.Integer(value)
    if isinstance(value, float):
        return sympy.Float(value)
    raise TypeError(f"not an expression or a number: {type(value).__name__}")


def multiplier_roles(multipliers) -> list[tuple[sympy.Symbol, sympy.Symbol]]:
    """A block's rows' multipliers as the placeholders `#lam0`.. (group "lam")."""
    return [(s, sympy.Symbol(f"#lam{k}")) for k, s in enumerate(multipliers)]


def member_roles(side: str, coordinates, rates) -> list[tuple[sympy.Symbol, sympy.Symbol]]:
    """A member's coordinates and rates as the placeholders of side "a" or "b"."""
    return [(s, sympy.Symbol(f"#{side}{k}")) for k, s in enumerate(coordinates)] \
        + [(s, sympy.Symbol(f"#d{side}{k}")) for k, s in enumerate(rates)]


def named_roles(symbols, prefixes: tuple[str, ...]) -> list[tuple[sympy.Symbol, sympy.Symbol]]:
    """The named symbols (`@<prefix><rest>`) of a block among `symbols` as `#c.<rest>`,
    sorted by name (the first prefix that matches)."""
    roles = []
    for symbol in sorted(symbols, key=lambda s: s.name):
        for prefix in prefixes:
            if symbol.name.startswith(f"@{prefix}"):
                roles.append((symbol, sympy.Symbol(f"#c.{symbol.name[len(prefix) + 1:]}")))
                break
    return roles
