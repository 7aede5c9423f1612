"""Syntax tree -> checked IR (`ir.Model`): names to indices, units to SI, defaults filled,
every semantic check. All errors are collected in the Reporter; no Model is built when
there is any.

Statements are read in file order (one `_read_<Statement>` method each), so parameter
entries come out in file order: declared params first, then attributes.
"""

from __future__ import annotations

import hashlib

from .assembly import assemble
from .attributes import SPECS, AttributeReader, ParamVector, read_block
from .errors import Reporter, at, file_span, sort_key
from .evaluate import EvaluationError, Typed, call, evaluate, param_indices
from .expressions import Context, ExprResolver, ParamInfo
from .initial import InitialValues
from .ir import (CYLINDRICAL_VALUES, FREE_VALUES, SPATIAL_FREE_VALUES, TURN_VALUES,
                 UNIVERSAL_VALUES, Ball, Beam, Body, Cable, Cylindrical, Expr, FreeJoint, Ground,
                 Hinge, InputKind, JointKind, Limit, MemberKind, Model, Num, Output, Param,
                 ParamKind, Particle, Simulation, Slider, StructuralParam, Universal)
from .joints import (resolve_ball, resolve_cable, resolve_cylindrical, resolve_free,
                     resolve_hinge, resolve_slider, resolve_spring, resolve_universal,
                     resolve_weld)
from .members import normal_cosine
from .members import check_element_total, resolve_gravity, resolve_ground, resolve_member
from .names import collect_symbols
from .repeat import expand
from .structural import Structural
from .inputs import resolve_input
from .syntax import (CableStmt, GravityStmt, GroundStmt, InitialStmt, InputStmt, JointStmt,
                     MemberStmt, ModelStmt, OutputStmt, ParamStmt, SimulateStmt, SourceFile)
from .units import si_text

DEFAULT_SIMULATION = Simulation(t_end=10.0, tol=1e-8, dt_out=0.01)
# How far from normal a universal joint's axes may be at its placement: round-off of the
# orientations' turns (a turn written in degrees is pi/2 to 1e-16).
UNIVERSAL_NORMAL = 1e-9
_SINGLE = (ModelStmt, GravityStmt, GroundStmt, SimulateStmt)  # at most one of each
# Elements of planar models that spatial models do not have yet, as messages name them.
_PLANAR_ONLY = {"beam": "flexible beams"}


def resolve(source: SourceFile, text: str, report: Reporter) -> Model | None:
    """The checked model, or None when `report` holds errors. Repetition (for loops,
    indexed names, array and structural parameters) is expanded first (dsl/repeat.py)."""
    expanded = expand(source, report)
    if expanded is None:
        return None
    source, structural = expanded
    return _ModelBuilder(source, text, report, structural).build()


class _ModelBuilder:
    def __init__(self, source: SourceFile, text: str, report: Reporter,
                 structural: dict[str, Structural]) -> None:
        self.source = source
        self.structural = tuple(StructuralParam(s.name, s.value, s.span)
                                for s in structural.values())
        self.text = text
        self.report = report
        self.symbols = collect_symbols(source, report)
        self.resolver = ExprResolver(self.symbols, report)
        self.vector = ParamVector()
        models = [s for s in source.statements if isinstance(s, ModelStmt)]
        self.spatial = bool(models) and models[0].spatial
        self.resolver.spatial = self.spatial
        self.reader = AttributeReader(self.resolver, self.vector, self.spatial)
        self.gravity: tuple[Expr, ...] | None = (Num(0.0),) * (3 if self.spatial else 2)
        self.ground: Ground | None = None
        self.members: list[Body | Beam | Particle | None] = []
        self.hinges: list[dict | None] = []
        self.sliders: list[dict | None] = []
        self.welds: list = []
        self.free_joints: list[dict | None] = []
        self.balls: list[dict | None] = []
        self.cylindricals: list[dict | None] = []
        self.universals: list[dict | None] = []
        self.springs: list = []
        self.cables: list[Cable | None] = []
        self.outputs: list[Output | None] = []
        self.inputs: list = []
        self.initial = InitialValues()
        self.simulation = DEFAULT_SIMULATION
        self.seen: dict[type, object] = {}
        self.hinge_index: dict[str, int] | None = None

    def build(self) -> Model | None:
        self._check_model_statement()
        for statement in self.source.statements:
            if isinstance(statement, ParamStmt):
                self._read_param(statement)
        for statement in self.source.statements:
            if self._first_of_its_kind(statement):
                getattr(self, "_read_" + type(statement).__name__)(statement)
        if self.ground is None:
            self.ground = resolve_ground(None, self.reader, self.source.filename)
        check_element_total([m for m in self.members if isinstance(m, Beam)], self.report)
        self._check_universal_axes()
        if self.report.has_errors:
            return None
        self._warn_unused_params()
        return self._model()

    # --- statements ----------------------------------------------------------------------

    def _check_model_statement(self) -> None:
        statements = self.source.statements
        models = [s for s in statements if isinstance(s, ModelStmt)]
        span = statements[0].span if statements else file_span(self.source.filename)
        if not models:
            self.report.error("E004", "missing model statement", span,
                              hint='start the file with: model NAME "description"')
        elif statements[0] is not models[0]:
            self.report.error("E004", "the model statement must come first", models[0].span,
                              notes=[f"the first statement is at {at(statements[0].span)}"])

    def _first_of_its_kind(self, statement) -> bool:
        if not isinstance(statement, _SINGLE):
            return True
        first = self.seen.setdefault(type(statement), statement)
        if first is statement:
            return True
        self.report.error("E005", f"a model has only one '{_keyword(statement)}' statement",
                          statement.span, notes=[f"first given at {at(first.span)}"])
        return False

    def _declares(self, statement) -> bool:
        """False for a statement whose name was refused (duplicate or reserved)."""
        symbol = self.symbols.get(statement.name.text)
        return symbol is not None and symbol.span == statement.name.span

    def _read_ModelStmt(self, statement: ModelStmt) -> None:
        pass  # read in _model

    def _read_param(self, statement: ParamStmt) -> None:
        if not self._declares(statement):
            return
        name = statement.name.text
        end = (statement.span.end_line, statement.span.end_col)
        typed = self.resolver.resolve(statement.value, Context.CONSTANT)
        if typed is not None and param_indices(typed.expr):
            self.vector.add_derived(name, typed.expr, statement.name.span)
        elif typed is not None:
            typed = self._free_param(name, typed, statement)
        self.resolver.params[name] = ParamInfo(typed, statement.name.span, end)

    def _free_param(self, name: str, typed: Typed, statement: ParamStmt) -> Typed | None:
        try:
            value = evaluate(typed.expr, ())
        except EvaluationError as error:
            self.report.error("E027", f"cannot evaluate parameter '{name}': {error}",
                              statement.value.span)
            return None
        ref = self.vector.add(Param(name, value, typed.dim, si_text(typed.dim),
                                    ParamKind.DECLARED, statement.name.span))
        return Typed(ref, typed.dim)

    def _read_ParamStmt(self, statement: ParamStmt) -> None:
        pass  # read first, in _read_param

    def _read_GravityStmt(self, statement: GravityStmt) -> None:
        self.gravity = resolve_gravity(statement, self.reader)

    def _read_GroundStmt(self, statement: GroundStmt) -> None:
        self.ground = resolve_ground(statement, self.reader, self.source.filename)

    def _read_MemberStmt(self, statement: MemberStmt) -> None:
        if self._declares(statement) and self._in_this_space(statement):
            self.members.append(resolve_member(statement, self.reader))

    def _read_JointStmt(self, statement: JointStmt) -> None:
        if not self._declares(statement) or not self._in_this_space(statement):
            return
        read = {"hinge": (self.hinges, resolve_hinge), "slider": (self.sliders, resolve_slider),
                "weld": (self.welds, resolve_weld), "free": (self.free_joints, resolve_free),
                "ball": (self.balls, resolve_ball), "spring": (self.springs, resolve_spring),
                "cylindrical": (self.cylindricals, resolve_cylindrical),
                "universal": (self.universals, resolve_universal)}
        found, resolve_kind = read[statement.kind]
        found.append(resolve_kind(statement, self.symbols, self.reader))

    def _in_this_space(self, statement: MemberStmt | JointStmt) -> bool:
        """False after E060 for an element spatial models do not have yet (beams, sliders)."""
        if self.spatial and statement.kind in _PLANAR_ONLY:
            self.report.error("E060", f"a spatial model cannot have {_PLANAR_ONLY[statement.kind]}"
                              " yet", statement.span,
                              hint="model it in a planar model, or with bodies and hinges")
            return False
        return True

    def _read_CableStmt(self, statement: CableStmt) -> None:
        if self._declares(statement):
            if self.hinge_index is None:  # every name is declared before any is read
                self.hinge_index = {s.name: s.index for s in self.symbols.of_kind("hinge")}
            self.cables.append(resolve_cable(statement, self.symbols, self.reader,
                                             self.hinge_index))

    def _read_InitialStmt(self, statement: InitialStmt) -> None:
        self.initial.read(statement, self.symbols, self.reader)

    def _read_SimulateStmt(self, statement: SimulateStmt) -> None:
        found = read_block(statement.block, "simulate", "simulate", statement.span,
                           self.report)
        values = {}
        for spec in SPECS["simulate"]:
            if spec.name in found:
                values[spec.name] = self._setting(found[spec.name], spec)
        settings = {k: v for k, v in values.items() if v is not None}
        self.simulation = Simulation(**{**_as_dict(DEFAULT_SIMULATION), **settings})
        if self.simulation.dt_out > self.simulation.t_end and "dt_out" in found:
            self.report.warning("W003", f"dt_out ({self.simulation.dt_out:g} s) is longer "
                                f"than t_end ({self.simulation.t_end:g} s)",
                                found["dt_out"].span, hint="only the final state is output")

    def _setting(self, item, spec) -> float | None:
        typed = self.reader.quantity(item.value, spec.dim, spec.name)
        if typed is None:
            return None
        if param_indices(typed.expr):
            self.report.error("E026", f"simulate settings are fixed numbers; {spec.name} "
                              "cannot use parameters", item.value.span)
            return None
        value = self.reader.value(typed.expr, item.value.span, spec.name)
        if value is not None and value <= 0:
            self.report.error("E026", f"{spec.name} must be positive, got {value:g} "
                              f"{si_text(spec.dim) if spec.name != 'tol' else ''}".rstrip(),
                              item.value.span)
            return None
        if value is not None and spec.name == "tol" and value >= 1:
            self.report.error("E026", f"tol must be less than 1, got {value:g}",
                              item.value.span, hint="tol is a relative tolerance, e.g. 1e-8")
            return None
        return value

    def _read_OutputStmt(self, statement: OutputStmt) -> None:
        if not self._declares(statement):
            return
        typed = self.resolver.resolve(statement.value, Context.OUTPUT)
        self.outputs.append(None if typed is None else Output(
            statement.name.text, typed.expr, typed.dim, si_text(typed.dim), statement.span))

    def _read_InputStmt(self, statement: InputStmt) -> None:
        if self._declares(statement):
            self.inputs.append(resolve_input(statement, self.symbols, self.reader))

    # --- checks and the model ------------------------------------------------------------

    def _warn_unused_params(self) -> None:
        for statement in self.source.statements:
            if isinstance(statement, ParamStmt) and self._declares(statement) \
                    and statement.name.text not in self.resolver.used_params:
                self.report.warning("W002", f"parameter '{statement.name.text}' is never used",
                                    statement.name.span)

    def _model(self) -> Model:
        parts = (self.members, self.hinges, self.sliders, self.cables, self.outputs,
                 self.inputs, self.welds, self.free_joints, self.springs, self.balls,
                 self.cylindricals, self.universals)
        assert self.gravity is not None and all(None not in p for p in parts), \
            "an element failed without an error"
        hinges = tuple(Hinge(**h, initial_angle=self._initial(h["name"], "initial_angle"),
                             initial_rate=self._initial(h["name"], "initial_rate"),
                             held=self._held(h["name"], "initial_angle"))
                       for h in self.hinges)
        sliders = tuple(Slider(**s, initial_position=self._initial(s["name"], "initial_position"),
                               initial_rate=self._initial(s["name"], "initial_rate"),
                               held=self._held(s["name"], "initial_position"))
                        for s in self.sliders)
        free_joints = tuple(self._free_joint(f) for f in self.free_joints)
        balls = tuple(Ball(**fields, **self._turns(fields["name"])) for fields in self.balls)
        cylindricals = tuple(
            Cylindrical(**fields, **self._free_values(fields["name"], CYLINDRICAL_VALUES))
            for fields in self.cylindricals)
        universals = tuple(
            Universal(**fields, **self._free_values(fields["name"], UNIVERSAL_VALUES))
            for fields in self.universals)
        bodies = tuple(m for m in self.members if isinstance(m, Body))
        beams = tuple(m for m in self.members if isinstance(m, Beam))
        particles = tuple(m for m in self.members if isinstance(m, Particle))
        members = [(s.member, s.describe(), s.span)
                   for s in self.symbols.of_kind("bar", "body", "beam", "particle")]
        placements, loops = assemble(hinges, sliders, members, self.report, tuple(self.welds),
                                     free_joints, balls, cylindricals, universals)
        self._check_loop_sliders(sliders, loops)
        self._check_particle_hinges(hinges)
        if not members:
            self.report.warning("W004", "the model has no bodies or beams",
                                self.source.statements[0].span)
        model_statement = self.seen[ModelStmt]
        return Model(
            name=model_statement.name.text, description=model_statement.description,
            source_file=self.source.filename,
            source_sha256=hashlib.sha256(self.text.encode("utf-8")).hexdigest(),
            params=tuple(self.vector.entries()), derived=tuple(self.vector.derived),
            gravity=self.gravity, ground=self.ground, bodies=bodies, beams=beams,
            hinges=hinges, sliders=sliders, cables=tuple(self.cables),
            outputs=tuple(self.outputs), simulation=self.simulation, placements=placements,
            loop_joints=loops, warnings=tuple(sorted(self.report.warnings(), key=sort_key)),
            limits=tuple(self.reader.limits), inputs=tuple(self.inputs),
            structural=self.structural, particles=particles, welds=tuple(self.welds),
            free_joints=free_joints, springs=tuple(self.springs), spatial=self.spatial,
            balls=balls, cylindricals=cylindricals, universals=universals)

    def _check_universal_axes(self) -> None:
        """E025 unless each universal joint's axes are normal where the members' orientations
        place them (a range check, so a study that turns a member is held to it too)."""
        bodies = [m for m in self.members if isinstance(m, Body)]
        for fields in self.universals:
            if fields is None:
                continue
            turns = [bodies[end.member.index].orientation
                     if end.member.kind is MemberKind.BODY else ()
                     for end in (fields["a"], fields["b"])]
            cosine = normal_cosine(fields["axis_a"], turns[0], fields["axis_b"], turns[1])
            name = fields["name"]
            self.reader.check_limit(Limit(
                f"the cosine of the angle between {name}.axis_a and {name}.axis_b where the "
                "members' orientations place them", call("abs", (cosine,)), "below", "",
                fields["span"], Num(UNIVERSAL_NORMAL), "1e-9 (they must be normal)"))

    def _initial(self, joint: str, suffix: str) -> Expr:
        value = self.initial.get(joint, suffix)
        return Num(0.0) if value is None else value

    def _held(self, joint: str, value_suffix: str, rate_suffix: str = "initial_rate") -> int:
        """What of a joint's initial state the user gave, so the assembly holds it: 1 its
        value, 2 its rate (docs/language.md, Assembly)."""
        return ((self.initial.get(joint, value_suffix) is not None)
                | 2 * (self.initial.get(joint, rate_suffix) is not None))

    def _turns(self, name: str) -> dict:
        """A ball joint's initial values: its turns' (0) and their rates (ir.TURN_VALUES)."""
        return self._free_values(name, TURN_VALUES)

    def _free_joint(self, fields: dict) -> FreeJoint:
        """The free joint with its initial values (0 where not given) and what was given."""
        name = fields["name"]
        if self.spatial:
            return FreeJoint(**fields, **self._free_values(name, SPATIAL_FREE_VALUES))
        initial, held = [], []
        for value, rate in FREE_VALUES:
            initial += [self._initial(name, value), self._initial(name, rate)]
            held.append(self._held(name, value, rate))
        if not fields["turns"]:
            for suffix in FREE_VALUES[2]:
                if self.initial.get(name, suffix) is not None:
                    self.report.error(
                        "E048", f"free joint '{name}' moves a particle, which has no angle: "
                        f"it takes no initial {suffix.removeprefix('initial_')}",
                        self.initial.span_of(name, suffix),
                        hint=f"give {name}.x, {name}.y, {name}.vx and {name}.vy")
        return FreeJoint(**fields, initial=tuple(initial), held=tuple(held))

    def _free_values(self, name: str, values) -> dict:
        initial, held = [], []
        for value, rate in values:
            initial += [self._initial(name, value), self._initial(name, rate)]
            held.append(self._held(name, value, rate))
        return dict(initial=tuple(initial), held=tuple(held))

    def _check_particle_hinges(self, hinges: tuple[Hinge, ...]) -> None:
        """A hinge at a particle carries no torque: no cable and no torque input on it."""
        at_particle = {i for i, h in enumerate(hinges)
                       if MemberKind.PARTICLE in (h.a.member.kind, h.b.member.kind)}
        if not at_particle:
            return
        for cable in self.cables:
            for term in cable.terms:
                if term.hinge in at_particle:
                    self.report.error("E048", f"cable '{cable.name}' acts on hinge "
                                      f"'{hinges[term.hinge].name}', which joins a particle "
                                      "and carries no torque", cable.span)
        for put in self.inputs:
            if put.kind is InputKind.TORQUE and put.hinge in at_particle:
                self.report.error("E047", f"torque input '{put.name}': hinge "
                                  f"'{hinges[put.hinge].name}' joins a particle, which has no "
                                  "angle, and carries no torque", put.span,
                                  hint="apply a force to the particle instead: `input NAME "
                                       "force on PARTICLE.cm`")

    def _check_loop_sliders(self, sliders, loops) -> None:
        """A slider that closes a loop has no coordinate of its own in the assembly: its
        initial value follows from the loop and cannot be held (E046)."""
        for kind, index in loops:
            if kind is JointKind.SLIDER and sliders[index].held:
                name = sliders[index].name
                which = "its position" if sliders[index].held & 1 else "its rate"
                self.report.error(
                    "E046", f"slider '{name}' closes a kinematic loop, so {which} follows from "
                    "the loop and cannot be given",
                    self.initial.span_of(name) or sliders[index].span,
                    hint=f"leave {name} out of `initial`: the assembly solves it from the "
                         "values given for the joints of the tree")


def _keyword(statement) -> str:
    return {ModelStmt: "model", GravityStmt: "gravity", GroundStmt: "ground",
            SimulateStmt: "simulate"}[type(statement)]


def _as_dict(simulation: Simulation) -> dict[str, float]:
    return {"t_end": simulation.t_end, "tol": simulation.tol, "dt_out": simulation.dt_out}
