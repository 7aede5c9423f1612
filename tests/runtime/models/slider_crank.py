"""Hand-made module: a slider-crank (closed loop) in absolute coordinates.

Written by hand from docs/generated-module.md, independently of depsim.codegen, following
examples/slider_crank.dep. Bodies (x, y, phi of the centre of mass): crank (bar r, end a at
the origin, hinge `crank_pin`), rod (bar l, hinge `wrist` to the crank's end b), piston (pin at
its centre, hinge `gudgeon` to the rod's end b, slider `guide` along +x through the origin:
y = 0 and phi = 0). The crank hinge has a spring with preload, torque preload - k theta - c
theta_dot on theta = phi_crank. No gravity.
"""

import numpy as np

from depsim.dsl import attributes

MODEL_NAME = "slider_crank"
SOURCE_FILE = "slider_crank.py"
SOURCE_SHA256 = "0" * 64
DEPSIM_VERSION = "hand-made"
NQ, NC, NP = 9, 8, 11
COORDINATES = ("crank.x", "crank.y", "crank.phi", "rod.x", "rod.y", "rod.phi",
               "piston.x", "piston.y", "piston.phi")
PARAMETERS = ("r", "l", "crank.mass", "rod.mass", "piston.mass", "piston.inertia",
              "crank_pin.stiffness", "crank_pin.preload", "crank_pin.damping", "theta0",
              "omega0")
PARAMETER_DEFAULTS = (0.1, 0.3, 0.5, 1.0, 2.0, 0.01, 2.0, 5.0, 0.01, np.pi / 2, 0.0)
PARAMETER_UNITS = ("m", "m", "kg", "kg", "kg", "kg*m^2", "N*m/rad", "N*m", "N*m*s/rad",
                   "rad", "rad/s")
CONSTRAINTS = ("crank_pin.x", "crank_pin.y", "wrist.x", "wrist.y", "gudgeon.x", "gudgeon.y",
               "guide.normal", "guide.angle")
CONSTRAINT_JOINTS = ("crank_pin", "crank_pin", "wrist", "wrist", "gudgeon", "gudgeon",
                     "guide", "guide")
CONSTRAINT_HINGES = (0, 0, 1, 1, 2, 2, -1, -1)
CONSTRAINT_SLIDERS = (-1, -1, -1, -1, -1, -1, 0, 0)
PHI_Q_ROWS = (0, 0, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 5, 5, 5, 6, 7)
PHI_Q_COLS = (0, 2, 1, 2, 0, 2, 3, 5, 1, 2, 4, 5, 3, 5, 6, 4, 5, 7, 7, 8)
HINGE_PROPERTIES = attributes.HINGE_PROPERTIES
HINGES = ("crank_pin", "wrist", "gudgeon")
HINGE_WRAPS = (0, 0, 0)
SLIDERS = ("guide",)
OUTPUTS = ("crank_angle", "piston_x", "rod_angle")
OUTPUT_UNITS = ("rad", "m", "rad")
ENERGIES = ("kinetic", "spring.crank_pin")
DISSIPATORS = ("damping.crank_pin",)
T_END, TOL, DT_OUT = 2.0, 1e-9, 0.005


def _masses(p):
    r, l, m1, m2, m3, J3 = p[0], p[1], p[2], p[3], p[4], p[5]
    return np.array([m1, m1, m1 * r * r / 12, m2, m2, m2 * l * l / 12, m3, m3, J3])


def mass_matrix(p):
    return _masses(p)


def initial_state(p):
    r, l, theta, omega = p[0], p[1], p[9], p[10]
    rod = -np.arcsin(r * np.sin(theta) / l)
    rod_rate = -r * np.cos(theta) * omega / (l * np.cos(rod))
    tip = np.array([r * np.cos(theta), r * np.sin(theta)])
    tip_rate = np.array([-r * np.sin(theta), r * np.cos(theta)]) * omega
    half = np.array([np.cos(rod), np.sin(rod)]) * l / 2
    half_rate = np.array([-np.sin(rod), np.cos(rod)]) * l / 2 * rod_rate
    piston = tip + 2 * half
    piston_rate = tip_rate + 2 * half_rate
    q = np.array([tip[0] / 2, tip[1] / 2, theta, *(tip + half), rod, piston[0], 0.0, 0.0])
    qd = np.array([tip_rate[0] / 2, tip_rate[1] / 2, omega, *(tip_rate + half_rate), rod_rate,
                   piston_rate[0], 0.0, 0.0])
    return q, qd


# Hand-made: the initial state is given whole, so there is no assembly tree (NV = 0).
TREE_JOINTS = ()
TREE_HELD = ()
HINGE_JACOBIAN_ROWS = (0, 1, 1, 2, 2)
HINGE_JACOBIAN_COLS = (2, 2, 5, 5, 8)
INPUTS = ()
INPUT_UNITS = ()
INPUT_SLOTS = ()
STIFFNESS_ROWS = ()  # no stiff forces: the explicit step throughout
STIFFNESS_COLS = ()
MASS_ROWS = MASS_COLS = tuple(range(9))  # diagonal
FIXED_PARAMETERS = FIXED_VALUES = ()  # no structural parameters
# the run values outputs may use: lock torques, the dissipators' work, totals
SYSTEM_STATE = ("mass", "com_x", "com_y", "momentum_x", "momentum_y", "angular_momentum")
RUN_VALUES = ('crank_pin.torque',
              'wrist.torque',
              'gudgeon.torque',
              'work.damping.crank_pin',
              'work.friction',
              'work.latch',
              'work.impacts',
              'energy.latch')
LIMITS = LIMIT_KINDS = LIMIT_MESSAGES = ()  # no range checks
LIMIT_PARAMETER_ROWS = LIMIT_PARAMETER_COLS = ()


def tree_values(p):
    return np.zeros(0), np.zeros(0)


def tree_pose(v, p):
    return initial_state(p)[0]


def tree_tangent(v, vd, p):
    return initial_state(p)[1]


def loop_targets(p):
    return np.full(len(HINGES), np.nan), np.full(len(HINGES), np.nan)


def phi(q, t, p):
    r, l = p[0], p[1]
    x1, y1, a1, x2, y2, a2, x3, y3, a3 = q
    return np.array([
        x1 - r / 2 * np.cos(a1), y1 - r / 2 * np.sin(a1),
        x1 + r / 2 * np.cos(a1) - x2 + l / 2 * np.cos(a2),
        y1 + r / 2 * np.sin(a1) - y2 + l / 2 * np.sin(a2),
        x2 + l / 2 * np.cos(a2) - x3, y2 + l / 2 * np.sin(a2) - y3,
        y3, a3])


def phi_q(q, t, p):
    r, l = p[0], p[1]
    a1, a2 = q[2], q[5]
    s1, c1, s2, c2 = r / 2 * np.sin(a1), r / 2 * np.cos(a1), l / 2 * np.sin(a2), l / 2 * np.cos(a2)
    return np.array([1.0, s1, 1.0, -c1,
                     1.0, -s1, -1.0, -s2,
                     1.0, c1, -1.0, c2,
                     1.0, -s2, -1.0,
                     1.0, c2, -1.0,
                     1.0, 1.0])


def phi_q_transpose_times(q, t, p, lam):
    out = np.zeros(NQ)
    np.add.at(out, list(PHI_Q_COLS), phi_q(q, t, p) * np.asarray(lam)[list(PHI_Q_ROWS)])
    return out


def phi_t(q, t, p):
    return np.zeros(8)


def gamma(q, qd, t, p):
    r, l = p[0], p[1]
    a1, a2, w1, w2 = q[2], q[5], qd[2], qd[5]
    c1, s1 = r / 2 * np.cos(a1) * w1 * w1, r / 2 * np.sin(a1) * w1 * w1
    c2, s2 = l / 2 * np.cos(a2) * w2 * w2, l / 2 * np.sin(a2) * w2 * w2
    return np.array([-c1, -s1, c1 + c2, s1 + s2, c2, s2, 0.0, 0.0])


def force(q, qd, t, p):
    k, preload, c = p[6], p[7], p[8]
    f = np.zeros(9)
    f[2] = preload - k * q[2] - c * qd[2]
    return f


def hinge_angles(q, p):
    return np.array([q[2], q[5] - q[2], q[8] - q[5]])


def hinge_rates(q, qd, p):
    return np.array([qd[2], qd[5] - qd[2], qd[8] - qd[5]])


def hinge_jacobian(q, p):
    return np.array([1.0, -1.0, 1.0, -1.0, 1.0])  # at HINGE_JACOBIAN_ROWS, _COLS


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
    return np.array([q[2], q[6], q[5]])


def energy(q, qd, t, p):
    k, preload = p[6], p[7]
    kinetic = 0.5 * sum(m * qd[i] ** 2 for i, m in enumerate(_masses(p)))
    return np.array([kinetic, -preload * q[2] + 0.5 * k * q[2] ** 2])


def stiffness(q, p):
    return np.zeros(0), np.zeros(0)


def dissipation(q, qd, t, p):
    return np.array([p[8] * qd[2] ** 2])


def hinge_gamma(q, qd, p):
    return np.zeros(3)  # hinge angles are linear in q


def hinge_properties(p):
    return np.full((3, len(HINGE_PROPERTIES)), np.nan)  # no latch, stop or friction


def parameter_checks(p):
    return np.zeros(0), np.zeros(0)


def coordinate_scales(p):
    length = max(p[0], p[1], np.sqrt(p[5] / p[4]))  # the largest member: r, l, the piston
    return np.array([length, length, 1.0] * 3)
