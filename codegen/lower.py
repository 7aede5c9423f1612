"""lower: a SymbolicSystem to view-models of plain strings and ints, ready for a template.

Each generated function's expressions go through one `sympy.cse`; temporaries and results are
printed by a backend printer (printing.py) that maps input symbols to array slots. Results keep
only their structurally non-zero entries (the arrays start as zeros)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import sympy

from depsim.dsl import ir
from depsim.dsl.attributes import HINGE_PROPERTIES
from depsim.dsl.evaluate import param_indices
from depsim.dsl.limits import LIMIT_KINDS, message_format
from depsim.runtime import interface

from .assembly import Group
from .derive import SymbolicSystem, column
from .printing import LoweringError, SlotPrinter
from .tangent import as_groups, direction, needed_steps, tangent_program

PrinterFactory = Callable[..., SlotPrinter]  # (slots, temporaries) -> printer

ARGUMENT_ORDER = interface.ARGUMENTS  # argument names and order, shared by every backend


@dataclass(frozen=True)
class Assignment:
    """`name = value` of one CSE temporary."""

    name: str
    value: str


@dataclass(frozen=True)
class Entry:
    """One non-zero entry of a result: its index per axis, its row-major flat index, value."""

    index: tuple[int, ...]
    flat: int
    value: str


@dataclass(frozen=True)
class ResultView:
    """One returned array: name, shape and its non-zero entries."""

    name: str
    shape: tuple[int, ...]
    entries: tuple[Entry, ...]


@dataclass(frozen=True)
class Statement:
    """One line of a function's body: a temporary (`result` is -1) or entry `entry` of result
    `result`."""

    result: int
    assignment: Assignment | None = None
    entry: Entry | None = None


@dataclass(frozen=True)
class FunctionView:
    """One generated function: arguments (names from ARGUMENT_ORDER), a one-line summary,
    CSE temporaries, its results (more than one: returned as a tuple), and the body: every
    temporary and entry in evaluation order, each temporary just before its first use (a
    result's entry as soon as its temporaries are there, so few values are live at once)."""

    name: str
    args: tuple[str, ...]
    summary: str
    temporaries: tuple[Assignment, ...]
    results: tuple[ResultView, ...]
    statements: tuple[Statement, ...]
    ieee: bool = False  # evaluated with IEEE semantics (IEEE_FUNCTIONS)


@dataclass(frozen=True)
class TableView:
    """One constant table of the interface (depsim.runtime.interface.TABLES) and its values."""

    constant: str  # module constant, e.g. "COORDINATES"
    field: str  # dep_model field, e.g. "coordinate_names"
    ctype: str  # C element type
    values: tuple


@dataclass(frozen=True)
class ModuleView:
    """Everything a generated module contains, as plain data (docs/generated-module.md):
    identity, sizes (dep_model field, module constant, value), tables, settings, functions."""

    model_name: str
    description: str
    source_file: str
    source_sha256: str
    depsim_version: str
    sizes: tuple[tuple[str, str, int], ...]
    tables: tuple[TableView, ...]
    t_end: float
    tol: float
    dt_out: float
    functions: tuple[FunctionView, ...]  # FUNCTIONS, then TANGENTS when generated
    tangents: bool = False  # whether functions hold interface.TANGENTS


@dataclass(frozen=True)
class FunctionSpec:
    """What to lower: a function's name, arguments, summary and named result matrices."""

    name: str
    args: tuple[str, ...]
    summary: str
    results: tuple[tuple[str, sympy.MatrixBase], ...]
    flatten: bool = True  # (n, 1) columns become 1-d arrays
    # symbols defined in order before the results (a program): the system's constants and
    # hinge steps, then the function's own
    steps: tuple[Group, ...] = ()


def function_specs(system: SymbolicSystem, tangents: bool = False
                   ) -> tuple[FunctionSpec, ...]:
    """The model functions of the interface (depsim.runtime.interface.FUNCTIONS: names,
    arguments, results, summaries), each with the system's matrices for its results; then,
    with `tangents`, those of interface.TANGENTS (tangent_spec)."""
    s = system
    q, qd = column(s.q), column(s.qd)
    placed = tuple(g for pair in zip(s.tree_pose, s.tree_tangent) for g in pair)
    steps = {"tree_pose": s.tree_pose, "tree_tangent": placed,
             "phi_q_transpose_times": (s.phi_q_entries,)}
    matrices = {
        "mass_matrix": (column(s.mass_matrix[i, j] for i, j in s.mass_pattern),),
        "tree_values": (s.tree_v0, s.tree_vd0), "tree_pose": (q,), "tree_tangent": (qd,),
        "loop_targets": (s.loop_angles, s.loop_rates), "phi": (s.phi,),
        "phi_q": (column(s.phi_q[i, j] for i, j in s.phi_q_pattern),),
        "phi_q_transpose_times": (s.phi_q_lam,), "phi_t": (s.phi_t,),
        "gamma": (s.gamma,), "force": (s.force,), "hinge_angles": (s.hinge_angles,),
        "hinge_rates": (s.hinge_rates,), "hinge_jacobian": (column(s.hinge_jacobian[i, j] for i, j in s.hinge_jacobian_pattern),),
        "hinge_gamma": (s.hinge_gamma,), "hinge_properties": (s.hinge_properties,),
        "outputs": (s.outputs,), "energy": (s.energy,), "dissipation": (s.dissipation,),
        "coordinate_scales": (s.coordinate_scales,),
        "system_state": (s.system_state,),
        "stiffness": (s.stiffness, s.stiffness_damping),
        "parameter_checks": (s.limit_values, s.limit_bounds),
    }
    prelude = s.constants + s.hinge_steps
    specs = tuple(FunctionSpec(f.name, f.args, f.summary,
                               tuple((r.name, m) for r, m in zip(f.results, matrices[f.name])),
                               flatten=len(f.results[0].shape) == 1,
                               steps=prelude + steps.get(f.name, ()))
                  for f in interface.FUNCTIONS)
    if not tangents:
        return specs
    bases = {spec.name: spec for spec in specs}
    return specs + tuple(tangent_spec(system, bases[f.name]) for f in interface.FUNCTIONS
                         if f.name in interface.TANGENT_BASES)


def tangent_spec(system: SymbolicSystem, base: FunctionSpec) -> FunctionSpec:
    """The tangent of a base function (interface.tangent): its program differentiated
    forward along the directions of its inputs but t (tangent.tangent_program)."""
    function = interface.tangent(next(f for f in interface.FUNCTIONS if f.name == base.name))
    inputs = [x for x in slots(system, base.args) if x != system.t]
    places = [(k, i, j) for k, (_, matrix) in enumerate(base.results)
              for (i, j), value in sorted(matrix.todok().items()) if value != 0]
    # the base as the straight-line program it is lowered to (its steps, then one CSE of its
    # results), so that every expression differentiated is a few terms ('#' keeps these
    # names apart from the model's; lowering the tangent renames them)
    names = sympy.numbered_symbols("#b")
    steps, exprs = _program(base.steps, [base.results[k][1][i, j] for k, i, j in places],
                            names)
    definitions, reduced = sympy.cse(exprs, symbols=names)
    program, changes = tangent_program(as_groups(steps + definitions), inputs, reduced)
    entries: list[dict] = [{} for _ in base.results]
    for (k, i, j), change in zip(places, changes):
        entries[k][(i, j)] = change
    results = tuple((r.name, sympy.ImmutableSparseMatrix(m.rows, m.cols, found))
                    for r, (_, m), found in zip(function.results, base.results, entries))
    return FunctionSpec(function.name, function.args, function.summary, results,
                        base.flatten, program)


def slots(system: SymbolicSystem, args: tuple[str, ...]) -> dict[sympy.Symbol, str]:
    """Input symbol -> array slot text (`q[3]`, `p[7]`, `t`, `dq[3]`) for a function's
    arguments; a direction's symbols are tangent.direction of its value's."""
    arrays = {"v": system.v, "vd": system.vd, "q": system.q, "qd": system.qd, "p": system.p,
              "lam": system.lam, "w": system.w}
    arrays.update({interface.direction(name): tuple(map(direction, symbols))
                   for name, symbols in arrays.items()})
    table = {system.t: "t"} if "t" in args else {}
    for name in args:
        table.update({s: f"{name}[{i}]" for i, s in enumerate(arrays.get(name, ()))})
    return table


# The functions whose expressions the user writes freely (`output` statements): a value outside
# a function's domain (sqrt of a negative number, log 0, a division by a state passing zero)
# is nan or inf in every target, as C computes it, and never an exception. The runtime warns
# about non-finite outputs (docs/language.md, outputs).
IEEE_FUNCTIONS = ("outputs", interface.tangent_name("outputs"))


def lower_function(system: SymbolicSystem, spec: FunctionSpec,
                   printer: PrinterFactory) -> FunctionView:
    """CSE the function's non-zero entries together and print them through `printer`; a
    function with steps computes them first (`_program`)."""
    assert tuple(a for a in ARGUMENT_ORDER if a in spec.args) == spec.args, spec.args
    entries = [matrix.todok() for _, matrix in spec.results]  # the non-zeros (sparse or not)
    places = [(r, i, j) for r, found in enumerate(entries)
              for (i, j), value in sorted(found.items()) if value != 0]
    exprs = [entries[r][i, j] for r, i, j in places]
    names = sympy.numbered_symbols("x")
    program, exprs = _program(spec.steps, exprs, names)
    definitions, reduced = sympy.cse(exprs, symbols=names)
    definitions, reduced = _split_sums(program + definitions, reduced, names)
    inputs = slots(system, spec.args)
    _check_inputs(spec.name, definitions, reduced, inputs)
    print_ = printer(inputs, [name for name, _ in definitions]).doprint
    printed = {name: Assignment(name.name, print_(value)) for name, value in definitions}
    entries: list[list[Entry]] = [[] for _ in spec.results]
    statements: list[Statement] = []
    order = _demand_order(definitions, reduced)
    for (r, i, j), value, needed in zip(places, reduced, order):
        statements += [Statement(-1, printed[name]) for name in needed]
        cols = spec.results[r][1].cols
        index = (i,) if spec.flatten else (i, j)
        entries[r].append(Entry(index, i * cols + j, print_(value)))
        statements.append(Statement(r, entry=entries[r][-1]))
    results = tuple(ResultView(name, _shape(matrix, spec.flatten), tuple(found))
                    for (name, matrix), found in zip(spec.results, entries))
    return FunctionView(spec.name, spec.args, spec.summary, tuple(printed.values()), results,
                        tuple(statements), spec.name in IEEE_FUNCTIONS)


def _demand_order(definitions, reduced) -> list[list[sympy.Symbol]]:
    """For each result expression, the temporaries to evaluate just before it (those it needs,
    directly or not, that no earlier result needed), each just before its first use: depth
    first, a temporary's needs before it, the latest defined of them first. So a running sum
    (a chain of partial sums, each needing the one before) is evaluated chunk after chunk,
    each chunk just after its own few terms, not after every term of the sum."""
    position = {name: k for k, (name, _) in enumerate(definitions)}
    needs = {name: sorted((s for s in value.free_symbols if s in position), key=position.get)
             for name, value in definitions}
    done: set[sympy.Symbol] = set()
    order = []
    for value in reduced:
        needed: list[sympy.Symbol] = []
        roots = sorted((s for s in value.free_symbols if s in position), key=position.get)
        stack = [(name, False) for name in roots]
        while stack:  # iterative post-order: a placement chain is thousands deep
            name, expanded = stack.pop()
            if name in done:
                continue
            if expanded:
                done.add(name)
                needed.append(name)
                continue
            stack.append((name, True))
            stack += [(s, False) for s in needs[name] if s not in done]
        order.append(needed)
    return order


def _program(steps: tuple[Group, ...], exprs: list[sympy.Expr], names
             ) -> tuple[list[tuple[sympy.Symbol, sympy.Expr]], list[sympy.Expr]]:
    """The steps the results need, as temporaries in order (each step's symbol renamed s<k>,
    the CSE of a window of groups before it), and the results in those names. A window
    gathers consecutive groups while none refers to a symbol defined in it, so each member's
    few terms share their sines and cosines with its neighbours' without one CSE over the
    whole tree."""
    kept = needed_steps(steps, exprs)  # only what the results need: no C variable unused
    rename: dict[sympy.Symbol, sympy.Expr] = {}
    steps_named = sympy.numbered_symbols("s")
    temporaries: list[tuple[sympy.Symbol, sympy.Expr]] = []
    window: list[tuple[sympy.Symbol, sympy.Expr]] = []

    def flush() -> None:
        definitions, reduced = sympy.cse([value.xreplace(rename) for _, value in window],
                                         symbols=names)
        temporaries.extend(definitions)
        for (symbol, _), value in zip(window, reduced):
            if value.is_Atom:  # a number, an input or a temporary: no copy
                rename[symbol] = value
                continue
            rename[symbol] = next(steps_named)
            temporaries.append((rename[symbol], value))
        window.clear()

    for group in kept:
        defined = {symbol for symbol, _ in window}
        if any(value.free_symbols & defined for _, value in group):
            flush()
        window.extend(group)
    if window:
        flush()
    return temporaries, [e.xreplace(rename) for e in exprs]


SUM_CHUNK = 32  # terms per statement: a model's long sums (the kinetic energy of every body)


def _split_sums(definitions, reduced, names):
    """Every sum of more than SUM_CHUNK terms as a running sum over temporaries, SUM_CHUNK
    terms a statement: one expression of thousands of terms costs a C compiler time growing
    faster than its length. Same value, the terms added in a fixed order."""
    out: list[tuple[sympy.Symbol, sympy.Expr]] = []

    def split(value: sympy.Expr) -> sympy.Expr:
        if not isinstance(value, sympy.Add) or len(value.args) <= SUM_CHUNK:
            return value
        terms, partial = value.args, None
        for start in range(0, len(terms) - SUM_CHUNK, SUM_CHUNK):
            chunk = terms[start:start + SUM_CHUNK]
            symbol = next(names)
            out.append((symbol, sympy.Add(*chunk) if partial is None
                        else sympy.Add(partial, *chunk)))
            partial = symbol
        return sympy.Add(partial, *terms[start + SUM_CHUNK:])

    for symbol, value in definitions:
        out.append((symbol, split(value)))
    reduced = [split(value) for value in reduced]
    return out, reduced


def _shape(matrix: sympy.MatrixBase, flatten: bool) -> tuple[int, ...]:
    if flatten:
        assert matrix.cols == 1, "only columns flatten"
        return (matrix.rows,)
    return (matrix.rows, matrix.cols)


def _check_inputs(name: str, definitions, reduced, inputs: dict) -> None:
    """Fail loudly when an expression has a free symbol that is neither an input nor an
    earlier temporary (as sympy.utilities.codegen.Routine does)."""
    known = set(inputs)
    for temporary, value in definitions:
        _require(name, value.free_symbols - known)
        known.add(temporary)
    for value in reduced:
        _require(name, value.free_symbols - known)


def _require(name: str, unknown: set) -> None:
    if unknown:
        listed = ", ".join(sorted(s.name for s in unknown))
        raise LoweringError(f"{name}: expression depends on {listed}, not an input of {name}")


def _limit_tables(model: ir.Model) -> dict[str, tuple]:
    """The model text's range checks (Model.limits) as the interface's tables: what each
    tests, its kind, its message (depsim.dsl.limits, the one wording) and the parameters it
    depends on (a sparse pattern, row-major)."""
    pairs = sorted((i, j) for i, limit in enumerate(model.limits)
                   for j in param_indices(limit.expr) | (
                       param_indices(limit.bound) if limit.bound is not None else set()))
    return {"LIMITS": tuple(limit.what for limit in model.limits),
            "LIMIT_KINDS": tuple(LIMIT_KINDS.index(limit.kind) for limit in model.limits),
            "LIMIT_MESSAGES": tuple(message_format(limit) for limit in model.limits),
            "LIMIT_PARAMETER_ROWS": tuple(i for i, _ in pairs),
            "LIMIT_PARAMETER_COLS": tuple(j for _, j in pairs)}


def lower_module(model: ir.Model, system: SymbolicSystem, printer: PrinterFactory,
                 depsim_version: str, ieee_printer: PrinterFactory | None = None,
                 tangents: bool = False) -> ModuleView:
    """The whole module's view-model: header constants and every function (those of
    IEEE_FUNCTIONS printed by `ieee_printer` when the backend's own printer is not IEEE),
    with `tangents` also the tangent functions (interface.TANGENTS)."""
    rows, cols = zip(*system.phi_q_pattern) if system.phi_q_pattern else ((), ())
    values = {
        "COORDINATES": system.coordinates, "PARAMETERS": tuple(p.name for p in model.params),
        "PARAMETER_DEFAULTS": tuple(float(p.default) for p in model.params),
        "PARAMETER_UNITS": tuple(p.unit for p in model.params),
        "CONSTRAINTS": system.constraint_names, "CONSTRAINT_JOINTS": system.constraint_joints,
        "CONSTRAINT_HINGES": system.constraint_hinges,
        "CONSTRAINT_SLIDERS": system.constraint_sliders,
        "PHI_Q_ROWS": tuple(rows), "PHI_Q_COLS": tuple(cols), "HINGES": system.hinge_names,
        "HINGE_PROPERTIES": HINGE_PROPERTIES, "SLIDERS": system.slider_names,
        "OUTPUTS": system.output_names, "OUTPUT_UNITS": tuple(o.unit for o in model.outputs),
        "ENERGIES": system.energy_names, "DISSIPATORS": system.dissipator_names,
        "TREE_JOINTS": system.tree_joints, "TREE_HELD": system.tree_held,
        "HINGE_JACOBIAN_ROWS": tuple(i for i, _ in system.hinge_jacobian_pattern),
        "HINGE_JACOBIAN_COLS": tuple(j for _, j in system.hinge_jacobian_pattern),
        "INPUTS": tuple(c for put in model.inputs for c in put.components),
        "INPUT_UNITS": tuple(model.params[s].unit for put in model.inputs for s in put.slots),
        "INPUT_SLOTS": tuple(s for put in model.inputs for s in put.slots),
        "STIFFNESS_ROWS": tuple(i for i, _ in system.stiffness_pattern),
        "STIFFNESS_COLS": tuple(j for _, j in system.stiffness_pattern),
        "MASS_ROWS": tuple(i for i, _ in system.mass_pattern),
        "MASS_COLS": tuple(j for _, j in system.mass_pattern),
        "FIXED_PARAMETERS": tuple(f.name for f in model.structural),
        "FIXED_VALUES": tuple(f.value for f in model.structural),
        "RUN_VALUES": system.run_value_names, "SYSTEM_STATE": system.system_state_names,
        **_limit_tables(model),
    }
    tables = tuple(TableView(t.constant, t.field, t.ctype, values[t.constant])
                   for t in interface.TABLES)
    counts = {"NQ": len(system.coordinates), "NC": len(system.constraint_names),
              "NP": len(model.params)}
    sizes = tuple((s.field, s.constant, counts.get(s.constant, len(values.get(s.constant, ()))))
                  for s in interface.SIZES)
    return ModuleView(
        model_name=model.name, description=model.description,
        source_file=model.source_file.replace("\\", "/").rsplit("/", 1)[-1],
        source_sha256=model.source_sha256, depsim_version=depsim_version,
        sizes=sizes, tables=tables,
        t_end=model.simulation.t_end, tol=model.simulation.tol, dt_out=model.simulation.dt_out,
        functions=tuple(lower_function(system, spec, ieee_printer if ieee_printer is not None
                                       and spec.name in IEEE_FUNCTIONS else printer)
                        for spec in function_specs(system, tangents)),
        tangents=tangents,
    )
