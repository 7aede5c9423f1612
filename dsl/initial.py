"""`initial { h1 = 30 deg; h1.rate = 0 rad/s; s1 = 0.2 m; fly.x = 2 m }`: joint values at
t = 0.

Each value becomes a parameter entry (`h1.initial_angle`, `h1.initial_rate`,
`s1.initial_position`, `s1.initial_rate`, `fly.initial_x`, ..., `fly.initial_omega`); values
not given are 0.
"""

from __future__ import annotations

from .attributes import AttrSpec, AttributeReader
from .errors import at, did_you_mean, join_names
from .ir import Dim, Expr, Span
from .names import SymbolTable
from .syntax import AttributeItem, InitialStmt, PointItem
from .units import ANGLE, LENGTH

_RATE, _VELOCITY = Dim(angle=1, time=-1), Dim(length=1, time=-1)
# (joint kind, property) -> (entry suffix, dimension)
_VALUES: dict[tuple[str, str], tuple[str, Dim]] = {
    ("hinge", ""): ("initial_angle", ANGLE),
    ("hinge", "rate"): ("initial_rate", _RATE),
    ("slider", ""): ("initial_position", LENGTH),
    ("slider", "rate"): ("initial_rate", _VELOCITY),
    ("free", "x"): ("initial_x", LENGTH), ("free", "y"): ("initial_y", LENGTH),
    ("free", "angle"): ("initial_angle", ANGLE), ("free", "vx"): ("initial_vx", _VELOCITY),
    ("free", "vy"): ("initial_vy", _VELOCITY), ("free", "omega"): ("initial_omega", _RATE),
}
# A spatial model's free joints and ball joints (ir.SPATIAL_FREE_VALUES, ir.TURN_VALUES).
_SPATIAL_VALUES = {key: value for key, value in _VALUES.items()
                   if key[0] in ("hinge", "slider")}
_SPATIAL_VALUES.update({
    ("free", "x"): ("initial_x", LENGTH), ("free", "y"): ("initial_y", LENGTH),
    ("free", "z"): ("initial_z", LENGTH), ("free", "vx"): ("initial_vx", _VELOCITY),
    ("free", "vy"): ("initial_vy", _VELOCITY), ("free", "vz"): ("initial_vz", _VELOCITY),
    ("free", "wx"): ("initial_wx", _RATE), ("free", "wy"): ("initial_wy", _RATE),
    ("free", "wz"): ("initial_wz", _RATE), ("ball", "wx"): ("initial_wx", _RATE),
    ("ball", "wy"): ("initial_wy", _RATE), ("ball", "wz"): ("initial_wz", _RATE),
    ("cylindrical", ""): ("initial_angle", ANGLE), ("cylindrical", "rate"): ("initial_rate", _RATE),
    ("cylindrical", "position"): ("initial_position", LENGTH),
    ("cylindrical", "velocity"): ("initial_velocity", _VELOCITY),
    ("universal", "angle_a"): ("initial_angle_a", ANGLE),
    ("universal", "rate_a"): ("initial_rate_a", _RATE),
    ("universal", "angle_b"): ("initial_angle_b", ANGLE),
    ("universal", "rate_b"): ("initial_rate_b", _RATE),
})
_HOW = {"hinge": "{n} = ... or {n}.rate = ...", "slider": "{n} = ... or {n}.rate = ...",
        "free": "{n}.x, {n}.y, {n}.angle, {n}.vx, {n}.vy or {n}.omega = ...",
        "ball": "{n}.wx, {n}.wy or {n}.wz = ... (its orientation is its members')"}
_SPATIAL_HOW = {**_HOW, "free": "{n}.x, {n}.y, {n}.z, {n}.vx, {n}.vy, {n}.vz, {n}.wx, {n}.wy "
                                "or {n}.wz = ... (its orientation is its members')",
                "cylindrical": "{n} = ... (its angle), {n}.rate, {n}.position or {n}.velocity "
                               "= ...",
                "universal": "{n}.angle_a, {n}.rate_a, {n}.angle_b or {n}.rate_b = ..."}


class InitialValues:
    """Initial values read so far, keyed by (joint name, entry suffix)."""

    def __init__(self) -> None:
        self.values: dict[tuple[str, str], Expr | None] = {}
        self.spans: dict[tuple[str, str], Span] = {}

    def get(self, joint: str, suffix: str) -> Expr | None:
        return self.values.get((joint, suffix))

    def span_of(self, joint: str, suffix: str | None = None) -> Span | None:
        """Where the first initial value of `joint` (of `suffix`, if given) was given."""
        found = [span for (name, kind), span in self.spans.items()
                 if name == joint and suffix in (None, kind)]
        return min(found, key=lambda s: (s.line, s.col)) if found else None

    def read(self, statement: InitialStmt, symbols: SymbolTable,
             reader: AttributeReader) -> None:
        for item in statement.block.items:
            if isinstance(item, PointItem):
                reader.report.error("E020", "initial takes joint values, not points",
                                    item.span, hint="e.g. h1 = 30 deg")
                continue
            self._read_item(item, symbols, reader)

    def _read_item(self, item: AttributeItem, symbols: SymbolTable,
                   reader: AttributeReader) -> None:
        report = reader.report
        name = item.name.text
        symbol = symbols.get(name)
        if symbol is None:
            joints = symbols.names_of_kind(*_SPATIAL_HOW)
            report.error("E010", f"unknown name '{name}'", item.name.span,
                         hint=did_you_mean(name, joints) or f"joints: {join_names(joints)}")
            return
        if symbol.kind not in _SPATIAL_HOW:
            report.error("E045", f"{symbol.describe()} has no initial value: initial values "
                         "are given for hinges, sliders, free, ball, cylindrical and universal "
                         "joints", item.name.span,
                         hint=_not_a_joint_hint(symbol))
            return
        prop = item.sub.text if item.sub else ""
        values, how = (_SPATIAL_VALUES, _SPATIAL_HOW) if reader.spatial else (_VALUES, _HOW)
        if (symbol.kind, prop) not in values:
            report.error("E019", f"{symbol.describe()} has no initial value "
                         f"'{prop or name}'", (item.sub or item.name).span,
                         hint="write " + how[symbol.kind].format(n=name))
            return
        suffix, dim = values[(symbol.kind, prop)]
        key = (name, suffix)
        if key in self.spans:
            report.error("E022", f"initial value '{name}{'.' + prop if prop else ''}' is "
                         "given twice", item.name.span,
                         notes=[f"first given at {at(self.spans[key])}"])
            return
        self.spans[key] = item.span
        spec = AttrSpec(f"initial value of {name}{'.' + prop if prop else ''}", dim)
        self.values[key] = reader.scalar(item, spec, f"{name}.{suffix}")


def _not_a_joint_hint(symbol) -> str:
    if symbol.kind in ("bar", "body", "beam", "particle"):
        return (f"to start {symbol.describe()} moving on its own, join it to the ground by a "
                f"free joint, `free {symbol.name}_motion joins ground.origin to "
                f"{symbol.name}.{'a' if symbol.kind == 'beam' else 'cm'}`, and give "
                f"{symbol.name}_motion.x, .y, .angle, .vx, .vy, .omega here")
    if symbol.kind == "weld":
        return "a weld holds its members together: it has no value of its own"
    return ""
