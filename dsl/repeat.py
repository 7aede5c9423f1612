"""Repetition: `for` loops, indexed names, array parameters and list picks, expanded into
plain statements before anything is checked (docs/language.md, Repetition).

    param N = 12                                   # structural: a loop bound
    param m[3] = (12.377, 9.982, 8.920) kg         # an array: entries m[1], m[2], m[3]
    for i in 1..N {
        bar panel[i] { length = 1 m; mass = m[min(i, 3)]; inertia = 0.4 kg*m^2 }
        hinge h[i] joins panel[i-1].b to panel[i].a { angle = (-1)^i * (panel[i] - panel[i-1]) }
    }

`expand` returns the syntax tree with every loop unrolled, every index computed (in
iteration i = 3, `panel[i-1]` is the plain name `panel[2]`), loop variables and structural
parameters replaced by their values, each array parameter split into one `param` per element
and each list pick replaced by the value it picks. `resolve` then checks it as if it had
been written out by hand. Text inside a loop keeps its position, tagged with the iteration
(errors.LoopSpan), so every later diagnostic points into the loop body and names the
iteration. Nothing here evaluates user text other than through `structural.exact`.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, fields, is_dataclass
from fractions import Fraction

from .errors import LoopSpan, Reporter, at
from .ir import FUNCTIONS, Span
from .parse import MAX_NAME_LENGTH
from .structural import NotFixed, Structural, exact, pick_index, structural_params, walk, whole
from .syntax import (KEYWORDS, AttachmentRef, Block, CableStmt, ForLoop,
                     GravityStmt, GroundStmt, Ident, InitialStmt, InputStmt, JointStmt,
                     ListPick, MemberStmt, ModelStmt, NameRef, NumberLit, OutputStmt,
                     ParamStmt, Quantity, SimulateStmt, SourceFile, TupleLit, UnaryOp,
                     VectorLit)

MAX_LOOP_DEPTH = 4  # for loops inside one another
MAX_INSTANCES = 50_000  # iterations, statements and block items all loops produce together

_ONCE = {ModelStmt: "model", GravityStmt: "gravity", GroundStmt: "ground",
         SimulateStmt: "simulate"}
_DECLARING = (ParamStmt, MemberStmt, JointStmt, CableStmt, OutputStmt, InputStmt)


@dataclass(frozen=True, slots=True)
class _Env:
    """The loop variables in scope: their values, and where each was introduced."""

    values: dict[str, int]
    spans: dict[str, Span]
    iteration: tuple[tuple[str, int], ...] = ()

    def span(self, span: Span) -> Span:
        if not self.iteration:
            return span
        if isinstance(span, LoopSpan):
            span = span.plain()
        return LoopSpan(span.file, span.line, span.col, span.end_line, span.end_col,
                        self.iteration)

    def entered(self, var: Ident, value: int) -> _Env:
        return _Env({**self.values, var.text: value}, {**self.spans, var.text: var.span},
                    self.iteration + ((var.text, value),))


class _TooLarge(Exception):
    """Raised (after reporting E054) to stop expanding."""


def expand(source: SourceFile, report: Reporter
           ) -> tuple[SourceFile, dict[str, Structural]] | None:
    """`source` with its repetition expanded, and its structural parameters; None when
    the repetition has errors (all reported)."""
    structural = structural_params(source, report)
    statements = _Expander(source, structural, report).run()
    if report.has_errors:
        return None
    return SourceFile(source.filename, tuple(statements)), structural


class _Expander:
    def __init__(self, source: SourceFile, structural: dict[str, Structural],
                 report: Reporter) -> None:
        self.source = source
        self.structural = structural
        self.report = report
        self.instances = 0
        # a spatial model's vectors have three components (x, y, z)
        self.spatial = any(isinstance(s, ModelStmt) and s.spatial for s in source.statements)
        self.declared: dict[str, Span] = {}  # every declared name as written (its base)
        for node in walk(source.statements):
            if isinstance(node, _DECLARING):
                self.declared.setdefault(node.name.text, node.name.span)

    def run(self) -> list:
        try:
            statements = list(self._statements(self.source.statements, _Env({}, {})))
        except _TooLarge:
            return []
        _check_references(statements, self.structural, self.report)
        return statements

    # --- statements, items and loops -------------------------------------------------------

    def _statements(self, statements, env: _Env) -> Iterator:
        for statement in statements:
            if isinstance(statement, ForLoop):
                yield from self._loop(statement, env, self._statements)
                continue
            if env.iteration:
                self._count(statement.span, env)
                if type(statement) in _ONCE:
                    self.report.error("E057", f"a model has one '{_ONCE[type(statement)]}' "
                                      "statement: it cannot be repeated in a for loop",
                                      env.span(statement.span),
                                      hint="write it outside the for loop")
                    continue
            if isinstance(statement, ParamStmt):
                yield from self._param(statement, env)
            else:
                yield self._node(statement, env)

    def _items(self, items, env: _Env) -> Iterator:
        for item in items:
            if isinstance(item, ForLoop):
                yield from self._loop(item, env, self._items)
                continue
            if env.iteration:
                self._count(item.span, env)
            yield self._node(item, env)

    def _loop(self, loop: ForLoop, env: _Env, body) -> Iterator:
        header = env.span(Span(loop.span.file, loop.span.line, loop.span.col,
                               loop.stop.span.end_line, loop.stop.span.end_col))
        if len(env.iteration) >= MAX_LOOP_DEPTH:
            self.report.error("E054", f"for loops nested more than {MAX_LOOP_DEPTH} deep",
                              header, hint="at most 4 for loops may be inside one another")
            return
        if not self._loop_variable_ok(loop.var, env):
            return
        try:
            start = whole(loop.start, env.values, self.structural, "a loop bound")
            stop = whole(loop.stop, env.values, self.structural, "a loop bound")
        except NotFixed as problem:
            self._not_fixed(problem, "E050", env)
            return
        if self.instances + max(stop - start + 1, 0) > MAX_INSTANCES:
            self._too_large(header)
        for value in range(start, stop + 1):
            self._count(header, env)
            yield from body(loop.body, env.entered(loop.var, value))

    def _loop_variable_ok(self, var: Ident, env: _Env) -> bool:
        name = var.text
        if name in KEYWORDS or name in FUNCTIONS or name in ("pi", "t", "ground", "system"):
            what = "a keyword" if name in KEYWORDS else "a function" if name in FUNCTIONS \
                else "the ground" if name == "ground" else "the system" if name == "system" \
                else "a built-in constant"
            self.report.error("E014", f"'{name}' is {what} and cannot name a loop variable",
                              env.span(var.span), hint="choose another name, e.g. i")
            return False
        first = env.spans.get(name) or self.declared.get(name) or \
            (self.structural[name].span if name in self.structural else None)
        if first is None:
            return True
        what = "the variable of an enclosing loop" if name in env.spans else \
            "a structural parameter" if name in self.structural else "a declared name"
        self.report.error("E056", f"loop variable '{name}' is already {what}",
                          env.span(var.span), hint="give the loop variable a name of its own",
                          notes=[f"'{name}' is defined at {at(first)}"])
        return False

    def _count(self, span: Span, env: _Env) -> None:
        self.instances += 1
        if self.instances > MAX_INSTANCES:
            self._too_large(env.span(span))

    def _too_large(self, span: Span) -> None:
        self.report.error("E054", f"the for loops repeat more than {MAX_INSTANCES} "
                          "iterations, statements and block items in all", span,
                          hint=f"a model expands to at most {MAX_INSTANCES} of them "
                          "(docs/language.md, Limits)")
        raise _TooLarge

    def _not_fixed(self, problem: NotFixed, code: str, env: _Env) -> None:
        if problem.message:
            self.report.error(problem.code or code, problem.message,
                              env.span(problem.node.span), hint=problem.hint)

    # --- parameters --------------------------------------------------------------------------

    def _param(self, statement: ParamStmt, env: _Env) -> Iterator[ParamStmt]:
        name = statement.name
        if not env.iteration and not name.indices and name.text in self.structural:
            return  # fixed now: its uses are replaced by its value
        if not isinstance(statement.value, (VectorLit, TupleLit)):
            yield self._node(statement, env)
            return
        values = statement.value
        items = (values.x, values.y) if isinstance(values, VectorLit) else values.items
        if not name.indices:
            self.report.error("E023", f"parameter '{name.text}' takes one value; a list of "
                              "values declares an array parameter", env.span(values.span),
                              hint=f"param {name.text}[{len(items)}] = (...)")
            return
        if len(name.indices) > 1:
            self.report.error("E053", "an array parameter has one index, its size",
                              env.span(name.span), hint=f"param {name.text}[{len(items)}] = "
                              "(...)")
            return
        try:
            size = whole(name.indices[0], env.values, self.structural, "an array size")
        except NotFixed as problem:
            self._not_fixed(problem, "E053", env)
            return
        if size != len(items):
            self.report.error("E053", f"array parameter '{name.text}[{size}]' has {size} "
                              f"element{'s' * (size != 1)}, but {len(items)} values are given",
                              env.span(values.span),
                              hint=f"give {size} values, or write {name.text}[{len(items)}]")
            return
        for k, item in enumerate(items, start=1):
            value = Quantity(item, values.unit, values.unit_span, item.span) \
                if values.unit else item
            yield ParamStmt(Ident(f"{name.text}[{k}]", env.span(name.span)),
                            self._node(value, env), env.span(statement.span))

    # --- nodes --------------------------------------------------------------------------------

    def _node(self, node, env: _Env):
        """`node` with indices computed, loop variables and structural parameters replaced
        and block items of inner loops expanded; spans tagged with the iteration."""
        if isinstance(node, tuple):
            return tuple(self._node(part, env) for part in node)
        if isinstance(node, Span):
            return env.span(node)
        if not is_dataclass(node):
            return node
        method = getattr(self, "_expand_" + type(node).__name__, None)
        if method is not None:
            return method(node, env)
        return type(node)(**{f.name: self._node(getattr(node, f.name), env)
                             for f in fields(node)})

    def _expand_Block(self, block: Block, env: _Env) -> Block:
        return Block(tuple(self._items(block.items, env)), env.span(block.span))

    def _expand_Ident(self, ident: Ident, env: _Env) -> Ident:
        text = ident.text
        for index in ident.indices:
            try:
                k = whole(index, env.values, self.structural, "an index")
            except NotFixed as problem:
                self._not_fixed(problem, "E051", env)
                k = "?"  # reported; a name with `[?]` is never looked up
            if k != "?" and k < 0:
                self.report.error("E051", f"an index is a whole number from 0, got {k}",
                                  env.span(index.span))
            text += f"[{k}]"
        if len(text) > MAX_NAME_LENGTH:
            self.report.error("E008", f"the name '{text}' is {len(text)} characters long with "
                              f"its indices; names have at most {MAX_NAME_LENGTH}",
                              env.span(ident.span), hint="use a shorter name")
        return Ident(text, env.span(ident.span))

    def _expand_NameRef(self, ref: NameRef, env: _Env):
        first = ref.parts[0]
        if len(ref.parts) == 1 and not first.indices:
            if first.text in env.values:
                return _literal(Fraction(env.values[first.text]), env.span(ref.span))
            if first.text in self.structural:
                try:
                    value = exact(ref, {}, self.structural)
                except NotFixed as problem:
                    self._not_fixed(problem, "E055", env)
                    value = Fraction(0)
                return _literal(value, env.span(ref.span))
        return NameRef(tuple(self._expand_Ident(part, env) for part in ref.parts),
                       env.span(ref.span))

    def _expand_ListPick(self, pick: ListPick, env: _Env):
        try:
            k = pick_index(pick, env.values, self.structural)
        except NotFixed as problem:
            self._not_fixed(problem, "E051", env)
            k = 1
        return self._node(pick.values[k - 1], env)

    def _expand_TupleLit(self, values: TupleLit, env: _Env) -> VectorLit:
        if self.spatial and len(values.items) == 3:
            x, y, z = (self._node(item, env) for item in values.items)
            return VectorLit(x, y, values.unit, env.span(values.unit_span)
                             if values.unit_span else None, env.span(values.span), z)
        if self.spatial:
            self.report.error("E023", f"a vector of a spatial model has three components "
                              f"(x, y, z), got {len(values.items)} values",
                              env.span(values.span),
                              hint="a list of more values is the value of an array parameter")
            return VectorLit(values.items[0], values.items[1], values.unit, values.unit_span,
                             env.span(values.span))
        self.report.error("E023", f"a vector has two components (x, y), got "
                          f"{len(values.items)} values", env.span(values.span),
                          hint="a list of more values is the value of an array parameter")
        return VectorLit(values.items[0], values.items[1], values.unit, values.unit_span,
                         env.span(values.span))

    def _fold(self, node, env: _Env):
        """A sign, operation or call of whole numbers, loop variables and structural
        parameters, as the number it is (`(-1)^i` is -1 in iteration i = 3); anything else
        rebuilt part by part."""
        if _foldable(node, env.values, self.structural):
            try:
                return _literal(exact(node, env.values, self.structural), env.span(node.span))
            except NotFixed:
                pass  # reported where it is rebuilt, or not a fixed value at all
        return type(node)(**{f.name: self._node(getattr(node, f.name), env)
                             for f in fields(node)})

    _expand_BinaryOp = _expand_UnaryOp = _expand_CallExpr = _fold


def _foldable(node, loop: dict[str, int], structural: dict[str, Structural]) -> bool:
    """True when `node` uses a loop variable or a structural parameter and otherwise only
    whole numbers written without a unit."""
    uses = False
    for part in walk((node,)):
        if isinstance(part, NumberLit) and not part.text.isdigit():
            return False
        if isinstance(part, (Quantity, ListPick)):
            return False
        if isinstance(part, NameRef):
            name = part.parts[0].text
            if len(part.parts) > 1 or part.parts[0].indices or \
                    (name not in loop and name not in structural):
                return False
            uses = True
    return uses


def _literal(value: Fraction, span: Span):
    """The number `value` as a syntax node: a NumberLit, signed with a unary minus."""
    size = abs(value)
    text = str(size.numerator) if size.denominator == 1 else repr(float(size))
    number = NumberLit(float(size), text, span)
    return UnaryOp("-", number, span) if value < 0 else number


# --- references to indexed names ------------------------------------------------------------


def _check_references(statements: list, structural: dict[str, Structural],
                      report: Reporter) -> None:
    """E052 for a reference to an element an index does not name (`panel[13]` when panel
    is declared for 1..12, `rod[1]` when rod has no index, `m` for the array m[1..3]);
    E011 for a declared name that is a structural parameter."""
    declared = {s.name.text: s.name.span for s in statements if isinstance(s, _DECLARING)}
    families: dict[str, set[int]] = defaultdict(set)
    for name in declared:
        if "[" in name and "[?]" not in name:
            base, rest = name.split("[", 1)
            families[base].add(int(rest.split("]", 1)[0]))
    for name, span in declared.items():
        if name in structural:
            report.error("E011", f"duplicate name '{name}': already used by structural "
                         f"parameter '{name}'", span,
                         notes=[f"first defined at {at(structural[name].span)}"])
    for name, span in _references(statements):
        if name in declared or "[?]" in name:
            continue
        base = name.split("[", 1)[0]
        if "[" in name and base in families:
            report.error("E052", f"there is no '{name}': '{base}' is declared with "
                         f"indices {_indices(families[base])}", span)
        elif "[" in name and (base in declared or base in structural):
            report.error("E052", f"'{base}' has no index: it is declared as '{base}'", span,
                         hint=f"write {base}")
        elif "[" not in name and name in families:
            first = min(families[name])
            report.error("E052", f"'{name}' is indexed: name one element, e.g. "
                         f"{name}[{first}]", span,
                         hint=f"'{name}' is declared with indices {_indices(families[name])}")


def _references(statements: list) -> Iterator[tuple[str, Span]]:
    """Each name that refers to a declared element or parameter, with its span."""
    for statement in statements:
        if isinstance(statement, InitialStmt):
            for item in statement.block.items:
                if not isinstance(item, ForLoop) and hasattr(item, "sub"):
                    yield item.name.text, item.name.span
        if isinstance(statement, InputStmt):
            yield statement.target.text, statement.target.span
    for node in walk(statements):
        if isinstance(node, NameRef):
            yield node.parts[0].text, node.parts[0].span
        elif isinstance(node, AttachmentRef):
            yield node.member.text, node.member.span


def _indices(found: set[int]) -> str:
    """'1..12', or '1, 3, 5' when they are not consecutive."""
    ordered = sorted(found)
    if ordered == list(range(ordered[0], ordered[-1] + 1)) and len(ordered) > 2:
        return f"{ordered[0]}..{ordered[-1]}"
    shown = ", ".join(map(str, ordered[:8]))
    return shown + (", ..." if len(ordered) > 8 else "")
