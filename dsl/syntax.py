"""The syntax tree of a .dep file: frozen dataclasses with spans, built from lark's parse tree.

This is what the text says, nothing more: names are strings, numbers are as written, units
are their text. `resolve` turns it into the checked IR. The Transformer only builds nodes;
every check happens later (lark would wrap exceptions raised here in VisitError).
"""

from __future__ import annotations

from dataclasses import dataclass

from lark import Discard, Token, Transformer, v_args

from .ir import Span


# The words that start statements, and all keywords of the grammar.
STATEMENT_WORDS = ("model", "param", "gravity", "ground", "bar", "body", "beam", "particle",
                   "hinge", "slider", "weld", "free", "ball", "cylindrical", "universal",
                   "spring", "cable", "initial", "simulate", "output", "input")
KEYWORDS = frozenset(STATEMENT_WORDS + ("joins", "to", "point", "for"))
# keywords the syntax tree keeps
KIND_WORDS = ("bar", "body", "beam", "particle", "hinge", "slider", "weld", "free", "ball",
              "cylindrical", "universal", "spring")
# Words of the input statement only (`input T torque on h1`): keywords there, names elsewhere.
INPUT_WORDS = ("torque", "force", "on")
# The word of the for statement only (`for i in 1..N`): a keyword there, a name elsewhere.
FOR_WORDS = ("in",)
# The word of the model statement only (`model arm spatial`): a keyword there, a name elsewhere.
MODEL_WORDS = ("spatial",)


@dataclass(frozen=True, slots=True)
class Ident:
    """A name as written; `indices` are its index expressions (`panel[i-1]`), () once
    repetition has expanded it into the plain name `panel[3]` (dsl/repeat.py)."""

    text: str
    span: Span
    indices: tuple[AstExpr, ...] = ()


# --- expressions ------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class NumberLit:
    value: float
    text: str
    span: Span


@dataclass(frozen=True, slots=True)
class NameRef:
    """`x`, `h1.rate`, `rod.b.x`: a name with optional dotted parts."""

    parts: tuple[Ident, ...]
    span: Span

    @property
    def dotted(self) -> str:
        return ".".join(p.text for p in self.parts)


@dataclass(frozen=True, slots=True)
class UnaryOp:
    op: str  # "-" or "+"
    arg: AstExpr
    span: Span


@dataclass(frozen=True, slots=True)
class BinaryOp:
    op: str  # "+", "-", "*", "/", "^"
    left: AstExpr
    right: AstExpr
    span: Span


@dataclass(frozen=True, slots=True)
class CallExpr:
    func: Ident
    args: tuple[AstExpr, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class Quantity:
    """A value followed by a unit: `1.09 m`, `(L/2) m`, `0.01835^2 N*m/rad`."""

    value: AstExpr
    unit: str
    unit_span: Span
    span: Span


@dataclass(frozen=True, slots=True)
class ListPick:
    """`(1.965, 1.965, 1.936)[j]`: the value at a fixed index (from 1), picked when the
    model is checked."""

    values: tuple[AstExpr, ...]
    index: AstExpr
    span: Span


AstExpr = NumberLit | NameRef | UnaryOp | BinaryOp | CallExpr | Quantity | ListPick


@dataclass(frozen=True, slots=True)
class VectorLit:
    """`(x, y)`, or `(x, y, z)` in a spatial model, with an optional unit applying to every
    component."""

    x: AstExpr
    y: AstExpr
    unit: str | None
    unit_span: Span | None
    span: Span
    z: AstExpr | None = None  # a spatial model's third component (dsl/repeat.py)

    @property
    def components(self) -> tuple[AstExpr, ...]:
        return (self.x, self.y) if self.z is None else (self.x, self.y, self.z)


@dataclass(frozen=True, slots=True)
class TupleLit:
    """`(a, b, c) UNIT`: three or more values, the value of an array parameter."""

    items: tuple[AstExpr, ...]
    unit: str | None
    unit_span: Span | None
    span: Span


@dataclass(frozen=True, slots=True)
class ForLoop:
    """`for i in start..stop { ... }` around statements, or around the items of a block:
    `body` repeated for i = start, start + 1, ..., stop (none when stop < start)."""

    var: Ident
    start: AstExpr
    stop: AstExpr
    body: tuple
    span: Span


# --- block items and statements ---------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class AttributeItem:
    """`name = value` or `name.sub = value` (e.g. `h1.rate = 0 rad/s` in `initial`)."""

    name: Ident
    sub: Ident | None
    value: AstExpr | VectorLit | TupleLit
    span: Span


@dataclass(frozen=True, slots=True)
class PointItem:
    name: Ident
    value: VectorLit
    span: Span


@dataclass(frozen=True, slots=True)
class Block:
    items: tuple[AttributeItem | PointItem | ForLoop, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class ModelStmt:
    name: Ident
    description: str
    span: Span
    spatial: bool = False  # `model NAME spatial "..."`: a 3-D model


@dataclass(frozen=True, slots=True)
class ParamStmt:
    name: Ident
    value: AstExpr | VectorLit | TupleLit  # a vector or tuple: an array parameter
    span: Span


@dataclass(frozen=True, slots=True)
class GravityStmt:
    value: VectorLit
    span: Span


@dataclass(frozen=True, slots=True)
class GroundStmt:
    block: Block
    span: Span


@dataclass(frozen=True, slots=True)
class MemberStmt:
    kind: str  # "bar", "body", "beam" or "particle"
    name: Ident
    block: Block
    span: Span


@dataclass(frozen=True, slots=True)
class AttachmentRef:
    member: Ident
    point: Ident
    span: Span


@dataclass(frozen=True, slots=True)
class JointStmt:
    """A connector between two member points: a joint (hinge, slider, weld, free) or a
    point-to-point spring-damper."""

    kind: str  # "hinge", "slider", "weld", "free", "ball", "cylindrical", "universal", "spring"
    name: Ident
    a: AttachmentRef
    b: AttachmentRef
    block: Block | None
    span: Span


@dataclass(frozen=True, slots=True)
class CableStmt:
    name: Ident
    block: Block
    span: Span


@dataclass(frozen=True, slots=True)
class InitialStmt:
    block: Block
    span: Span


@dataclass(frozen=True, slots=True)
class SimulateStmt:
    block: Block
    span: Span


@dataclass(frozen=True, slots=True)
class OutputStmt:
    name: Ident
    value: AstExpr
    span: Span


@dataclass(frozen=True, slots=True)
class InputStmt:
    name: Ident
    kind: str  # "torque" or "force"
    target: Ident  # a hinge (torque) or a member (force)
    point: Ident | None  # force: the member's point
    default: "AstExpr | VectorLit | None"
    span: Span


Statement = ModelStmt | ParamStmt | GravityStmt | GroundStmt | MemberStmt | JointStmt \
    | CableStmt | InitialStmt | SimulateStmt | OutputStmt | InputStmt | ForLoop


@dataclass(frozen=True, slots=True)
class SourceFile:
    filename: str
    statements: tuple[Statement, ...]


# --- lark tree -> syntax tree -----------------------------------------------------------------


@v_args(meta=True)
class ToSyntax(Transformer):
    """Builds the syntax tree; one method per grammar rule, no checks."""

    def __init__(self, filename: str) -> None:
        super().__init__()
        self.filename = filename

    def _span(self, meta) -> Span:
        return Span(self.filename, meta.line, meta.column, meta.end_line, meta.end_column)

    def __default_token__(self, token: Token):
        """Keyword tokens say nothing the rule does not, except the element kinds."""
        if token.type.lower() in KEYWORDS and token.lower() not in KIND_WORDS:
            return Discard
        return token

    def _ident(self, token: Token | Ident) -> Ident:
        if isinstance(token, Ident):
            return token
        return Ident(str(token), Span(self.filename, token.line, token.column,
                                      token.end_line, token.end_column))

    def start(self, meta, children) -> SourceFile:
        return SourceFile(self.filename, tuple(children))

    # statements
    def model_stmt(self, meta, children) -> ModelStmt:
        name, *rest = children
        spatial = bool(rest) and isinstance(rest[0], Token) and rest[0].type == "SPATIAL"
        description = str(rest[-1])[1:-1] if rest and rest[-1].type == "STRING" else ""
        return ModelStmt(self._ident(name), description, self._span(meta), spatial)

    def param_stmt(self, meta, children) -> ParamStmt:
        return ParamStmt(self._ident(children[0]), children[1], self._span(meta))

    def gravity_stmt(self, meta, children) -> GravityStmt:
        return GravityStmt(children[0], self._span(meta))

    def ground_stmt(self, meta, children) -> GroundStmt:
        return GroundStmt(children[0], self._span(meta))

    def member_stmt(self, meta, children) -> MemberStmt:
        kind, name, block = children
        return MemberStmt(str(kind), self._ident(name), block, self._span(meta))

    def joint_stmt(self, meta, children) -> JointStmt:
        kind, name, a, b = children[:4]
        block = children[4] if len(children) > 4 else None
        return JointStmt(str(kind), self._ident(name), a, b, block, self._span(meta))

    def cable_stmt(self, meta, children) -> CableStmt:
        return CableStmt(self._ident(children[0]), children[1], self._span(meta))

    def initial_stmt(self, meta, children) -> InitialStmt:
        return InitialStmt(children[0], self._span(meta))

    def simulate_stmt(self, meta, children) -> SimulateStmt:
        return SimulateStmt(children[0], self._span(meta))

    def output_stmt(self, meta, children) -> OutputStmt:
        return OutputStmt(self._ident(children[0]), children[1], self._span(meta))

    def input_stmt(self, meta, children) -> InputStmt:
        name, kind, on, target, *rest = children
        point = rest.pop(0) if rest and isinstance(rest[0], Ident) else None
        default = rest[0] if rest else None
        return InputStmt(self._ident(name), str(kind), self._ident(target), point, default,
                         self._span(meta))

    def for_stmt(self, meta, children) -> ForLoop:
        var, _in, start, stop, *body = children
        return ForLoop(self._ident(var), start, stop, tuple(body), self._span(meta))

    for_item = for_stmt

    def ixname(self, meta, children) -> Ident:
        name, *indices = children
        if not indices:
            return self._ident(name)
        return Ident(str(name), self._span(meta), tuple(indices))

    def attachment(self, meta, children) -> AttachmentRef:
        member, point = children
        return AttachmentRef(self._ident(member), self._ident(point), self._span(meta))

    # blocks
    def block(self, meta, children) -> Block:
        return Block(tuple(children), self._span(meta))

    def attribute(self, meta, children) -> AttributeItem:
        *names, value = children
        sub = self._ident(names[1]) if len(names) > 1 else None
        return AttributeItem(self._ident(names[0]), sub, value, self._span(meta))

    def point(self, meta, children) -> PointItem:
        return PointItem(self._ident(children[0]), children[1], self._span(meta))

    def values(self, meta, children) -> tuple:
        return tuple(children)

    def vector(self, meta, children) -> VectorLit | TupleLit:
        values = children[0]
        unit = children[1] if len(children) > 1 else None
        unit_span = self._ident(unit).span if unit is not None else None
        unit_text = str(unit) if unit is not None else None
        if len(values) == 2:
            return VectorLit(values[0], values[1], unit_text, unit_span, self._span(meta))
        return TupleLit(values, unit_text, unit_span, self._span(meta))

    def pick(self, meta, children) -> ListPick:
        values, index = children
        return ListPick(values, index, self._span(meta))

    # expressions
    def number(self, meta, children) -> NumberLit:
        token = children[0]
        return NumberLit(float(token), str(token), self._span(meta))

    def ref(self, meta, children) -> NameRef:
        return NameRef(tuple(self._ident(t) for t in children), self._span(meta))

    def call(self, meta, children) -> CallExpr:
        func, *args = children
        return CallExpr(self._ident(func), tuple(args), self._span(meta))

    def with_unit(self, meta, children) -> Quantity:
        value, unit = children
        return Quantity(value, str(unit), self._ident(unit).span, self._span(meta))

    def _binary(op: str):  # noqa: N805 - builds one method per operator
        def method(self, meta, children) -> BinaryOp:
            left, right = children
            return BinaryOp(op, left, right, self._span(meta))
        return method

    add = _binary("+")
    sub = _binary("-")
    mul = _binary("*")
    div = _binary("/")
    pow = _binary("^")

    def neg(self, meta, children) -> UnaryOp:
        return UnaryOp("-", children[0], self._span(meta))

    def pos(self, meta, children) -> UnaryOp:
        return UnaryOp("+", children[0], self._span(meta))
