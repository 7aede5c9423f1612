"""The model interface, defined once: what every generated model provides to the integrator.

A model is a set of sizes, name tables, simulation settings and the functions below. The
NumPy module (`<model>.py`) has them as constants and functions, the C model (`model.c`) as
the fields of one `dep_model` struct (runtime/c/depsim_model.h). Everything else is derived
from the tables here: codegen emits the functions in this order with these arguments and
results, the C header is rendered from them (depsim.codegen.interface_header; a test keeps the
file in runtime/c/include equal to it), and the runtime fills a `dep_model` from a NumPy
module with them.

    python -m depsim.codegen.interface_header > runtime/c/include/depsim_model.h

Arrays are float64 in SI units; q, qd have NQ entries, p NP; t is the time (s); v holds the
values of the assembly tree's joints (NV: angles, rad, and slider displacements, m), vd their
rates; lam holds NC multipliers (the constraint rows' forces); w holds the NW run values an
output may use, which the integrator keeps (RUN_VALUES: each hinge's lock torque, nan while
free, then each slider entry's lock force, docs/language.md, slider; the work each of the model's dissipators removed; the work of friction, of compliant
latches and of impacts; the compliant latches' potential energy). Matrices are row-major. A
function writes every entry of its results (zeros included). A tangent function (TANGENTS,
generated on request) also takes a direction d<x> of the length of x for each argument x but t.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ABI = 14  # DEP_MODEL_ABI: bumped whenever the dep_model struct changes

VALUES = ("v", "vd", "q", "qd", "t", "p", "lam", "w")  # the arguments of the model's state
# The direction of each value but t (same length): d<value>, along which a tangent
# differentiates (TANGENTS).
DIRECTIONS = tuple(f"d{name}" for name in VALUES if name != "t")
ARGUMENTS = VALUES + DIRECTIONS  # each function takes a subsequence, in this order


@dataclass(frozen=True, slots=True)
class Size:
    """A size of the model: the dep_model field, the module constant giving it (a count, or
    the table whose length it is) and what it counts."""

    field: str
    constant: str
    meaning: str


@dataclass(frozen=True, slots=True)
class Table:
    """A constant table: dep_model field, module constant, C element type, length (a size
    field) and a note."""

    field: str
    constant: str
    ctype: str
    size: str
    note: str


@dataclass(frozen=True, slots=True)
class Output:
    """One result array of a function: its name and shape in size fields (row-major)."""

    name: str
    shape: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class Function:
    """A model function: name, arguments (from ARGUMENTS, in that order), results, summary."""

    name: str
    args: tuple[str, ...]
    results: tuple[Output, ...]
    summary: str


IDENTITY = (  # (dep_model field, module constant)
    ("name", "MODEL_NAME"), ("description", "DESCRIPTION"), ("source_file", "SOURCE_FILE"),
    ("source_sha256", "SOURCE_SHA256"), ("depsim_version", "DEPSIM_VERSION"),
)

SIZES = (
    Size("nq", "NQ", "coordinates"),
    Size("nc", "NC", "constraint rows"),
    Size("np", "NP", "parameters"),
    Size("nnz", "PHI_Q_ROWS", "structural non-zeros of Phi_q"),
    Size("nh", "HINGES", "hinges"),
    Size("nhp", "HINGE_PROPERTIES", "hinge properties"),
    Size("ns", "SLIDERS", "sliders"),
    Size("nout", "OUTPUTS", "outputs"),
    Size("ne", "ENERGIES", "energy terms"),
    Size("nd", "DISSIPATORS", "dissipators"),
    Size("nv", "TREE_JOINTS", "joints of the assembly tree"),
    Size("ni", "INPUTS", "inputs (external loads a run or a co-simulation drives)"),
    Size("nhnz", "HINGE_JACOBIAN_ROWS", "structural non-zeros of hinge_jacobian"),
    Size("nkz", "STIFFNESS_ROWS", "structural non-zeros of the stiffness (0: no beams)"),
    Size("nmz", "MASS_ROWS", "structural non-zeros of the mass matrix"),
    Size("nfix", "FIXED_PARAMETERS", "structural parameters (loop bounds, indices): fixed"),
    Size("nw", "RUN_VALUES", "run values outputs may use: nh + nd + 4"),
    Size("nsys", "SYSTEM_STATE", "the system's quantities of system_state"),
    Size("nlim", "LIMITS", "range checks of the parameters (the model text's)"),
    Size("nlimp", "LIMIT_PARAMETER_ROWS", "(range check, parameter) pairs it depends on"),
)

TABLES = (
    Table("coordinate_names", "COORDINATES", "const char *const", "nq", ""),
    Table("parameter_names", "PARAMETERS", "const char *const", "np", ""),
    Table("parameter_defaults", "PARAMETER_DEFAULTS", "const double", "np", "SI"),
    Table("parameter_units", "PARAMETER_UNITS", "const char *const", "np", "SI unit text"),
    Table("constraint_names", "CONSTRAINTS", "const char *const", "nc",
          '"<joint>.<component>"'),
    Table("constraint_joints", "CONSTRAINT_JOINTS", "const char *const", "nc", ""),
    Table("constraint_hinges", "CONSTRAINT_HINGES", "const int", "nc",
          "the hinge (index into hinge_names) whose row it is, -1 for none; a hinge's rows in "
          "component order (x, y): its reaction force"),
    Table("constraint_sliders", "CONSTRAINT_SLIDERS", "const int", "nc",
          "the slider (index into slider_names) whose row it is, -1 for none"),
    Table("phi_q_rows", "PHI_Q_ROWS", "const int", "nnz", "row-major sorted"),
    Table("phi_q_cols", "PHI_Q_COLS", "const int", "nnz", ""),
    Table("hinge_names", "HINGES", "const char *const", "nh", ""),
    Table("hinge_property_names", "HINGE_PROPERTIES", "const char *const", "nhp",
          "columns of hinge_properties()"),
    Table("hinge_wraps", "HINGE_WRAPS", "const int", "nh",
          "1: the angle is measured within half a turn of the middle of its travel (a "
          "spatial hinge, atan2) and the motion depends on it, so a run stops where it "
          "turns past that; 0: it is continuous (a planar hinge, a slider's entry) or "
          "nothing loads by it"),
    Table("slider_names", "SLIDERS", "const char *const", "ns", ""),
    Table("output_names", "OUTPUTS", "const char *const", "nout", ""),
    Table("output_units", "OUTPUT_UNITS", "const char *const", "nout", ""),
    Table("energy_names", "ENERGIES", "const char *const", "ne", ""),
    Table("dissipator_names", "DISSIPATORS", "const char *const", "nd", ""),
    Table("tree_joints", "TREE_JOINTS", "const char *const", "nv",
          "the joints placing the members at t = 0, in placement order"),
    Table("tree_held", "TREE_HELD", "const int", "nv",
          "1: its initial value is given, 2: its rate, 3: both (held by the assembly)"),
    Table("hinge_jacobian_rows", "HINGE_JACOBIAN_ROWS", "const int", "nhnz",
          "row-major sorted: where d theta / d q can be non-zero (a lock row's pattern)"),
    Table("hinge_jacobian_cols", "HINGE_JACOBIAN_COLS", "const int", "nhnz", ""),
    Table("input_names", "INPUTS", "const char *const", "ni", ""),
    Table("input_units", "INPUT_UNITS", "const char *const", "ni", "SI unit text"),
    Table("input_slots", "INPUT_SLOTS", "const int", "ni",
          "u_k(t) = p[slot] + p[slot + 1] t: the parameters holding input k"),
    Table("stiffness_rows", "STIFFNESS_ROWS", "const int", "nkz",
          "row-major sorted: where the stiff forces' Jacobian can be non-zero"),
    Table("stiffness_cols", "STIFFNESS_COLS", "const int", "nkz", ""),
    Table("mass_rows", "MASS_ROWS", "const int", "nmz",
          "row-major sorted: where the mass matrix is non-zero (its diagonal for rigid bodies)"),
    Table("mass_cols", "MASS_COLS", "const int", "nmz", ""),
    Table("fixed_names", "FIXED_PARAMETERS", "const char *const", "nfix",
          "structural parameters: fixed in the model text, not in p"),
    Table("fixed_values", "FIXED_VALUES", "const int", "nfix", "their values"),
    Table("run_value_names", "RUN_VALUES", "const char *const", "nw",
          "\"<h>.torque\" per hinge, \"work.<dissipator>\" per dissipator, then "
          "\"work.friction\", \"work.latch\", \"work.impacts\", \"energy.latch\""),
    Table("system_state_names", "SYSTEM_STATE", "const char *const", "nsys",
          "columns of system_state(): mass, com_x, com_y, momentum_x, momentum_y, "
          "angular_momentum (about the centre of mass)"),
    Table("limit_names", "LIMITS", "const char *const", "nlim",
          "what each range check tests, e.g. \"rod.length\", in the model text's order"),
    Table("limit_kinds", "LIMIT_KINDS", "const int", "nlim",
          "enum dep_limit_kind: value > 0, >= 0, != 0, < bound, >= bound"),
    Table("limit_messages", "LIMIT_MESSAGES", "const char *const", "nlim",
          "the check broken in words, a printf format of the value and the bound (%g each, "
          "in that order; %% a percent sign)"),
    Table("limit_parameter_rows", "LIMIT_PARAMETER_ROWS", "const int", "nlimp",
          "row-major sorted: range check i depends on parameter j"),
    Table("limit_parameter_cols", "LIMIT_PARAMETER_COLS", "const int", "nlimp", ""),
)

SETTINGS = (("t_end", "T_END"), ("tol", "TOL"), ("dt_out", "DT_OUT"))

FUNCTIONS = (
    Function("mass_matrix", ("p",), (Output("M", ("nmz",)),),
             "Values of the constant mass matrix M at (MASS_ROWS, MASS_COLS)."),
    Function("tree_values", ("p",), (Output("v0", ("nv",)), Output("vd0", ("nv",))),
             "The tree joints' initial values and rates (given, else 0)."),
    Function("tree_pose", ("v", "p"), (Output("q", ("nq",)),),
             "The pose placed along the assembly tree with joint values v, shape (NQ,)."),
    Function("tree_tangent", ("v", "vd", "p"), (Output("qd", ("nq",)),),
             "d tree_pose / d v times the joint rates vd: the tree's velocities, shape (NQ,)."),
    Function("loop_targets", ("p",), (Output("angle", ("nh",)), Output("rate", ("nh",))),
             "Given initial angle and rate of each hinge closing a loop (nan: not given)."),
    Function("phi", ("q", "t", "p"), (Output("phi", ("nc",)),),
             "Constraint residuals Phi(q, t), shape (NC,)."),
    Function("phi_q", ("q", "t", "p"), (Output("phi_q", ("nnz",)),),
             "Values of Phi_q at (PHI_Q_ROWS, PHI_Q_COLS)."),
    Function("phi_q_transpose_times", ("q", "t", "p", "lam"), (Output("f", ("nq",)),),
             "Phi_q^T lam for multipliers lam (NC,): the constraints' generalized force, shape "
             "(NQ,)."),
    Function("phi_t", ("q", "t", "p"), (Output("phi_t", ("nc",)),),
             "dPhi/dt, shape (NC,)."),
    Function("gamma", ("q", "qd", "t", "p"), (Output("gamma", ("nc",)),),
             "Right side of Phi_q qdd = gamma, shape (NC,)."),
    Function("force", ("q", "qd", "t", "p"), (Output("f", ("nq",)),),
             "Generalized applied force f = -dV/dq + damping (no hinge friction), shape (NQ,)."),
    Function("hinge_angles", ("q", "p"), (Output("theta", ("nh",)),),
             "Hinge angles theta (rad), shape (NH,)."),
    Function("hinge_rates", ("q", "qd", "p"), (Output("theta_rate", ("nh",)),),
             "Hinge angle rates (rad/s), shape (NH,)."),
    Function("hinge_jacobian", ("q", "p"), (Output("J", ("nhnz",)),),
             "Values of d theta / d q at (HINGE_JACOBIAN_ROWS, HINGE_JACOBIAN_COLS)."),
    Function("hinge_gamma", ("q", "qd", "p"), (Output("gamma_h", ("nh",)),),
             "-(J qd)_q qd per hinge: a locked hinge adds the row J qdd = hinge_gamma."),
    Function("hinge_properties", ("p",), (Output("H", ("nh", "nhp")),),
             "HINGE_PROPERTIES of each hinge (SI; nan: not given), shape (NH, NHP)."),
    Function("outputs", ("q", "qd", "t", "p", "lam", "w"), (Output("y", ("nout",)),),
             "The named outputs, shape (NOUT,), from the state, the model rows' multipliers "
             "lam (NC,) and the run values w (NW,)."),
    Function("system_state", ("q", "qd", "p"), (Output("s", ("nsys",)),),
             "The whole system's mass (kg), centre of mass (m), momentum (N*s) and angular "
             "momentum about its centre of mass (N*m*s), in the order of SYSTEM_STATE."),
    Function("energy", ("q", "qd", "t", "p"), (Output("E", ("ne",)),),
             "Kinetic energy and each potential (J), in the order of ENERGIES."),
    Function("dissipation", ("q", "qd", "t", "p"), (Output("P", ("nd",)),),
             "Power removed by each element of DISSIPATORS (W)."),
    Function("coordinate_scales", ("p",), (Output("s", ("nq",)),),
             "The size (SI) each coordinate's errors are measured against: the model's length "
             "(its largest member's) for a position, 1 for an angle or a beam's slope."),
    Function("stiffness", ("q", "p"), (Output("K", ("nkz",)), Output("D", ("nkz",))),
             "The stiff forces' Jacobian of a model with beams, K ~ -df/dq and D ~ -df/dqd, at "
             "(STIFFNESS_ROWS, STIFFNESS_COLS)."),
    Function("parameter_checks", ("p",), (Output("value", ("nlim",)),
                                          Output("bound", ("nlim",))),
             "Each range check's value and its bound (kinds below and at_least; else 0)."),
)

FUNCTION_NAMES = tuple(f.name for f in FUNCTIONS)


# ---- tangents (forward sensitivities) -------------------------------------------------------
# A tangent of a function F(x_1, ..., t, ...) is d/de F(x_1 + e dx_1, ..., t, ...) at e = 0:
# its directional derivative along directions dx of every argument but t. A model has them
# only when compiled with `tangents=True` (all of them or none: check_module); in dep_model
# they follow the functions, NULL when not generated, and `tangents` is 1 when they are.

TANGENT_FLAG = "tangents"  # the dep_model field: 1 when the model has TANGENTS, else 0

# The functions with a tangent, and a note on what theirs gives beyond the derivative.
TANGENT_BASES = {
    "mass_matrix": "", "tree_values": "", "tree_pose": "", "tree_tangent": "",
    "loop_targets": "; 0 where the base is nan (not given)",
    "phi": "", "phi_q": "", "phi_t": "", "gamma": "", "force": "", "hinge_angles": "",
    "hinge_rates": "", "hinge_jacobian": "", "hinge_gamma": "",
    "hinge_properties": "; 0 where the base is nan (a property not given)",
    "outputs": "; with IEEE arithmetic, as outputs (nan or inf outside a function's domain)",
}


def direction(argument: str) -> str:
    """The direction argument of a value argument: `q` -> `dq`."""
    assert argument in VALUES and argument != "t", argument
    return f"d{argument}"


def tangent_name(name: str) -> str:
    """The tangent function's name of a base function: `phi` -> `phi_tangent`."""
    return f"{name}_tangent"


def _shape_text(output: Output) -> str:
    return "(" + ", ".join(s.upper() for s in output.shape) + ("," if len(output.shape) == 1
                                                                else "") + ")"


def tangent(function: Function) -> Function:
    """The tangent of a base function: its arguments, then the directions of all but t; its
    results' shapes, each named d<name>; a summary saying what it computes."""
    varied = tuple(a for a in function.args if a != "t")
    moved = ", ".join(a if a == "t" else f"{a} + e {direction(a)}" for a in function.args)
    results = tuple(Output(f"d{r.name}", r.shape) for r in function.results)
    if len(results) == 1:
        shapes = f"shape {_shape_text(results[0])}"
    else:
        shapes = "shapes " + ", ".join(f"{r.name} {_shape_text(r)}" for r in results)
    where = (f": values at ({', '.join(PATTERNS[function.name][:2])})"
             if function.name in PATTERNS else "")
    return Function(tangent_name(function.name),
                    function.args + tuple(direction(a) for a in varied), results,
                    f"d/de {function.name}({moved}) at e = 0{where}, {shapes}"
                    f"{TANGENT_BASES[function.name]}.")


# The functions returning a sparse matrix's values at its pattern: (rows table, columns table,
# the table whose length is the matrix's row count).
PATTERNS = {"phi_q": ("PHI_Q_ROWS", "PHI_Q_COLS", "CONSTRAINTS"),
            "hinge_jacobian": ("HINGE_JACOBIAN_ROWS", "HINGE_JACOBIAN_COLS", "HINGES"),
            "mass_matrix": ("MASS_ROWS", "MASS_COLS", "COORDINATES")}

TANGENTS = tuple(tangent(f) for f in FUNCTIONS if f.name in TANGENT_BASES)
TANGENT_NAMES = tuple(f.name for f in TANGENTS)

# Every name a NumPy module must define (docs/generated-module.md).
MODULE_CONSTANTS = tuple(dict.fromkeys(
    [c for _, c in IDENTITY] + [s.constant for s in SIZES[:3]] + [t.constant for t in TABLES]
    + [c for _, c in SETTINGS]))


def dense(module, function: str, *args) -> np.ndarray:
    """A model function of PATTERNS as the whole matrix (zeros elsewhere), e.g.
    `dense(module, "mass_matrix", p)`: (NQ, NQ); "phi_q": (NC, NQ), "hinge_jacobian": (NH, NQ).
    For analysis and tests; the integrator works on the values at the pattern."""
    rows, cols, count = PATTERNS[function]
    matrix = np.zeros((len(getattr(module, count)), len(module.COORDINATES)))
    matrix[list(getattr(module, rows)), list(getattr(module, cols))] = getattr(module, function)(
        *args)
    return matrix


def initial_state(module, p) -> tuple[np.ndarray, np.ndarray]:
    """The pose and velocities placed along the assembly tree at the joints' initial values
    and rates, (q0, qd0): tree_pose and tree_tangent at tree_values(p), as the runtime starts
    (its assembly then closes any loop the given values leave open)."""
    v0, vd0 = (np.asarray(a, dtype=float) for a in module.tree_values(p))
    return (np.asarray(module.tree_pose(v0, p), dtype=float),
            np.asarray(module.tree_tangent(v0, vd0, p), dtype=float))


def outputs_at(module, q, qd, t: float, p, lam=None, w=None) -> np.ndarray:
    """The module's outputs at a state (NOUT,), the multipliers `lam` (NC) and run values `w`
    (NW) zero unless given: for analysis and tests of outputs that use neither."""
    lam = np.zeros(int(module.NC)) if lam is None else lam
    w = np.zeros(len(module.RUN_VALUES)) if w is None else w
    return np.asarray(module.outputs(q, qd, t, p, lam, w), dtype=float)


def check_module(module) -> None:
    """Raise TypeError naming what a module lacks of the interface (a programming error
    upstream: generated modules have everything): every constant and base function, and
    all of TANGENTS or none."""
    optional = {"DESCRIPTION"}
    missing = [name for name in MODULE_CONSTANTS + FUNCTION_NAMES
               if name not in optional and not hasattr(module, name)]
    if missing:
        raise TypeError(f"{module!r} is not a depsim model module: missing "
                        + ", ".join(missing) + " (see docs/generated-module.md)")
    has_tangents(module)


def has_tangents(module) -> bool:
    """Whether a module has the tangent functions (TANGENTS: a model compiled with
    tangents=True); TypeError when it has some but not all."""
    present = [name for name in TANGENT_NAMES if hasattr(module, name)]
    if present and len(present) < len(TANGENT_NAMES):
        missing = [name for name in TANGENT_NAMES if name not in present]
        raise TypeError(f"{module!r} has some tangent functions but not all: missing "
                        + ", ".join(missing) + " (see docs/generated-module.md)")
    return bool(present)


# ---- the C header ----------------------------------------------------------------------------

_C_ARGUMENTS = {name: "double t" if name == "t" else f"const double *{name}"
                for name in ARGUMENTS}


def c_declaration(function: Function, restrict: bool = False) -> str:
    """The C parameter list of a model function (results last), e.g.
    `const double *q, double t, const double *p, double *phi`. restrict: the results'
    pointers `restrict` (a definition's: a result never shares memory with an argument, and
    the compiler may then keep a loaded q[j] across the stores, so that sin and cos of one
    angle become one sincos)."""
    pointer = "double *restrict " if restrict else "double *"
    return ", ".join([_C_ARGUMENTS[a] for a in function.args]
                     + [f"{pointer}{r.name}" for r in function.results])
