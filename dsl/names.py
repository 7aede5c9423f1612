"""The symbol table: every declared name, its kind and index, and each member's points.

One namespace holds parameters, members (bars, bodies, beams, particles), joints (hinges,
sliders, welds, free joints), springs, cables, outputs and inputs.
Keywords, functions, `pi`, `t`, `ground` and `system` are reserved. A parameter may reuse a unit's
name (the pendulum's `m`): a bare name is looked up as a declared name first, and a unit
written after a value (`2 m`) is always the unit.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .errors import Reporter, at
from .ir import FUNCTIONS, Member, MemberKind, Span
from .syntax import (KEYWORDS, CableStmt, GroundStmt, InputStmt, JointStmt, MemberStmt,
                     OutputStmt, ParamStmt, PointItem, SourceFile)
from .units import UNITS

CONSTANTS = frozenset({"pi", "t"})
# Names of things every model has: the ground, and the system as a whole (its outputs).
BUILT_IN = ("ground", "system")

# What each kind is called in messages.
KIND_WORDS = {
    "param": "parameter", "bar": "bar", "body": "body", "beam": "beam", "particle": "particle",
    "hinge": "hinge", "slider": "slider", "weld": "weld", "free": "free joint", "ball": "ball joint",
    "cylindrical": "cylindrical joint", "universal": "universal joint",
    "spring": "spring", "cable": "cable", "output": "output", "input": "input",
    "ground": "the ground", "system": "the system",
}
MEMBER_KINDS = ("bar", "body", "beam", "particle", "ground")
# connectors that are joints
JOINT_KINDS = ("hinge", "slider", "weld", "free", "ball", "cylindrical", "universal")
# Every rigid member (and a particle) has the point `cm`, its centre of mass; a bar and a
# beam have their ends `a` and `b`.
BUILT_IN_POINTS = {"bar": ("a", "b", "cm"), "body": ("cm",), "particle": ("cm",),
                   "beam": ("a", "b")}


@dataclass(frozen=True, slots=True)
class Symbol:
    """A declared name: its kind, its index among elements of that kind (bars and bodies
    share Model.bodies), and where it is declared."""

    name: str
    kind: str
    index: int
    span: Span

    @property
    def member(self) -> Member:
        assert self.kind in MEMBER_KINDS, self.kind
        kind = {"bar": MemberKind.BODY, "body": MemberKind.BODY, "beam": MemberKind.BEAM,
                "particle": MemberKind.PARTICLE, "ground": MemberKind.GROUND}[self.kind]
        return Member(kind, self.index)

    def describe(self) -> str:
        """"bar 'yoke'", "the ground"."""
        if self.kind in BUILT_IN:
            return KIND_WORDS[self.kind]
        return f"{KIND_WORDS[self.kind]} '{self.name}'"


@dataclass
class SymbolTable:
    symbols: dict[str, Symbol] = field(default_factory=dict)
    points: dict[str, dict[str, Span | None]] = field(default_factory=dict)  # member -> points
    counts: dict[str, int] = field(default_factory=dict)

    def get(self, name: str) -> Symbol | None:
        return self.symbols.get(name)

    def of_kind(self, *kinds: str) -> list[Symbol]:
        return [s for s in self.symbols.values() if s.kind in kinds]

    def names_of_kind(self, *kinds: str) -> list[str]:
        return [s.name for s in self.of_kind(*kinds)]


_INDEX_GROUP = {"bar": "body", "body": "body"}  # bars and bodies are both Model.bodies


def collect_symbols(source: SourceFile, report: Reporter) -> SymbolTable:
    """Declare every name in file order; report duplicates and reserved names."""
    table = SymbolTable()
    ground_span = Span(source.filename, 1, 1, 1, 1)
    table.symbols["ground"] = Symbol("ground", "ground", 0, ground_span)
    table.symbols["system"] = Symbol("system", "system", 0, ground_span)
    table.points["ground"] = {"origin": None}
    for statement in source.statements:
        _declare_statement(table, statement, report)
    return table


def _declare_statement(table: SymbolTable, statement, report: Reporter) -> None:
    if isinstance(statement, ParamStmt):
        _declare(table, statement.name, "param", report)
    elif isinstance(statement, MemberStmt):
        if _declare(table, statement.name, statement.kind, report):
            _declare_points(table, statement, report)
    elif isinstance(statement, JointStmt):
        _declare(table, statement.name, statement.kind, report)
    elif isinstance(statement, CableStmt):
        _declare(table, statement.name, "cable", report)
    elif isinstance(statement, OutputStmt):
        _declare(table, statement.name, "output", report)
    elif isinstance(statement, InputStmt):
        _declare(table, statement.name, "input", report)
    elif isinstance(statement, GroundStmt):
        _declare_points_of(table, "ground", "the ground", statement.block.items, report)


def _declare(table: SymbolTable, ident, kind: str, report: Reporter) -> bool:
    name = ident.text
    if name in KEYWORDS or name in FUNCTIONS or name in CONSTANTS or name in BUILT_IN:
        what = "a keyword" if name in KEYWORDS else "a function" if name in FUNCTIONS \
            else "the ground" if name == "ground" \
            else "reserved for the system's quantities (system.momentum_x, ...)" \
            if name == "system" else "a built-in constant"
        word = KIND_WORDS[kind]
        article = "an" if word[0] in "aeiou" else "a"
        report.error("E014", f"'{name}' is {what} and cannot name {article} {word}",
                     ident.span, hint="choose another name")
        return False
    if name in table.symbols:
        first = table.symbols[name]
        report.error("E011", f"duplicate name '{name}': already used by {first.describe()}",
                     ident.span, notes=[f"first defined at {at(first.span)}"])
        return False
    group = _INDEX_GROUP.get(kind, kind)
    index = table.counts.get(group, 0)
    table.counts[group] = index + 1
    table.symbols[name] = Symbol(name, kind, index, ident.span)
    return True


def _declare_points(table: SymbolTable, statement: MemberStmt, report: Reporter) -> None:
    name = statement.name.text
    table.points[name] = dict.fromkeys(BUILT_IN_POINTS[statement.kind])
    if statement.kind in ("beam", "particle"):
        return  # a beam's points are its ends, a particle's its cm: others are reported later
    owner = f"{statement.kind} '{name}'"
    _declare_points_of(table, name, owner, statement.block.items, report)


def _declare_points_of(table: SymbolTable, member: str, owner: str, items,
                       report: Reporter) -> None:
    points = table.points[member]
    for item in items:
        if not isinstance(item, PointItem):
            continue
        name = item.name.text
        if name in points:
            first = points[name]
            notes = [f"first defined at {at(first)}"] if first else \
                [f"'{name}' is a built-in point of {owner}" + (" (its centre of mass)"
                                                              if name == "cm" else "")]
            report.error("E011", f"duplicate point '{name}' on {owner}", item.name.span,
                         notes=notes)
            continue
        points[name] = item.name.span


def element_name(symbols: SymbolTable):
    """A predicate for the names a linear form is taken in (hinge and cable angles): any
    element, and unknown names (reported by the caller), but not parameters, units, `pi`
    or `t`."""
    def is_element(name: str) -> bool:
        symbol = symbols.get(name)
        if symbol is not None:
            return symbol.kind != "param"
        return name not in UNITS and name not in CONSTANTS
    return is_element
