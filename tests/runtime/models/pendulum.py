"""Hand-made module: a rigid bar pendulum in absolute coordinates (x, y, phi).

Written by hand from docs/generated-module.md, independently of depsim.codegen, as a
reference for the runtime and a cross-check of the generated pendulum.

The bar (length L, mass m, inertia J = m L^2 / 12 about its centre) has end a at
(-L/2, 0) in body coordinates, held at the origin by hinge `pivot`; gravity g along -y.
Hinge angle theta = phi + pi/2 (0 hanging down, counter-clockwise positive). Optional viscous
damping c (N m s/rad) on the hinge.
"""

import numpy as np

from depsim.dsl import attributes

MODEL_NAME = "pendulum"
SOURCE_FILE = "pendulum.py"
SOURCE_SHA256 = "0" * 64
DEPSIM_VERSION = "hand-made"
NQ, NC, NP = 3, 2, 6
COORDINATES = ("rod.x", "rod.y", "rod.phi")
PARAMETERS = ("L", "m", "g", "theta0", "omega0", "c")
PARAMETER_DEFAULTS = (1.0, 2.0, 9.81, np.pi / 3, 0.0, 0.0)
PARAMETER_UNITS = ("m", "kg", "m/s^2", "rad", "rad/s", "N*m*s/rad")
CONSTRAINTS = ("pivot.x", "pivot.y")
CONSTRAINT_JOINTS = ("pivot", "pivot")
CONSTRAINT_HINGES = (0, 0)
CONSTRAINT_SLIDERS = (-1, -1)
PHI_Q_ROWS = (0, 0, 1, 1)
PHI_Q_COLS = (0, 2, 1, 2)
HINGE_PROPERTIES = attributes.HINGE_PROPERTIES
HINGES = ("pivot",)
HINGE_WRAPS = (0,)
SLIDERS = ()
OUTPUTS = ("theta", "omega", "tip_x", "tip_y")
OUTPUT_UNITS = ("rad", "rad/s", "m", "m")
ENERGIES = ("kinetic", "gravity")
DISSIPATORS = ("damping.pivot",)
T_END, TOL, DT_OUT = 10.0, 1e-9, 0.01


def mass_matrix(p):
    L, m = p[0], p[1]
    return np.array([m, m, m * L * L / 12])


def initial_state(p):
    L, theta0, omega0 = p[0], p[3], p[4]
    phi = theta0 - np.pi / 2
    q = np.array([L / 2 * np.cos(phi), L / 2 * np.sin(phi), phi])
    qd = np.array([-L / 2 * np.sin(phi) * omega0, L / 2 * np.cos(phi) * omega0, omega0])
    return q, qd


# Hand-made: the initial state is given whole, so there is no assembly tree (NV = 0).
TREE_JOINTS = ()
TREE_HELD = ()
HINGE_JACOBIAN_ROWS = (0,)
HINGE_JACOBIAN_COLS = (2,)
INPUTS = ()
INPUT_UNITS = ()
INPUT_SLOTS = ()
STIFFNESS_ROWS = ()  # no stiff forces: the explicit step throughout
STIFFNESS_COLS = ()
MASS_ROWS = MASS_COLS = (0, 1, 2)  # diagonal
FIXED_PARAMETERS = FIXED_VALUES = ()  # no structural parameters
# the run values outputs may use: lock torques, the dissipators' work, totals
SYSTEM_STATE = ("mass", "com_x", "com_y", "momentum_x", "momentum_y", "angular_momentum")
RUN_VALUES = ('pivot.torque',
              'work.damping.pivot',
              'work.friction',
              'work.latch',
              'work.impacts',
              'energy.latch')
LIMITS = ("rod.length",)  # one range check: L > 0 (depsim.dsl.limits)
LIMIT_KINDS = (0,)  # positive
LIMIT_MESSAGES = ("rod.length must be positive, got %g m",)
LIMIT_PARAMETER_ROWS = LIMIT_PARAMETER_COLS = (0,)


def tree_values(p):
    return np.zeros(0), np.zeros(0)


def tree_pose(v, p):
    return initial_state(p)[0]


def tree_tangent(v, vd, p):
    return initial_state(p)[1]


def loop_targets(p):
    return np.full(len(HINGES), np.nan), np.full(len(HINGES), np.nan)


def phi(q, t, p):
    L = p[0]
    return np.array([q[0] - L / 2 * np.cos(q[2]), q[1] - L / 2 * np.sin(q[2])])


def phi_q(q, t, p):
    L = p[0]
    return np.array([1.0, L / 2 * np.sin(q[2]), 1.0, -L / 2 * np.cos(q[2])])


def phi_q_transpose_times(q, t, p, lam):
    out = np.zeros(NQ)
    np.add.at(out, list(PHI_Q_COLS), phi_q(q, t, p) * np.asarray(lam)[list(PHI_Q_ROWS)])
    return out


def phi_t(q, t, p):
    return np.zeros(2)


def gamma(q, qd, t, p):
    L, w = p[0], qd[2]
    return np.array([-L / 2 * np.cos(q[2]) * w * w, -L / 2 * np.sin(q[2]) * w * w])


def force(q, qd, t, p):
    m, g, c = p[1], p[2], p[5]
    return np.array([0.0, -m * g, -c * qd[2]])


def hinge_angles(q, p):
    return np.array([q[2] + np.pi / 2])


def hinge_rates(q, qd, p):
    return np.array([qd[2]])


def hinge_jacobian(q, p):
    return np.array([1.0])


def system_state(q, qd, p):
    """Rigid bodies (x, y, phi) with the diagonal mass_matrix: mass, centre of mass, momentum,
    angular momentum about the centre of mass."""
    m, q, qd = np.asarray(mass_matrix(p)), np.asarray(q), np.asarray(qd)
    mass = m[0::3].sum()
    com = np.array([m[0::3] @ q[0::3], m[1::3] @ q[1::3]]) / mass
    px, py = m[0::3] @ qd[0::3], m[1::3] @ qd[1::3]
    h = (m[2::3] @ qd[2::3] + m[0::3] @ (q[0::3] * qd[1::3] - q[1::3] * qd[0::3])
         - (com[0] * py - com[1] * px))
    return np.array([mass, com[0], com[1], px, py, h])


def outputs(q, qd, t, p, lam, w):
    L = p[0]
    return np.array([q[2] + np.pi / 2, qd[2], q[0] + L / 2 * np.cos(q[2]),
                     q[1] + L / 2 * np.sin(q[2])])


def energy(q, qd, t, p):
    L, m, g = p[0], p[1], p[2]
    kinetic = 0.5 * m * (qd[0] ** 2 + qd[1] ** 2) + 0.5 * m * L * L / 12 * qd[2] ** 2
    return np.array([kinetic, m * g * q[1]])


def stiffness(q, p):
    return np.zeros(0), np.zeros(0)


def dissipation(q, qd, t, p):
    return np.array([p[5] * qd[2] ** 2])


def hinge_gamma(q, qd, p):
    return np.zeros(1)  # hinge angles are linear in q


def hinge_properties(p):
    return np.full((1, len(HINGE_PROPERTIES)), np.nan)  # no latch, stop or friction


def parameter_checks(p):
    return np.array([p[0]]), np.zeros(1)


def coordinate_scales(p):
    return np.array([p[0], p[0], 1.0])  # the rod's length for its position
