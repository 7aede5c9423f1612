"""lower: a SymbolicSystem to view-models of plain strings and ints, ready for a template.

Each generated function's expressions go through one `sympy.cse`; temporaries and results are
printed by a backend printer (printing.py) that maps input symbols to array slots. Results keep
only their structurally non-zero entries (the arrays start as zeros)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import sympy

from depsim.dsl import ir

from .derive import HINGE_PROPERTIES, SymbolicSystem, column
from .printing import LoweringError, SlotPrinter

PrinterFactory = Callable[..., SlotPrinter]  # (slots, temporaries) -> printer

# Argument names and order, shared by every backend (docs/generated-module.md).
ARGUMENT_ORDER = ("q", "qd", "t", "p")


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
class FunctionView:
    """One generated function: arguments (names from ARGUMENT_ORDER), a one-line summary,
    CSE temporaries in evaluation order, and its results (more than one: returned as a tuple)."""

    name: str
    args: tuple[str, ...]
    summary: str
    temporaries: tuple[Assignment, ...]
    results: tuple[ResultView, ...]


@dataclass(frozen=True)
class ModuleView:
    """Everything a generated module contains, as plain data (docs/generated-module.md)."""

    model_name: str
    description: str
    source_file: str
    source_sha256: str
    depsim_version: str
    coordinates: tuple[str, ...]
    parameters: tuple[str, ...]
    parameter_defaults: tuple[float, ...]
    parameter_units: tuple[str, ...]
    constraints: tuple[str, ...]
    constraint_joints: tuple[str, ...]
    phi_q_rows: tuple[int, ...]
    phi_q_cols: tuple[int, ...]
    hinges: tuple[str, ...]
    hinge_properties: tuple[str, ...]
    sliders: tuple[str, ...]
    outputs: tuple[str, ...]
    output_units: tuple[str, ...]
    energies: tuple[str, ...]
    dissipators: tuple[str, ...]
    t_end: float
    tol: float
    dt_out: float
    functions: tuple[FunctionView, ...]


@dataclass(frozen=True)
class FunctionSpec:
    """What to lower: a function's name, arguments, summary and named result matrices."""

    name: str
    args: tuple[str, ...]
    summary: str
    results: tuple[tuple[str, sympy.MatrixBase], ...]
    flatten: bool = True  # (n, 1) columns become 1-d arrays


def function_specs(system: SymbolicSystem) -> tuple[FunctionSpec, ...]:
    """The generated functions of docs/generated-module.md, in module order."""
    s = system
    phi_q_values = column(s.phi_q[i, j] for i, j in s.phi_q_pattern)
    return (
        FunctionSpec("mass_matrix", ("p",), "Constant mass matrix M, shape (NQ, NQ).",
                     (("M", s.mass_matrix),), flatten=False),
        FunctionSpec("initial_state", ("p",), "Assembled initial pose and velocities (q0, qd0).",
                     (("q0", s.q0), ("qd0", s.qd0))),
        FunctionSpec("phi", ("q", "t", "p"), "Constraint residuals Phi(q, t), shape (NC,).",
                     (("phi", s.phi),)),
        FunctionSpec("phi_q", ("q", "t", "p"), "Values of Phi_q at (PHI_Q_ROWS, PHI_Q_COLS).",
                     (("phi_q", phi_q_values),)),
        FunctionSpec("phi_t", ("q", "t", "p"), "dPhi/dt, shape (NC,).", (("phi_t", s.phi_t),)),
        FunctionSpec("gamma", ("q", "qd", "t", "p"),
                     "Right side of Phi_q qdd = gamma, shape (NC,).", (("gamma", s.gamma),)),
        FunctionSpec("force", ("q", "qd", "t", "p"),
                     "Generalized applied force f = -dV/dq + friction + damping, shape (NQ,).",
                     (("f", s.force),)),
        FunctionSpec("hinge_angles", ("q", "p"), "Hinge angles theta (rad), shape (NH,).",
                     (("theta", s.hinge_angles),)),
        FunctionSpec("hinge_rates", ("q", "qd", "p"), "Hinge angle rates (rad/s), shape (NH,).",
                     (("theta_rate", s.hinge_rates),)),
        FunctionSpec("hinge_jacobian", ("q", "p"), "d theta / d q, shape (NH, NQ).",
                     (("J", s.hinge_jacobian),), flatten=False),
        FunctionSpec("hinge_gamma", ("q", "qd", "p"),
                     "-(J qd)_q qd per hinge: a locked hinge adds the row J qdd = hinge_gamma.",
                     (("gamma_h", s.hinge_gamma),)),
        FunctionSpec("hinge_properties", ("p",),
                     "HINGE_PROPERTIES of each hinge (SI; nan: not given), shape (NH, NHP).",
                     (("H", s.hinge_properties),), flatten=False),
        FunctionSpec("outputs", ("q", "qd", "t", "p"), "The named outputs, shape (NOUT,).",
                     (("y", s.outputs),)),
        FunctionSpec("energy", ("q", "qd", "t", "p"),
                     "Kinetic energy and each potential (J), in the order of ENERGIES.",
                     (("E", s.energy),)),
        FunctionSpec("dissipation", ("q", "qd", "t", "p"),
                     "Power removed by each element of DISSIPATORS (W).",
                     (("P", s.dissipation),)),
    )


def slots(system: SymbolicSystem, args: tuple[str, ...]) -> dict[sympy.Symbol, str]:
    """Input symbol -> array slot text (`q[3]`, `p[7]`, `t`) for a function's arguments."""
    arrays = {"q": system.q, "qd": system.qd, "p": system.p}
    table = {system.t: "t"} if "t" in args else {}
    for name in args:
        table.update({s: f"{name}[{i}]" for i, s in enumerate(arrays.get(name, ()))})
    return table


def lower_function(system: SymbolicSystem, spec: FunctionSpec,
                   printer: PrinterFactory) -> FunctionView:
    """CSE the function's non-zero entries together and print them through `printer`."""
    assert tuple(a for a in ARGUMENT_ORDER if a in spec.args) == spec.args, spec.args
    places = [(r, i, j) for r, (_, matrix) in enumerate(spec.results)
              for i in range(matrix.rows) for j in range(matrix.cols) if matrix[i, j] != 0]
    exprs = [spec.results[r][1][i, j] for r, i, j in places]
    definitions, reduced = sympy.cse(exprs, symbols=sympy.numbered_symbols("x"))
    inputs = slots(system, spec.args)
    _check_inputs(spec.name, definitions, reduced, inputs)
    print_ = printer(inputs, [name for name, _ in definitions]).doprint
    temporaries = tuple(Assignment(name.name, print_(value)) for name, value in definitions)
    entries: list[list[Entry]] = [[] for _ in spec.results]
    for (r, i, j), value in zip(places, reduced):
        cols = spec.results[r][1].cols
        index = (i,) if spec.flatten else (i, j)
        entries[r].append(Entry(index, i * cols + j, print_(value)))
    results = tuple(ResultView(name, _shape(matrix, spec.flatten), tuple(found))
                    for (name, matrix), found in zip(spec.results, entries))
    return FunctionView(spec.name, spec.args, spec.summary, temporaries, results)


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


def lower_module(model: ir.Model, system: SymbolicSystem, printer: PrinterFactory,
                 depsim_version: str) -> ModuleView:
    """The whole module's view-model: header constants and every function."""
    rows, cols = zip(*system.phi_q_pattern) if system.phi_q_pattern else ((), ())
    return ModuleView(
        model_name=model.name, description=model.description,
        source_file=model.source_file.replace("\\", "/").rsplit("/", 1)[-1],
        source_sha256=model.source_sha256, depsim_version=depsim_version,
        coordinates=system.coordinates,
        parameters=tuple(p.name for p in model.params),
        parameter_defaults=tuple(float(p.default) for p in model.params),
        parameter_units=tuple(p.unit for p in model.params),
        constraints=system.constraint_names, constraint_joints=system.constraint_joints,
        phi_q_rows=tuple(rows), phi_q_cols=tuple(cols),
        hinges=system.hinge_names, hinge_properties=HINGE_PROPERTIES, sliders=system.slider_names,
        outputs=system.output_names, output_units=tuple(o.unit for o in model.outputs),
        energies=system.energy_names, dissipators=system.dissipator_names,
        t_end=model.simulation.t_end, tol=model.simulation.tol, dt_out=model.simulation.dt_out,
        functions=tuple(lower_function(system, spec, printer) for spec in function_specs(system)),
    )
