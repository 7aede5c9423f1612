"""Element attributes: which each kind takes, reading a block, and the parameter vector.

An attribute written as a plain constant (`mass = 2.222 kg`) becomes an entry of the
parameter vector named `element.attribute` (`yoke.mass`) and the element refers to it by
ParamRef, so it can be changed at run time. An attribute written with parameters
(`inertia = m * L^2 / 12`) keeps its expression and is recorded as a DerivedName.
"""

from __future__ import annotations

from dataclasses import dataclass

from .errors import Reporter, at, did_you_mean, join_names
from .evaluate import EvaluationError, Typed, evaluate, param_indices
from .expressions import Context, ExprResolver, warn_plain_angle
from .ir import DerivedName, Dim, Expr, Limit, Param, ParamKind, ParamRef, Span
from .limits import violation
from .syntax import AstExpr, AttributeItem, Block, NumberLit, PointItem, Quantity, VectorLit
from .units import ANGLE, LENGTH, MASS, NONE, TIME, TORQUE, describe, dim_div, si_text


@dataclass(frozen=True, slots=True)
class AttrSpec:
    """An attribute of an element kind. dim None: read by dedicated code (angle, angles,
    elements, axis). limit: "positive", "nonnegative" or "". default: the SI value an
    attribute takes when the model leaves it out (None: it is absent then). meaning: one line
    for the language reference (docs/language.md shows the hinge's from here). column: a hinge
    property the integrator applies itself, its column of a generated model's
    hinge_properties(p) (None: derived into the model's forces, or not a hinge's)."""

    name: str
    dim: Dim | None
    required: bool = False
    limit: str = ""
    default: float | None = None
    meaning: str = ""
    column: int | None = None

    @property
    def unit(self) -> str:
        """The SI unit text ("rad" for a hinge angle, read by dedicated code)."""
        return si_text(self.dim) if self.dim is not None else "rad" if self.name == "angle" else ""


_STIFFNESS = Dim(mass=1, length=2, time=-2, angle=-1)
_DAMPING = Dim(mass=1, length=2, time=-1, angle=-1)
_LINEAR_STIFFNESS = Dim(mass=1, time=-2)  # N/m
_LINEAR_DAMPING = Dim(mass=1, time=-1)  # N*s/m
_FORCE = Dim(mass=1, length=1, time=-2)

SPECS: dict[str, tuple[AttrSpec, ...]] = {
    # A spatial model's `inertia` is a vector of moments, `products_of_inertia` another,
    # `orientation` and `principal_axes` products of turns (read by dedicated code:
    # dsl/members.py).
    "bar": (AttrSpec("length", LENGTH, True, "positive"), AttrSpec("mass", MASS, True, "positive"),
            AttrSpec("inertia", Dim(mass=1, length=2), True, "positive"),
            AttrSpec("orientation", None), AttrSpec("principal_axes", None),
            AttrSpec("products_of_inertia", None)),
    "body": (AttrSpec("mass", MASS, True, "positive"),
             AttrSpec("inertia", Dim(mass=1, length=2), True, "positive"),
             AttrSpec("orientation", None), AttrSpec("principal_axes", None),
             AttrSpec("products_of_inertia", None)),
    "particle": (AttrSpec("mass", MASS, True, "positive"),),
    "beam": (AttrSpec("length", LENGTH, True, "positive"),
             AttrSpec("EI", Dim(mass=1, length=3, time=-2), True, "positive"),
             AttrSpec("EA", Dim(mass=1, length=1, time=-2), True, "positive"),
             AttrSpec("mass_per_length", Dim(mass=1, length=-1), True, "positive"),
             AttrSpec("elements", None, True), AttrSpec("damping", TIME, False, "nonnegative")),
    # The one definition of a hinge's attributes: the language reads them, the IR carries them
    # (dsl/ir.py, Hinge), codegen makes the columns of hinge_properties(p) and the C header's
    # enum dep_hinge_property from those with a column (python -m
    # depsim.codegen.interface_header), and docs/language.md shows this table (tests compare).
    "hinge": (
        AttrSpec("angle", None, meaning="the hinge angle, above"),
        AttrSpec("axis", None, meaning="spatial models: the axis, a direction in member A's "
                                       "frame (required there)"),
        AttrSpec("stiffness", _STIFFNESS, False, "nonnegative",
                 meaning="spring: torque on theta is `preload - stiffness * theta`"),
        AttrSpec("preload", TORQUE, meaning="spring torque at theta = 0"),
        AttrSpec("friction", TORQUE, False, "nonnegative", column=5,
                 meaning="Coulomb friction `-friction * tanh(theta_rate / slip_rate)`"),
        AttrSpec("static_friction", TORQUE, False, "nonnegative", column=6,
                 meaning="stick-slip model when given (at least `friction`)"),
        AttrSpec("slip_rate", Dim(angle=1, time=-1), False, "positive", default=1e-3, column=7,
                 meaning="regularisation of friction"),
        AttrSpec("damping", _DAMPING, False, "nonnegative",
                 meaning="viscous `-damping * theta_rate`"),
        AttrSpec("latch", ANGLE, column=0,
                 meaning="the hinge locks when theta first reaches this angle"),
        AttrSpec("latch_stiffness", _STIFFNESS, False, "positive", column=1,
                 meaning="a flexible latch (rigid without it); needs `latch` (E028)"),
        AttrSpec("latch_damping", _DAMPING, False, "nonnegative", column=2,
                 meaning="damping of a flexible latch; needs `latch` (E028)"),
        AttrSpec("stop_min", ANGLE, column=3, meaning="one-sided lower limit of theta"),
        AttrSpec("stop_max", ANGLE, column=4,
                 meaning="one-sided upper limit of theta, above `stop_min` (E028)"),
        AttrSpec("release", TIME, False, "nonnegative", column=8,
                 meaning="held locked from t = 0 until this time, then released (a "
                         "hold-down)")),
    # A slider has the hinge's toolkit along its axis, on its displacement s (m) with linear
    # units; the integrator applies those with a column as it applies a hinge's (the same
    # columns: a slider with any of them is one more entry of the generated model's hinge
    # tables, docs/language.md, slider).
    "slider": (
        AttrSpec("axis", None, True, meaning="the direction of travel in member A's frame"),
        AttrSpec("stiffness", _LINEAR_STIFFNESS, False, "nonnegative",
                 meaning="spring: force along the axis is `preload - stiffness * s`"),
        AttrSpec("preload", _FORCE, meaning="spring force at s = 0"),
        AttrSpec("friction", _FORCE, False, "nonnegative", column=5,
                 meaning="Coulomb friction `-friction * tanh(s_rate / slip_rate)`"),
        AttrSpec("static_friction", _FORCE, False, "nonnegative", column=6,
                 meaning="stick-slip model when given (at least `friction`)"),
        AttrSpec("slip_rate", Dim(length=1, time=-1), False, "positive", default=1e-3,
                 column=7, meaning="regularisation of friction (its entry only with friction)"),
        AttrSpec("damping", _LINEAR_DAMPING, False, "nonnegative",
                 meaning="viscous `-damping * s_rate`"),
        AttrSpec("latch", LENGTH, column=0,
                 meaning="the slider locks when s first reaches this position"),
        AttrSpec("latch_stiffness", _LINEAR_STIFFNESS, False, "positive", column=1,
                 meaning="a flexible latch (rigid without it); needs `latch` (E028)"),
        AttrSpec("latch_damping", _LINEAR_DAMPING, False, "nonnegative", column=2,
                 meaning="damping of a flexible latch; needs `latch` (E028)"),
        AttrSpec("stop_min", LENGTH, column=3, meaning="one-sided lower limit of s"),
        AttrSpec("stop_max", LENGTH, column=4,
                 meaning="one-sided upper limit of s, above `stop_min` (E028)"),
        AttrSpec("release", TIME, False, "nonnegative", column=8,
                 meaning="held locked from t = 0 until this time, then released (a "
                         "hold-down)")),
    "weld": (AttrSpec("angle", ANGLE, meaning="the relative angle it holds, angle(B) - "
                                              "angle(A); default 0"),),
    "free": (),
    "ball": (),
    "cylindrical": (AttrSpec("axis", None, True,
                             meaning="the axis, a direction in member A's frame"),),
    "universal": (AttrSpec("axis_a", None, True,
                           meaning="the cross-piece's axis in member A, in A's frame"),
                  AttrSpec("axis_b", None, True,
                           meaning="its axis in member B, in B's frame: normal to axis_a "
                                   "where the members' orientations place them")),
    # A point-to-point spring-damper (ir.Spring); `acts` is read by dedicated code.
    "spring": (AttrSpec("stiffness", _LINEAR_STIFFNESS, False, "nonnegative",
                        meaning="force per length change: `-stiffness (L - free_length)`"),
               AttrSpec("free_length", LENGTH, False, "nonnegative",
                        meaning="the length at which the spring's force is its preload"),
               AttrSpec("preload", _FORCE, meaning="the force at the free length, positive "
                                                   "pushing the points apart"),
               AttrSpec("damping", _LINEAR_DAMPING, False, "nonnegative",
                        meaning="viscous force `-damping dL/dt`"),
               AttrSpec("acts", None, meaning="`push`: only while shorter than its free "
                                              "length, never pulling (a kick-off spring); "
                                              "`pull`: only while longer, never pushing (a "
                                              "cable); default both")),
    "cable": (AttrSpec("stiffness", _STIFFNESS, True, "nonnegative"),
              AttrSpec("angles", None, True)),
    "simulate": (AttrSpec("t_end", TIME, False, "positive"),
                 AttrSpec("tol", NONE, False, "positive"),
                 AttrSpec("dt_out", TIME, False, "positive")),
    "ground": (),
}
_POINTS_ALLOWED = ("bar", "body", "ground")
# What to say when a block that takes no attributes is given one.
_NO_ATTRIBUTES = {"free": "a free joint takes no attributes: give its initial position and "
                          "motion in `initial` (NAME.x, NAME.y, NAME.angle, NAME.vx, NAME.vy, "
                          "NAME.omega)",
                  "ball": "a ball joint takes no attributes: give its initial angular velocity "
                          "in `initial` (NAME.wx, NAME.wy, NAME.wz)"}

# The hinge attributes the integrator applies itself (Coulomb friction, latches, hard stops,
# stick-slip): the columns of a generated model's hinge_properties(p), in column order.
HINGE_PROPERTIES = tuple(spec.name for spec in sorted(
    (spec for spec in SPECS["hinge"] if spec.column is not None), key=lambda s: s.column))
assert sorted(s.column for s in SPECS["hinge"] if s.column is not None) == \
    list(range(len(HINGE_PROPERTIES))), "hinge property columns are numbered 0, 1, 2, ..."


# A slider's attributes with a column are the hinge's of that column, in linear units.
assert all(spec.name == HINGE_PROPERTIES[spec.column] for spec in SPECS["slider"]
           if spec.column is not None), "a slider's property columns are the hinge's"
# The joints whose attributes the integrator may apply itself (an entry of the hinge tables).
TOOLKIT_JOINTS = ("hinge", "slider")


def hinge_attribute_table(kind: str = "hinge") -> str:
    """The attributes of a hinge (or of a slider: kind "slider") as docs/language.md shows
    them (a Markdown table), from SPECS."""
    assert kind in TOOLKIT_JOINTS, kind
    lines = ["| attribute | unit | meaning |", "|---|---|---|"]
    for spec in SPECS[kind]:
        notes = [spec.meaning]
        if spec.limit:
            notes.append({"positive": "> 0", "nonnegative": ">= 0"}[spec.limit])
        if spec.default is not None:
            notes.append(f"default {spec.default:g} {spec.unit}")
        lines.append(f"| `{spec.name}` | {spec.unit} | {'; '.join(n for n in notes if n)} |")
    return "\n".join(lines) + "\n"


def read_block(block: Block | None, kind: str, owner: str, owner_span: Span,
               report: Reporter) -> dict[str, AttributeItem]:
    """The block's attributes by name, after reporting unknown, repeated and missing ones.
    Points are left to the caller."""
    specs = {spec.name: spec for spec in SPECS[kind]}
    found: dict[str, AttributeItem] = {}
    for item in block.items if block is not None else ():
        if isinstance(item, PointItem):
            if kind not in _POINTS_ALLOWED:
                hint = {"beam": "a beam's points are its ends a and b",
                        "particle": "a particle is a point: its one point is cm (use a body "
                                    "for a member with points)"}.get(kind, "")
                report.error("E020", f"{owner} cannot have points", item.span, hint=hint)
            continue
        name = item.name.text if item.sub is None else f"{item.name.text}.{item.sub.text}"
        if name not in specs:
            hint = did_you_mean(name, specs) or f"{owner} takes: {join_names(specs)}" \
                if specs else _NO_ATTRIBUTES.get(kind, f"{owner} takes only points")
            report.error("E020", f"unknown attribute '{name}' for {owner}", item.name.span,
                         hint=hint)
        elif name in found:
            report.error("E022", f"attribute '{name}' of {owner} is given twice", item.name.span,
                         notes=[f"first given at {at(found[name].span)}"])
        else:
            found[name] = item
    for spec in SPECS[kind]:
        if spec.required and spec.name not in found:
            report.error("E021", f"{owner} is missing the attribute '{spec.name}'", owner_span,
                         hint=_add_hint(spec))
    return found


def _add_hint(spec: AttrSpec) -> str:
    examples = {"elements": "elements = 4", "axis": "axis = (1, 0)",
                "axis_a": "axis_a = (0, 0, 1)", "axis_b": "axis_b = (1, 0, 0)",
                "orientation": "orientation = rz(30 deg)",
                "angles": "angles = h1 - h2", "acts": "acts = push"}
    if spec.dim is None:
        return f"add: {examples[spec.name]}"
    return f"add: {spec.name} = 1 {si_text(spec.dim)}"


class ParamVector:
    """The run-time parameter vector being laid out: declared params, then attributes."""

    def __init__(self) -> None:
        self.declared: list[Param] = []
        self.attributes: list[Param] = []
        self.derived: list[DerivedName] = []
        self._defaults: list[float] = []  # in entries() order, kept as entries are added

    def entries(self) -> list[Param]:
        return self.declared + self.attributes

    def defaults(self) -> list[float]:
        """The entries' default values (the list kept here: read it, do not change it)."""
        return self._defaults

    def add(self, param: Param) -> ParamRef:
        if param.kind is ParamKind.DECLARED:
            assert not self.attributes, "declared params come first"
            self.declared.append(param)
        else:
            self.attributes.append(param)
        self._defaults.append(param.default)
        return ParamRef(len(self.declared) + len(self.attributes) - 1)

    def add_derived(self, name: str, expr: Expr, span: Span) -> None:
        first = len(self.declared)
        depends = tuple((self.declared[i] if i < first else self.attributes[i - first]).name
                        for i in sorted(param_indices(expr)))
        self.derived.append(DerivedName(name, depends, span))


class AttributeReader:
    """Resolves attribute values: dimension checks, parameter entries, range checks."""

    def __init__(self, resolver: ExprResolver, vector: ParamVector,
                 spatial: bool = False) -> None:
        self.spatial = spatial  # a spatial model: vectors have three components
        self.resolver = resolver
        self.vector = vector
        self.report: Reporter = resolver.report
        self.limits: list[Limit] = []  # every range check made, for Model.limits

    def scalar(self, item: AttributeItem, spec: AttrSpec, entry: str) -> Expr | None:
        """A scalar attribute as a parameter entry named `entry` (or a derived expression)."""
        assert spec.dim is not None
        typed = self.quantity(item.value, spec.dim, spec.name)
        if typed is None:
            return None
        expr = self.enter(entry, typed.expr, spec.dim, item.value.span)
        if expr is not None and spec.limit:
            self.check_limit(Limit(entry, expr, spec.limit, si_text(spec.dim),
                                   item.value.span))
        return expr

    def enter(self, entry: str, expr: Expr, dim: Dim, span: Span) -> Expr | None:
        """A parameter entry for a plain constant, or a derived name for an expression."""
        if param_indices(expr):
            self.vector.add_derived(entry, expr, span)
            return expr
        value = self.value(expr, span, entry)
        if value is None:
            return None
        return self.vector.add(Param(entry, value, dim, si_text(dim), ParamKind.ATTRIBUTE, span))

    def quantity(self, node: AstExpr | VectorLit, dim: Dim, what: str) -> Typed | None:
        """A scalar constant of dimension `dim`."""
        if isinstance(node, VectorLit):
            self.report.error("E023", f"{what} takes one value, not a vector", node.span)
            return None
        typed = self.resolver.resolve(node, Context.CONSTANT)
        if typed is None or not self.expect(typed, dim, what, node):
            return None
        return typed

    def expect(self, typed: Typed, dim: Dim, what: str, node) -> bool:
        """Report unless `typed` has dimension `dim` (a plain number counts as radians)."""
        if typed.dim == dim:
            return True
        if dim == ANGLE and typed.dim == NONE:
            warn_plain_angle(self.report, node, f"{what} is an angle:")
            return True
        example = self._example(node, dim)
        if typed.dim == NONE:
            self.report.error("E031", f"{what} needs a unit, e.g. {example}", node.span)
            return False
        hint = f"e.g. {example}" if dim != NONE else "remove the unit"
        if dim_div(dim, typed.dim) == Dim(angle=-1):
            hint = f"a {describe(dim).split(' (')[0]} has '/rad' in its unit: e.g. {example}"
        self.report.error("E030", f"{what}: expected {describe(dim)}, got {describe(typed.dim)}",
                          node.span, hint=hint)
        return False

    def _example(self, node, dim: Dim) -> str:
        """"2 kg": the number the user wrote, if any, with the SI unit."""
        if isinstance(node, Quantity):
            node = node.value
        text = node.text if isinstance(node, NumberLit) else "1"
        return f"{text} {si_text(dim)}" if dim != NONE else text

    def value(self, expr: Expr, span: Span, what: str) -> float | None:
        """The value at the default parameters, or None (reported) when there is none."""
        try:
            return evaluate(expr, self.vector.defaults())
        except EvaluationError as error:
            self.report.error("E027", f"cannot evaluate {what}: {error}", span)
            return None

    def check_limit(self, limit: Limit) -> bool:
        """Record `limit` (for Model.limits) and check it at the default parameters; False
        after reporting E025 (E028 for an ordered pair of attributes) or E027."""
        self.limits.append(limit)
        try:
            message = violation(limit, self.vector.defaults())
        except EvaluationError as error:
            self.report.error("E027", f"cannot evaluate {limit.what}: {error}", limit.span)
            return False
        if message is not None:
            code = "E028" if limit.bound is not None else "E025"
            self.report.error(code, message, limit.span)
        return message is None
