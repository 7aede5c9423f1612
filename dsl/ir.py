"""The checked model IR: what `dsl` hands to `codegen`.

Flat, frozen, indexed by position (like MuJoCo's compiled mjModel): bodies, beams, hinges,
sliders, cables and outputs are tuples, and every reference between them is an index. Every
numeric attribute is an `Expr` tree over the parameter vector (`ParamRef`), already in SI
units; nothing here knows about lark or sympy. `codegen` turns `Expr` trees into sympy
expressions node by node.

Conventions (documented for users in docs/language.md):
* A rigid body's coordinates are (x, y, phi) of its centre of mass; phi is measured from +x,
  counter-clockwise. Points are given in body coordinates relative to the centre of mass.
* A `bar` of length L has points `a` at (-L/2, 0) and `b` at (+L/2, 0).
* A beam of length L has end points `a` (s = 0) and `b` (s = L); its angle at an end is the
  angle of the beam tangent there. Undeformed, the beam lies along its tangent.
* The ground has angle 0 and a point `origin` at (0, 0), plus any declared points.
* Hinge angle: theta = sign * (angle(b) - angle(a)) + offset, where a and b are the two
  members the hinge joins, in the order written (`joins A to B`).
* Slider displacement: s = axis_a . (r_b - r_a), axis a unit vector fixed in member a; the
  slider also keeps angle(b) - angle(a) at its initial value.
* A particle has coordinates (x, y) and no angle: its angle counts as 0, as the ground's, and
  its one point `cm` is where it is. Every rigid member has the point `cm` (0, 0).
* A weld holds r_a = r_b and angle(b) - angle(a) = angle (not the angle with a particle).
* A free joint (floating joint) places member b relative to member a at t = 0: its point at
  (x, y) from a's point in a's frame, turned by `angle`; it has no constraint rows.
* A spring-damper's force acts along the line from its point a to its point b, positive
  pushing the points apart: F = preload - stiffness (L - free_length) - damping dL/dt.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum


@dataclass(frozen=True, slots=True)
class Span:
    """A source range, 1-based lines and columns; end is exclusive."""

    file: str
    line: int
    col: int
    end_line: int
    end_col: int


# ---------------------------------------------------------------------------------------------
# Dimensions (SI base: mass, length, time, plus plane angle so that N*m/rad differs from N*m)
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Dim:
    """Exponents of kg, m, s, rad. Dimensionless is Dim()."""

    mass: int = 0
    length: int = 0
    time: int = 0
    angle: int = 0


# ---------------------------------------------------------------------------------------------
# Expressions. Values are SI. Constant expressions contain only Num, ParamRef, Unary, Binary,
# Call; state expressions (outputs) may also contain the state references below.
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Num:
    value: float


@dataclass(frozen=True, slots=True)
class ParamRef:
    """Entry `index` of the run-time parameter vector (Model.params[index])."""

    index: int


@dataclass(frozen=True, slots=True)
class Unary:
    op: str  # "-"
    arg: Expr


@dataclass(frozen=True, slots=True)
class Binary:
    op: str  # "+", "-", "*", "/", "^"
    left: Expr
    right: Expr


# Functions allowed in expressions; the checker rejects anything else.
FUNCTIONS: dict[str, int] = {
    "sin": 1, "cos": 1, "tan": 1, "asin": 1, "acos": 1, "atan": 1, "atan2": 2,
    "sinh": 1, "cosh": 1, "tanh": 1, "sqrt": 1, "exp": 1, "log": 1, "abs": 1,
    "min": 2, "max": 2,
}


@dataclass(frozen=True, slots=True)
class Call:
    func: str  # a key of FUNCTIONS
    args: tuple[Expr, ...]


@dataclass(frozen=True, slots=True)
class Time:
    """Simulation time t (s)."""


@dataclass(frozen=True, slots=True)
class BodyCoord:
    """A rigid body's coordinate or its rate: coord in x, y, phi, vx, vy, omega."""

    body: int
    coord: str


@dataclass(frozen=True, slots=True)
class PointCoord:
    """World position (axis x or y) or velocity (vx, vy) of a point of a member."""

    member: Member
    point: str
    axis: str


@dataclass(frozen=True, slots=True)
class HingeAngle:
    hinge: int
    rate: bool = False  # True: d(theta)/dt


@dataclass(frozen=True, slots=True)
class SliderPosition:
    slider: int
    rate: bool = False


@dataclass(frozen=True, slots=True)
class BeamQuantity:
    """A beam quantity: `chord` (angle of the chord a->b from +x, rad) or `tip_deflection`
    (signed distance of end b from the tangent line at end a, counter-clockwise positive, m)."""

    beam: int
    kind: str


@dataclass(frozen=True, slots=True)
class JointLoad:
    """A load or value a connector carries (outputs only). kind "hinge": force_x, force_y,
    force (the force on member b from member a, world frame, N), torque (its lock torque,
    N*m, nan while nothing holds it); "weld": the same, torque the moment the weld holds;
    "spring": force (along its line, positive pushing apart, N), length (m), rate (m/s);
    "slider": force (its lock force along the axis on member b, N, nan while nothing holds
    it, 0 for a slider nothing can hold); in a spatial model also force_z and moment_x, ...
    (dsl/state_refs.py, SPATIAL_LOADS), a cylindrical joint's angle, rate, position,
    velocity and a universal joint's angle_a, rate_a, angle_b, rate_b."""

    kind: str
    index: int
    quantity: str


@dataclass(frozen=True, slots=True)
class SystemQuantity:
    """A quantity of the whole system (outputs only, docs/language.md, System outputs):
    mass, com_x, com_y, com_vx, com_vy, momentum_x, momentum_y, angular_momentum (about the
    centre of mass, or about `point` when given), kinetic_energy, potential_energy, energy,
    dissipated, dissipated_friction, dissipated_damping, dissipated_impacts."""

    quantity: str
    point: "Attachment | None" = None


Expr = Num | ParamRef | Unary | Binary | Call | Time | BodyCoord | PointCoord | HingeAngle \
    | SliderPosition | BeamQuantity | JointLoad | SystemQuantity


# ---------------------------------------------------------------------------------------------
# Model elements
# ---------------------------------------------------------------------------------------------


class ParamKind(Enum):
    DECLARED = "param"  # a `param` statement
    ATTRIBUTE = "attribute"  # an element attribute given as a plain quantity, e.g. yoke.mass
    INPUT = "input"  # an input's value at t = 0 or its rate (`T.rate`): u = value + rate t


@dataclass(frozen=True, slots=True)
class Param:
    """One entry of the run-time parameter vector.

    name: `kc` for a declared param, `h2.friction` for an attribute.
    default: SI value. dim: its dimension. unit: SI unit text for display, e.g. "N*m/rad".
    """

    name: str
    default: float
    dim: Dim
    unit: str
    kind: ParamKind
    span: Span


@dataclass(frozen=True, slots=True)
class DerivedName:
    """A name that is not in the parameter vector because its value is an expression of
    params (a param defined from other params, or an attribute written as an expression).
    Kept so `--set` can say which param to set instead."""

    name: str
    depends_on: tuple[str, ...]
    span: Span


class MemberKind(Enum):
    GROUND = "ground"
    BODY = "body"
    BEAM = "beam"
    PARTICLE = "particle"


@dataclass(frozen=True, slots=True)
class Member:
    """A reference to the ground, a rigid body (index into Model.bodies), a beam (index into
    Model.beams) or a particle (index into Model.particles). index is 0 for the ground."""

    kind: MemberKind
    index: int


@dataclass(frozen=True, slots=True)
class Point:
    """A named point in body coordinates (m), relative to the centre of mass (z: a spatial
    model's third coordinate, 0 in a planar one)."""

    name: str
    x: Expr
    y: Expr
    span: Span
    z: Expr = Num(0.0)


@dataclass(frozen=True, slots=True)
class Turn:
    """One factor of an orientation: a right-handed rotation by `angle` (rad) about the axis
    `axis` ("x", "y" or "z") of the frame the factors before it reached. An orientation is a
    tuple of turns, R = R_1 R_2 ... (`orientation = rz(30 deg) * rx(10 deg)`)."""

    axis: str
    angle: Expr


@dataclass(frozen=True, slots=True)
class Ground:
    points: tuple[Point, ...]  # always includes `origin` at (0, 0)


@dataclass(frozen=True, slots=True)
class Body:
    """A rigid body. kind "bar" (points a, b from length) or "body". Planar: `inertia` about
    the centre of mass. Spatial: `principal`, the principal moments of inertia about the
    centre of mass along the axes of the frame `principal_axes` (given in the body frame;
    the body frame itself when empty) or, with `products`, the moments about the body's
    axes and its products of inertia (Pxy, Pyz, Pzx) = integrals of (x y, y z, z x) dm, so
    that the inertia tensor is [[Ixx, -Pxy, -Pzx], [-Pxy, Iyy, -Pyz], [-Pzx, -Pyz, Izz]];
    and `orientation`, the body frame's orientation in the world when every hinge is at its
    zero (docs/language.md, Spatial models)."""

    name: str
    kind: str
    mass: Expr  # kg
    inertia: Expr | None  # kg*m^2 about the centre of mass; None in a spatial model
    length: Expr | None  # m, bars only
    points: tuple[Point, ...]
    span: Span
    principal: tuple[Expr, Expr, Expr] | None = None  # kg*m^2, spatial models only
    principal_axes: tuple[Turn, ...] = ()
    orientation: tuple[Turn, ...] = ()
    products: tuple[Expr, Expr, Expr] | None = None  # kg*m^2, spatial: Pxy, Pyz, Pzx


@dataclass(frozen=True, slots=True)
class Beam:
    """A flexible planar beam with end points `a` and `b`."""

    name: str
    length: Expr  # m
    EI: Expr  # N*m^2
    EA: Expr  # N
    mass_per_length: Expr  # kg/m
    elements: int  # structural: compile-time
    damping: Expr | None  # stiffness-proportional damping coefficient (s), optional
    span: Span


@dataclass(frozen=True, slots=True)
class Particle:
    """A point mass: coordinates (x, y), no angle; its one point is `cm`."""

    name: str
    mass: Expr  # kg
    span: Span


@dataclass(frozen=True, slots=True)
class Attachment:
    member: Member
    point: str  # point name on that member ("a", "b", "origin", or a declared point)
    span: Span


@dataclass(frozen=True, slots=True)
class Hinge:
    """A revolute joint. Optional attributes are None when absent.

    theta = sign * (angle(b) - angle(a)) + offset                      (rad)
    drive spring torque on theta: preload - stiffness * theta           (N*m)
    Coulomb friction: -friction * tanh(theta_rate / slip_rate)          (N*m)
    viscous damping: -damping * theta_rate                              (N*m)
    latch: locks when theta first reaches `latch` (rad); rigid unless latch_stiffness given.
    stops: one-sided limits stop_min <= theta <= stop_max.
    """

    name: str
    a: Attachment
    b: Attachment
    sign: int  # +1 or -1
    offset: Expr  # rad
    stiffness: Expr | None  # N*m/rad
    preload: Expr | None  # N*m
    friction: Expr | None  # N*m (kinetic)
    static_friction: Expr | None  # N*m (stick-slip model when given)
    slip_rate: Expr  # rad/s, tanh regularisation (default 1e-3 rad/s)
    damping: Expr | None  # N*m*s/rad
    latch: Expr | None  # rad
    latch_stiffness: Expr | None  # N*m/rad
    latch_damping: Expr | None  # N*m*s/rad
    stop_min: Expr | None  # rad
    stop_max: Expr | None  # rad
    initial_angle: Expr  # rad
    initial_rate: Expr  # rad/s
    span: Span
    held: int = 0  # the assembly holds: 1 its initial angle (given), 2 its rate, 3 both
    release: Expr | None = None  # s: held locked (a hold-down) from t = 0 until this time
    axis: tuple[Expr, Expr, Expr] | None = None  # spatial: direction in member a's frame


@dataclass(frozen=True, slots=True)
class Slider:
    """A prismatic joint: point b of member b slides along `axis` (fixed in member a) through
    point a of member a; the relative angle stays at its initial value. Optional attributes
    are None when absent: the hinge's toolkit along the axis, on the displacement s (m),

    drive spring force on s: preload - stiffness * s                    (N)
    Coulomb friction: -friction * tanh(s_rate / slip_rate)              (N)
    viscous damping: -damping * s_rate                                  (N)
    latch: locks when s first reaches `latch` (m); rigid unless latch_stiffness given.
    stops: one-sided limits stop_min <= s <= stop_max; release: a hold-down until then (s).
    """

    name: str
    a: Attachment
    b: Attachment
    axis: tuple[Expr, ...]  # direction in member a's frame (normalised by codegen); x, y[, z]
    initial_position: Expr  # m
    initial_rate: Expr  # m/s
    span: Span
    held: int = 0  # the assembly holds: 1 its initial position (given), 2 its rate, 3 both
    stiffness: Expr | None = None  # N/m
    preload: Expr | None = None  # N
    friction: Expr | None = None  # N (kinetic)
    static_friction: Expr | None = None  # N (stick-slip model when given)
    slip_rate: Expr | None = None  # m/s, tanh regularisation (given with friction)
    damping: Expr | None = None  # N*s/m
    latch: Expr | None = None  # m
    latch_stiffness: Expr | None = None  # N/m
    latch_damping: Expr | None = None  # N*s/m
    stop_min: Expr | None = None  # m
    stop_max: Expr | None = None  # m
    release: Expr | None = None  # s


@dataclass(frozen=True, slots=True)
class Weld:
    """A fixed joint: point a of member a and point b of member b coincide (rows x, y) and
    angle(b) - angle(a) = angle (row `angle`, only when `rotational`: a particle has no angle,
    so a weld to one holds the points only)."""

    name: str
    a: Attachment
    b: Attachment
    angle: Expr  # rad, the relative angle angle(b) - angle(a) it holds
    rotational: bool  # False when a member is a particle: the weld holds the points only
    span: Span


# The initial values of a free joint, in the order of its tree values: (suffix, rate suffix).
FREE_VALUES = (("initial_x", "initial_vx"), ("initial_y", "initial_vy"),
               ("initial_angle", "initial_omega"))
# In a spatial model: the position and velocity of b's point from a's, in a's frame, then
# three turns about a's axes x, y, z (always 0 at t = 0: the members' orientations place b)
# whose rates are b's angular velocity relative to a in a's frame.
TURN_VALUES = (("initial_turn_x", "initial_wx"), ("initial_turn_y", "initial_wy"),
               ("initial_turn_z", "initial_wz"))
SPATIAL_FREE_VALUES = (("initial_x", "initial_vx"), ("initial_y", "initial_vy"),
                       ("initial_z", "initial_vz")) + TURN_VALUES


@dataclass(frozen=True, slots=True)
class FreeJoint:
    """A floating joint: member b free relative to member a (no constraint rows). At t = 0 it
    places b (or a) so that b's point is at (x, y) from a's point in a's frame and
    angle(b) - angle(a) = angle, moving at (vx, vy, omega), the rates of those three.
    `initial` holds the six values in FREE_VALUES order (value, rate per coordinate), 0 when
    not given; `held` per coordinate: 1 value given, 2 rate given, 3 both. A particle has no
    angle: `turns` is False and the angle's values are not used."""

    name: str
    a: Attachment
    b: Attachment
    initial: tuple[Expr, ...]  # x, vx, y, vy, angle, omega (m, m/s, rad, rad/s)
    held: tuple[int, ...]
    turns: bool
    span: Span


@dataclass(frozen=True, slots=True)
class Ball:
    """A spherical joint of a spatial model: point a of member a and point b of member b
    coincide (rows x, y, z); b turns freely about it. At t = 0 the members' orientations place
    b; `initial` holds three (value, rate) pairs in TURN_VALUES order: the values 0, the
    rates b's angular velocity relative to a in a's frame (rad/s). `held` as a free joint's."""

    name: str
    a: Attachment
    b: Attachment
    initial: tuple[Expr, ...]
    held: tuple[int, ...]
    span: Span


# The initial values of a cylindrical joint (value, rate suffixes): its turn about the axis
# and its displacement along it.
CYLINDRICAL_VALUES = (("initial_angle", "initial_rate"), ("initial_position", "initial_velocity"))
# A universal joint's: its turn about axis_a (in A), then about axis_b (in B).
UNIVERSAL_VALUES = (("initial_angle_a", "initial_rate_a"), ("initial_angle_b", "initial_rate_b"))


@dataclass(frozen=True, slots=True)
class Cylindrical:
    """A cylindrical joint of a spatial model: b's point moves along `axis` (member a's
    frame) through a's point and b turns about it (rows: the offset normal to the axis, and
    the axis held in b). `initial` holds (angle, rate, position, velocity) in
    CYLINDRICAL_VALUES order: the turn from the members' orientations (rad) and the
    displacement of b's point from a's along the axis (m). `held` per pair, as a free
    joint's."""

    name: str
    a: Attachment
    b: Attachment
    axis: tuple[Expr, Expr, Expr]
    initial: tuple[Expr, ...]
    held: tuple[int, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class Universal:
    """A universal (Hooke's) joint of a spatial model: the points coincide and `axis_a`
    (member a's frame) stays normal to `axis_b` (member b's frame), the cross-piece between
    them; they are normal where the members' orientations place them (a range check). b is
    turned from its orientation by angle_a about axis_a, then angle_b about axis_b;
    `initial` holds (angle_a, rate_a, angle_b, rate_b) in UNIVERSAL_VALUES order."""

    name: str
    a: Attachment
    b: Attachment
    axis_a: tuple[Expr, Expr, Expr]
    axis_b: tuple[Expr, Expr, Expr]
    initial: tuple[Expr, ...]
    held: tuple[int, ...]
    span: Span


class SpringActs(Enum):
    BOTH = "both"  # pushes and pulls
    PUSH = "push"  # only while shorter than its free length, and never pulls (a kick-off spring)
    PULL = "pull"  # only while longer than its free length, and never pushes (a cable)


@dataclass(frozen=True, slots=True)
class Spring:
    """A point-to-point spring-damper between point a of member a and point b of member b:
    force along the line a -> b, positive pushing the points apart,
    F = preload - stiffness (L - free_length) - damping dL/dt (N); `acts` one-sided: PUSH
    applies max(F, 0) while L < free_length, PULL min(F, 0) while L > free_length, else 0."""

    name: str
    a: Attachment
    b: Attachment
    stiffness: Expr | None  # N/m
    free_length: Expr | None  # m (required with stiffness or a one-sided range)
    preload: Expr | None  # N, the force at the free length
    damping: Expr | None  # N*s/m
    acts: SpringActs
    span: Span


@dataclass(frozen=True, slots=True)
class CableTerm:
    hinge: int
    coefficient: Expr  # dimensionless


@dataclass(frozen=True, slots=True)
class Cable:
    """A closed cable loop: V = stiffness/2 * (sum coefficient_k * theta_k)^2."""

    name: str
    stiffness: Expr  # N*m/rad
    terms: tuple[CableTerm, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class Output:
    name: str
    expr: Expr
    dim: Dim
    unit: str  # SI unit text, e.g. "rad", "m"
    span: Span


class InputKind(Enum):
    TORQUE = "torque"  # on a hinge: +u on member b, -u on member a (N*m)
    FORCE = "force"  # on a point, in the ground frame: components `<name>.x`, `<name>.y` (N)


@dataclass(frozen=True, slots=True)
class Input:
    """An external load a run or a co-simulation drives (docs/language.md, Inputs).

    Each component k is two entries of the parameter vector: its value at t = 0 at
    `slots[k]` and its rate at `slots[k] + 1`, so that u_k(t) = p[slot] + p[slot + 1] t
    (a constant unless a run changes them: a time table, an FMU's inputs)."""

    name: str
    kind: InputKind
    hinge: int | None  # TORQUE: index into Model.hinges
    point: Attachment | None  # FORCE: where it acts
    components: tuple[str, ...]  # ("T",) or ("F.x", "F.y"): the input names a run sets
    slots: tuple[int, ...]  # each component's value slot in Model.params
    span: Span


@dataclass(frozen=True, slots=True)
class Simulation:
    t_end: float  # s
    tol: float  # dimensionless relative/absolute integration tolerance
    dt_out: float  # s


class JointKind(Enum):
    HINGE = "hinge"
    SLIDER = "slider"
    WELD = "weld"
    FREE = "free"
    BALL = "ball"
    CYLINDRICAL = "cylindrical"
    UNIVERSAL = "universal"


@dataclass(frozen=True, slots=True)
class Placement:
    """One step of the initial assembly: joint `joint` (of `kind`) places member `child` from
    the already placed member `parent`, using the joint's initial angle or displacement.
    Joints not used for placement close kinematic loops (Model.loop_joints)."""

    kind: JointKind
    joint: int
    parent: Member
    child: Member


@dataclass(frozen=True, slots=True)
class Limit:
    """A range check on a value computed from the parameters, kept so that any parameter
    vector can be checked as the model's defaults were (`dsl.limits.check_parameters`).

    kind "positive": value > 0; "nonnegative": value >= 0; "nonzero": value != 0;
    "below": value < bound; "at_least": value >= bound. `what` names the value in messages
    (`rod.length`, `h1.stop_min`), `bound_what` the bound; `unit` is the SI unit text."""

    what: str
    expr: Expr
    kind: str
    unit: str
    span: Span
    bound: Expr | None = None
    bound_what: str = ""


@dataclass(frozen=True, slots=True)
class Diagnostic:
    """A warning the checker found (errors never reach the IR; `dsl.ModelError` carries them
    in the same type). code "E0xx" is an error, "W0xx" a warning. hint: one suggestion, e.g.
    "did you mean 'panel3'?"; notes: extra facts, e.g. "first defined at 12:5"."""

    code: str
    message: str
    span: Span
    hint: str = ""
    notes: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class StructuralParam:
    """A parameter fixed when the model is checked: a whole number used for a loop bound or
    an index (docs/language.md, Repetition). It is not in the run-time parameter vector;
    changing it means changing the model text."""

    name: str
    value: int
    span: Span


@dataclass(frozen=True, slots=True)
class Model:
    """A checked model. `params` is the run-time parameter vector's layout."""

    name: str
    description: str
    source_file: str
    source_sha256: str
    params: tuple[Param, ...]
    derived: tuple[DerivedName, ...]
    gravity: tuple[Expr, ...]  # m/s^2, (x, y) or spatial (x, y, z); zeros when it has none
    ground: Ground
    bodies: tuple[Body, ...]
    beams: tuple[Beam, ...]
    hinges: tuple[Hinge, ...]
    sliders: tuple[Slider, ...]
    cables: tuple[Cable, ...]
    outputs: tuple[Output, ...]
    simulation: Simulation
    placements: tuple[Placement, ...]  # assembly order from the ground (a spanning forest)
    loop_joints: tuple[tuple[JointKind, int], ...]  # joints closing kinematic loops
    warnings: tuple[Diagnostic, ...]
    limits: tuple[Limit, ...] = ()  # every range check of an attribute, in file order
    inputs: tuple[Input, ...] = ()
    structural: tuple[StructuralParam, ...] = ()  # loop bounds and indices, fixed
    particles: tuple[Particle, ...] = ()
    welds: tuple[Weld, ...] = ()
    free_joints: tuple[FreeJoint, ...] = ()
    springs: tuple[Spring, ...] = ()
    spatial: bool = False  # a 3-D model (`model NAME spatial`)
    balls: tuple[Ball, ...] = ()
    cylindricals: tuple[Cylindrical, ...] = ()
    universals: tuple[Universal, ...] = ()
