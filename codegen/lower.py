"""lower: a SymbolicSystem to view-models of plain strings and ints, ready for a template.

Each generated function's expressions go through one `sympy.cse`; temporaries and results are
printed by a backend printer (printing.py) that maps input symbols to array slots. Results keep
only their structurally non-zero entries (the arrays start as zeros)."""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from typing import Callable

import sympy

from depsim.dsl import ir
from depsim.dsl.attributes import HINGE_PROPERTIES
from depsim.dsl.evaluate import param_indices
from depsim.dsl.limits import LIMIT_KINDS, message_format
from depsim.runtime import interface

from .assembly import Group
from .blocks import Block, Place, kinds
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
    """One returned array: name, shape and its non-zero entries (those a kernel call writes
    not among them: `kernel_entries` of them)."""

    name: str
    shape: tuple[int, ...]
    entries: tuple[Entry, ...]
    kernel_entries: int = 0


@dataclass(frozen=True)
class Call:
    """A kernel's call for one block: per argument group its values (printed) or, when they
    are consecutive slots of one array, that array and the first slot; where each output
    goes (result, flat index), consecutive in one result when `out` names it."""

    kernel: str
    args: tuple[tuple[str, tuple[str, ...]], ...]  # (group name, values)
    pointers: tuple[str | None, ...]  # per group: "q + 12", or None (gathered)
    outputs: tuple[tuple[int, int], ...]  # (result, flat) per output
    out: str | None  # "phi + 6" when the outputs are consecutive entries of one result
    accumulate: bool = False  # the outputs are added to the entries (a sum's block)


@dataclass(frozen=True)
class Statement:
    """One line of a function's body: a temporary (`result` is -1) or entry `entry` of result
    `result`, or a kernel's call (`call`, `result` -2)."""

    result: int
    assignment: Assignment | None = None
    entry: Entry | None = None
    call: Call | None = None


@dataclass(frozen=True)
class KernelView:
    """A kind of blocks written once (codegen/blocks.py): its argument groups (each an array
    of the group's length), its statements (entries of result 0, `out`), its outputs' count."""

    name: str
    groups: tuple[tuple[str, int], ...]
    outputs: int
    statements: tuple[Statement, ...]


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
    kernels: tuple[KernelView, ...] = ()  # the kernels its calls use
    # local arrays another model function fills before the body: (array, size, function,
    # its arguments), e.g. ("pose", NQ, "tree_pose", ("v", "p"))
    computed: tuple[tuple[str, int, str, tuple[str, ...]], ...] = ()


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
    blocks: tuple[Block, ...] = ()  # repeated parts of its results (codegen/blocks.py)
    # a step symbol that is the whole entry of a place a kernel's call writes is read back
    # from that place of the result wherever else it is used (the tree's blocks: a child's
    # placement reads its parent's coordinates), not computed again
    reads_results: bool = False
    # the coordinates q read from a local array `pose` that tree_pose fills first (the
    # tree's tangent: its pose steps not written again)
    pose: bool = False


def function_specs(system: SymbolicSystem, tangents: bool = False, kernels: bool = False
                   ) -> tuple[FunctionSpec, ...]:
    """The model functions of the interface (depsim.runtime.interface.FUNCTIONS: names,
    arguments, results, summaries), each with the system's matrices for its results; then,
    with `tangents`, those of interface.TANGENTS (tangent_spec). `kernels`: with the
    system's blocks (their repeated kinds written once, as kernels)."""
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
    blocks = dict(s.blocks) if kernels else {}
    tree = ("tree_pose", "tree_tangent")
    specs = tuple(FunctionSpec(f.name, f.args, f.summary,
                               tuple((r.name, m) for r, m in zip(f.results, matrices[f.name])),
                               flatten=len(f.results[0].shape) == 1,
                               steps=prelude + steps.get(f.name, ()),
                               blocks=blocks.get(f.name, ()),
                               reads_results=f.name in tree and f.name in blocks,
                               pose=f.name == "tree_tangent" and f.name in blocks)
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


@dataclass(frozen=True)
class SharedConstants:
    """A spatial model's named constants (SymbolicSystem.constants) lowered once for the
    functions that use many of them (those with blocks): each constant's lowered value (a
    temporary k<i>, a number or an input), the temporaries in order with what each needs and
    its printed assignment. A function takes the temporaries it needs, in that order."""

    rename: dict
    definitions: tuple[tuple[sympy.Symbol, sympy.Expr], ...]
    needs: dict
    printed: dict


def shared_constants(system: SymbolicSystem, printer: PrinterFactory) -> SharedConstants:
    """The constants' program (`_program`, its temporaries named k<i> and kx<i>), printed."""
    symbols = [symbol for group in system.constants for symbol, _ in group]
    definitions, reduced = _program(system.constants, symbols, sympy.numbered_symbols("kx"),
                                    step_prefix="k")
    definitions, _ = _split_sums(definitions, [], sympy.numbered_symbols("ks"))
    inputs = slots(system, ("p",))
    _check_inputs("constants", definitions, reduced, inputs)
    print_ = printer(inputs, [name for name, _ in definitions]).doprint
    position = {name for name, _ in definitions}
    return SharedConstants(dict(zip(symbols, reduced)), tuple(definitions),
                           {name: [x for x in value.free_symbols if x in position]
                            for name, value in definitions},
                           {name: Assignment(name.name, print_(value))
                            for name, value in definitions})


def _shared_needed(shared: SharedConstants, exprs) -> list[tuple[sympy.Symbol, sympy.Expr]]:
    """The shared constants' temporaries `exprs` need, directly or not, in their order."""
    stack = [x for value in exprs for x in value.free_symbols if x in shared.needs]
    found: set[sympy.Symbol] = set()
    while stack:
        name = stack.pop()
        if name not in found:
            found.add(name)
            stack += shared.needs[name]
    return [(name, value) for name, value in shared.definitions if name in found]


def lower_function(system: SymbolicSystem, spec: FunctionSpec,
                   printer: PrinterFactory, shared: SharedConstants | None = None
                   ) -> FunctionView:
    """CSE the function's non-zero entries together and print them through `printer`; a
    function with steps computes them first (`_program`). The entries of its blocks whose
    kind repeats are written by a kernel's call each (`_kernels`). `shared`: the named
    constants lowered once, taken as they are."""
    assert tuple(a for a in ARGUMENT_ORDER if a in spec.args) == spec.args, spec.args
    entries = [matrix.todok() for _, matrix in spec.results]  # the non-zeros (sparse or not)
    places = [(r, i, j) for r, found in enumerate(entries)
              for (i, j), value in sorted(found.items()) if value != 0]
    kernel_kinds, instances = kinds(spec.blocks, {
        place: entries[place[0]].get(place[1:], sympy.Integer(0))
        for block in spec.blocks for place in block.places}) if spec.blocks else ((), ())
    covered = {place for instance in instances if instance.terms is None
               for place in instance.places}
    rest = {place: entries[place[0]][place[1:]] for place in places if place not in covered}
    taken: dict[Place, list[sympy.Expr]] = {}
    for instance in instances:  # a sum's blocks: their calls add their terms
        for place, term in zip(instance.places or (), instance.terms or ()):
            taken.setdefault(place, []).append(-term)
    for place, terms in taken.items():  # one sum each: an entry of thousands of terms
        rest[place] = sympy.Add(rest.get(place, sympy.Integer(0)), *terms)
    places = [place for place in places if place in rest and rest[place] != 0]
    exprs = [rest[place] for place in places]
    # each call's arguments follow the entries, as one tuple each
    arguments = [value for instance in instances for group in instance.args for value in group]
    reads, read_slots, writes = _result_reads(system, spec, entries, instances)
    steps = spec.steps
    if shared is not None:  # the constants' groups: one step each
        steps = tuple(group for group in steps if group[0][0] not in shared.rename)
    if reads:
        exprs = [value.xreplace(reads) for value in exprs]
        arguments = [value.xreplace(reads) for value in arguments]
        steps = _read_steps(steps, exprs + arguments, reads)
    names = sympy.numbered_symbols("x")
    program, reduced_all = _program(steps, exprs + arguments, names,
                                    renamed=shared.rename if shared is not None else None)
    definitions, reduced_all = sympy.cse(reduced_all, symbols=names)
    definitions, reduced_all = _split_sums(program + definitions, reduced_all, names)
    taken = _shared_needed(shared, [value for _, value in definitions] + reduced_all) \
        if shared is not None else []
    definitions = taken + definitions
    reduced, call_args = reduced_all[:len(exprs)], reduced_all[len(exprs):]
    inputs = {**slots(system, spec.args), **read_slots}
    _check_inputs(spec.name, definitions, reduced_all, inputs)
    print_ = printer(inputs, [name for name, _ in definitions]).doprint
    printed = {name: shared.printed[name] if shared is not None and name in shared.printed
               else Assignment(name.name, print_(value)) for name, value in definitions}
    kernel_views = tuple(_lower_kernel(f"{spec.name}_{kind.label}_{k}", kind, printer)
                         for k, kind in enumerate(kernel_kinds))
    calls = _calls(spec, kernel_views, instances, call_args, print_)
    # the statements in the order of the results' places: entries and calls
    items = [(place, value, None) for place, value in zip(places, reduced)] + [
        (instance.places[0], sympy.Tuple(*values), call)
        for instance, (values, call) in zip(instances, calls)]
    # a sum's calls after every entry (they add to the entries)
    items.sort(key=lambda item: (item[2] is not None and item[2].accumulate, item[0]))
    if writes:
        items = _after_writers(items, writes, definitions)
    order = _demand_order(definitions, [value for _, value, _ in items])
    results_entries: list[list[Entry]] = [[] for _ in spec.results]
    statements: list[Statement] = []
    for ((r, i, j), value, call), needed in zip(items, order):
        statements += [Statement(-1, printed[name]) for name in needed]
        if call is not None:
            statements.append(Statement(-2, call=call))
            continue
        cols = spec.results[r][1].cols
        index = (i,) if spec.flatten else (i, j)
        results_entries[r].append(Entry(index, i * cols + j, print_(value)))
        statements.append(Statement(r, entry=results_entries[r][-1]))
    written = [sum(1 for place in covered if place[0] == r) for r in range(len(spec.results))]
    results = tuple(ResultView(name, _shape(matrix, spec.flatten), tuple(found), count)
                    for (name, matrix), found, count in zip(spec.results, results_entries,
                                                            written))
    computed = (("pose", len(system.q), "tree_pose", tuple(
        f.args for f in interface.FUNCTIONS if f.name == "tree_pose")[0]),) if spec.pose else ()
    return FunctionView(spec.name, spec.args, spec.summary, tuple(printed.values()), results,
                        tuple(statements), spec.name in IEEE_FUNCTIONS, kernel_views, computed)


def _result_reads(system: SymbolicSystem, spec: FunctionSpec, entries, instances):
    """What a function reads back instead of computing again (FunctionSpec.reads_results,
    pose): step symbol -> the symbol of the slot holding it, each slot symbol's text, and
    per slot symbol written by a kernel's call, that call's first place."""
    reads: dict[sympy.Symbol, sympy.Symbol] = {}
    texts: dict[sympy.Symbol, str] = {}
    writes: dict[sympy.Symbol, tuple[int, int, int]] = {}

    def slot(symbol: sympy.Symbol, text: str) -> sympy.Symbol:
        reads[symbol] = sympy.Symbol(f"#{text}")  # '#' keeps it apart from the model's
        texts[reads[symbol]] = text
        return reads[symbol]

    if spec.pose:
        for k, symbol in enumerate(system.q):
            slot(symbol, f"pose[{k}]")
    if spec.reads_results:
        defined = {symbol for group in spec.steps for symbol, _ in group}
        for instance in instances:
            if instance.terms is not None:
                continue
            for r, i, j in instance.places:
                value = entries[r].get((i, j))
                if value in defined and value not in reads:
                    name, matrix = spec.results[r]
                    writes[slot(value, f"{name}[{i * matrix.cols + j}]")] = instance.places[0]
    return reads, texts, writes


def _read_steps(steps: tuple[Group, ...], exprs, reads: dict) -> tuple[Group, ...]:
    """The steps `exprs` need when the symbols of `reads` are read from their slots: their
    own steps dropped, and in the others they are renamed to their slots."""
    needed = set().union(*(value.free_symbols for value in exprs))
    kept: list[Group] = []
    for group in reversed(steps):
        group = tuple((symbol, value.xreplace(reads)) for symbol, value in group
                      if symbol in needed and symbol not in reads)
        if group:
            kept.append(group)
            needed |= set().union(*(value.free_symbols for _, value in group))
    kept.reverse()
    return tuple(kept)


def _after_writers(items: list, writes: dict, definitions) -> list:
    """`items` (place, value, call) in their order but each after the calls writing the
    slots it reads, directly or through the temporaries it needs (a child placed before its
    parent in the coordinates' order)."""
    reading: dict[sympy.Symbol, frozenset] = {}
    for name, value in definitions:
        found = {writes[s] for s in value.free_symbols if s in writes}
        for s in value.free_symbols:
            found |= reading.get(s, frozenset())
        reading[name] = frozenset(found)
    written: set = set()
    waiting: dict[tuple, list] = {}
    ordered: list = []

    def needs(item) -> set:
        place, value, call = item
        found = {writes[s] for s in value.free_symbols if s in writes}
        for s in value.free_symbols:
            found |= reading.get(s, frozenset())
        return found - written - ({place} if call is not None else set())

    def emit(item) -> None:
        ordered.append(item)
        if item[2] is not None:
            written.add(item[0])
            for other in waiting.pop(item[0], []):
                place(other)

    def place(item) -> None:
        missing = needs(item)
        if missing:
            waiting.setdefault(min(missing), []).append(item)
        else:
            emit(item)

    for item in items:
        place(item)
    assert not waiting, "a read of a slot no call writes"
    return ordered


def _lower_kernel(name: str, kind, printer: PrinterFactory) -> KernelView:
    """A kind's kernel: its steps and outputs over its argument groups' arrays, as a
    function's body (one CSE), every output an entry of `out`."""
    inputs = {x: f"{group}[{k}]" for group, placeholders in kind.groups
              for k, x in enumerate(placeholders)}
    names = sympy.numbered_symbols("x")
    program, exprs = _program(kind.steps, list(kind.outputs), names)
    definitions, reduced = sympy.cse(exprs, symbols=names)
    definitions, reduced = _split_sums(program + definitions, reduced, names)
    _check_inputs(name, definitions, reduced, inputs)
    print_ = printer(inputs, [symbol for symbol, _ in definitions]).doprint
    printed = {symbol: Assignment(symbol.name, print_(value)) for symbol, value in definitions}
    statements: list[Statement] = []
    for k, (value, needed) in enumerate(zip(reduced, _demand_order(definitions, reduced))):
        statements += [Statement(-1, printed[symbol]) for symbol in needed]
        statements.append(Statement(0, entry=Entry((k,), k, print_(value))))
    return KernelView(name, tuple((group, len(placeholders))
                                  for group, placeholders in kind.groups),
                      len(kind.outputs), tuple(statements))


_SLOT = re.compile(r"^([A-Za-z_]\w*)\[(\d+)\]$")


def _calls(spec: FunctionSpec, kernels: tuple[KernelView, ...], instances, values, print_
           ) -> list[tuple[list[sympy.Expr], Call]]:
    """Each instance's call: its arguments (reduced, in order) and the Call that passes them
    (a group of consecutive slots of one array as a pointer into it)."""
    calls = []
    start = 0
    for instance in instances:
        kernel = kernels[instance.kind]
        count = sum(size for _, size in kernel.groups)
        mine = values[start:start + count]
        start += count
        args, pointers, offset = [], [], 0
        for group, size in kernel.groups:
            texts = tuple(print_(value) for value in mine[offset:offset + size])
            offset += size
            args.append((group, texts))
            pointers.append(_pointer(texts))
        outputs = tuple((r, i * spec.results[r][1].cols + j) for r, i, j in instance.places)
        results = {r for r, _ in outputs}
        flats = [flat for _, flat in outputs]
        out, accumulate = None, instance.terms is not None
        if not accumulate and len(results) == 1 \
                and flats == list(range(flats[0], flats[0] + len(flats))):
            out = _offset(spec.results[outputs[0][0]][0], flats[0])
        calls.append((mine, Call(kernel.name, tuple(args), tuple(pointers), outputs, out,
                                 accumulate)))
    return calls


def _pointer(texts: tuple[str, ...]) -> str | None:
    """`q + 12` when the texts are q[12], q[13], ... in order; else None."""
    found = [_SLOT.match(text) for text in texts]
    if not all(found) or len({m.group(1) for m in found}) != 1:
        return None
    first = int(found[0].group(2))
    if [int(m.group(2)) for m in found] != list(range(first, first + len(found))):
        return None
    return _offset(found[0].group(1), first)


def _offset(array: str, start: int) -> str:
    return array if start == 0 else f"{array} + {start}"


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


def _program(steps: tuple[Group, ...], exprs: list[sympy.Expr], names, step_prefix: str = "s",
             renamed: dict | None = None
             ) -> tuple[list[tuple[sympy.Symbol, sympy.Expr]], list[sympy.Expr]]:
    """The steps the results need, as temporaries in order (each step's symbol renamed
    <step_prefix><k>, the CSE of a window of groups before it), and the results in those
    names. A window gathers consecutive groups while none refers to a symbol defined in it,
    so each member's few terms share their sines and cosines with its neighbours' without one
    CSE over the whole tree. `renamed`: symbols already lowered (SharedConstants), by their
    names."""
    kept = needed_steps(steps, exprs)  # only what the results need: no C variable unused
    rename: dict[sympy.Symbol, sympy.Expr] = dict(renamed or {})
    steps_named = sympy.numbered_symbols(step_prefix)
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
                 tangents: bool = False, kernels: bool = False,
                 lowered: Callable[[ModuleView, FunctionView], None] | None = None
                 ) -> ModuleView:
    """The whole module's view-model: header constants and every function (those of
    IEEE_FUNCTIONS printed by `ieee_printer` when the backend's own printer is not IEEE),
    with `tangents` also the tangent functions (interface.TANGENTS); with `kernels` the
    system's repeated blocks as kernels (a backend that writes them: C). `lowered(header,
    function)` is told of each function as soon as it is lowered, in order, with the module
    so far (no functions): a backend may write a function's code while the next is lowered."""
    rows, cols = zip(*system.phi_q_pattern) if system.phi_q_pattern else ((), ())
    values = {
        "COORDINATES": system.coordinates, "PARAMETERS": tuple(p.name for p in model.params),
        "PARAMETER_DEFAULTS": tuple(float(p.default) for p in model.params),
        "PARAMETER_UNITS": tuple(p.unit for p in model.params),
        "CONSTRAINTS": system.constraint_names, "CONSTRAINT_JOINTS": system.constraint_joints,
        "CONSTRAINT_HINGES": system.constraint_hinges,
        "CONSTRAINT_SLIDERS": system.constraint_sliders,
        "PHI_Q_ROWS": tuple(rows), "PHI_Q_COLS": tuple(cols), "HINGES": system.hinge_names,
        "HINGE_WRAPS": system.hinge_wraps,
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
    # the named constants lowered once for the functions with blocks (a backend with kernels)
    shared = shared_constants(system, printer) if kernels and system.constants else None
    counts = {"NQ": len(system.coordinates), "NC": len(system.constraint_names),
              "NP": len(model.params)}
    sizes = tuple((s.field, s.constant, counts.get(s.constant, len(values.get(s.constant, ()))))
                  for s in interface.SIZES)
    header = ModuleView(
        model_name=model.name, description=model.description,
        source_file=model.source_file.replace("\\", "/").rsplit("/", 1)[-1],
        source_sha256=model.source_sha256, depsim_version=depsim_version,
        sizes=sizes, tables=tables,
        t_end=model.simulation.t_end, tol=model.simulation.tol, dt_out=model.simulation.dt_out,
        functions=(), tangents=tangents,
    )
    functions = []
    for spec in function_specs(system, tangents, kernels):
        functions.append(lower_function(system, spec, ieee_printer if ieee_printer is not None
                                        and spec.name in IEEE_FUNCTIONS else printer,
                                        shared if spec.blocks else None))
        if lowered is not None:
            lowered(header, functions[-1])
    return replace(header, functions=tuple(functions))
