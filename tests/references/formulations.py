"""Spatial rigid-body formulations to measure depsim's coordinates against: Euler parameters
with their equations of motion derived here with sympy and emitted as C, joint coordinates
(the articulated-body algorithm) and, for one free body, Euler angles and a quaternion with
Euler's equations. Nothing here comes from depsim.

The integrator and the algebra are hand-written C (tests/references/formulations.c, whose
header says what each method solves); this module writes the Euler-parameter kernels,
builds the program, writes a mechanism's description for it and reads its results.

**Euler parameters.** Body i has q_i = (r_i, p_i): its centre of mass r (world) and a
quaternion p = (e0, e1, e2, e3), scalar first. Its rotation matrix (body to world) is

    R(p) = (e0^2 - e.e) 1 + 2 e e^T + 2 e0 [e]x      (homogeneous of degree 2 in p),

its body-frame angular velocity omega' = 2 L(p) p', L = [-e, e0 1 - [e]x], and its kinetic
energy T = m |r'|^2 / 2 + 2 p'^T L^T J L p' (J the inertia about the centre, body frame). So
M(p) = diag(m 1, 4 L^T J L): it depends on p (and is singular along p, since L p = 0), and
Lagrange's equations with the norm row p.p - 1 = 0 and the hinges' rows give

    M(p) q'' + Phi_q^T lambda = Q(q, q'),   Q = (m g, dT/dp - (d(M p')/dp) p'),

the quadratic-velocity force derived here. A hinge joining A and B holds its points together
(3 rows, r_A + R_A s_A = r_B + R_B s_B) and its axis (R_B a_B) . (R_A e) = (R_B a_B) . (R_A f)
= 0, e and f normal to the axis in A's frame: depsim's rows, in R(p). gamma = -(Phi_q q')_q q'
for each row is derived here too.

Conventions are tests/references/spatial.py's: SI units; a hinge's axis and its point on the
parent are in the parent's frame (the ground's is the world), its point on the child in the
child's frame from the child's centre of mass; the angle theta turns the child about the axis,
R_child = R_parent rot(axis, theta) (every body has the world's orientation at theta = 0).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sympy as sp
from sympy.utilities.codegen import C99CodeGen

from .spatial import _cross, _matrix_to_quaternion, _rodrigues, _unit

HERE = Path(__file__).resolve().parent
SOURCE = HERE / "formulations.c"
CFLAGS = ["-O2", "-fno-math-errno", "-std=c99"]  # depsim's own (docs/c-target.md)
METHODS = ("ep", "ep-project", "joint", "angles", "quat")


# ------------------------------------------------------------- Euler parameters by sympy


def quaternion_matrix(p) -> sp.Matrix:
    e0, e = p[0], sp.Matrix(p[1:])
    skew = sp.Matrix([[0, -e[2], e[1]], [e[2], 0, -e[0]], [-e[1], e[0], 0]])
    return (e0 ** 2 - e.dot(e)) * sp.eye(3) + 2 * e * e.T + 2 * e0 * skew


def rate_matrix(p) -> sp.Matrix:
    """L(p): omega' = 2 L p' (body frame)."""
    return sp.Matrix([[-p[1], p[0], p[3], -p[2]],
                      [-p[2], -p[3], p[0], p[1]],
                      [-p[3], p[2], -p[1], p[0]]])


def _vector(name: str, n: int) -> sp.Matrix:
    return sp.Matrix(sp.symbols(f"{name}0:{n}", real=True))


def body_equations():
    """The rotational block of one body: (p, pd, J6, c) -> (M_p + c p p^T, Q_p), M_p = 4 L^T J L
    and Q_p = dT/dp - (d(M_p pd)/dp) pd; J6 = (Jxx, Jyy, Jzz, Jxy, Jyz, Jxz)."""
    p, pd, J6 = _vector("p", 4), _vector("pd", 4), _vector("J", 6)
    c = sp.Symbol("c", real=True)
    Jm = sp.Matrix([[J6[0], J6[3], J6[5]], [J6[3], J6[1], J6[4]], [J6[5], J6[4], J6[2]]])
    w = 2 * rate_matrix(p) * pd
    T = (w.T * Jm * w)[0] / 2
    M = sp.hessian(T, list(pd))
    Mpd = M * pd
    Q = sp.Matrix([sp.diff(T, p[k]) - sum(sp.diff(Mpd[k], p[j]) * pd[j] for j in range(4))
                   for k in range(4)])
    Mhat = M + c * p * p.T
    return (p, pd, J6, c), sp.expand(Mhat), sp.expand(Q)


def hinge_equations(ground: bool):
    """Phi (5), Phi_q (5 x 7 on B, or 5 x 14 on A then B) and gamma (5) of a hinge."""
    par = _vector("s", 15)  # sA, sB, e, f, aB
    sA, sB, e, f, aB = (sp.Matrix(par[3 * k:3 * k + 3]) for k in range(5))
    qB, qdB = _vector("qB", 7), _vector("qdB", 7)
    RB = quaternion_matrix(qB[3:, 0])
    axis = RB * aB
    if ground:
        q, qd = qB, qdB
        rows = [sA - sp.Matrix(qB[:3]) - RB * sB, axis.dot(e), axis.dot(f)]
    else:
        qA, qdA = _vector("qA", 7), _vector("qdA", 7)
        RA = quaternion_matrix(qA[3:, 0])
        q, qd = sp.Matrix.vstack(qA, qB), sp.Matrix.vstack(qdA, qdB)
        rows = [sp.Matrix(qA[:3]) + RA * sA - sp.Matrix(qB[:3]) - RB * sB,
                axis.dot(RA * e), axis.dot(RA * f)]
    phi = sp.Matrix([*rows[0], rows[1], rows[2]])
    jac = phi.jacobian(q)
    gamma = -(jac * qd).jacobian(q) * qd
    args = (qB, qdB, par) if ground else (qA, qdA, qB, qdB, par)
    return args, phi, jac, gamma


def _routine(gen, name, args, outputs):
    """A routine of C99CodeGen with array arguments (MatrixSymbols) for the symbol vectors."""
    symbols, replace = [], {}
    for k, arg in enumerate(args):
        if isinstance(arg, sp.Symbol):
            arg = sp.Matrix([arg])
        ms = sp.MatrixSymbol(f"in{k}", len(arg), 1)
        symbols.append(ms)
        replace.update({s: ms[i, 0] for i, s in enumerate(arg)})
    results = []
    for k, expr in enumerate(outputs):
        flat = sp.Matrix(list(expr)).xreplace(replace)
        results.append(sp.Eq(sp.MatrixSymbol(f"out{k}", len(flat), 1), flat))
    return gen.routine(name, results, argument_sequence=[*symbols, *(r.lhs for r in results)],
                       global_vars=None)


def write_kernels(folder: Path) -> None:
    """ep_kernels.c and ep_kernels.h in folder: ep_body(p, pd, J6, c, M, Q),
    ep_ground_hinge(qB, qdB, par, phi, jac, gamma), ep_hinge(qA, qdA, qB, qdB, par, phi, jac,
    gamma); matrices row-major."""
    gen = C99CodeGen(project="formulations", cse=True)
    body_args, Mhat, Q = body_equations()
    routines = [_routine(gen, "ep_body", body_args, [Mhat, Q])]
    for name, ground in (("ep_ground_hinge", True), ("ep_hinge", False)):
        args, phi, jac, gamma = hinge_equations(ground)
        routines.append(_routine(gen, name, args, [phi, jac, gamma]))
    (c_name, c_text), (h_name, h_text) = gen.write(routines, "ep_kernels", header=False,
                                                   empty=False)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / c_name).write_text(c_text)
    (folder / h_name).write_text(h_text)


def build(folder: Path) -> Path:
    """The program (formulations.c with the kernels), built in folder; reused while neither
    formulations.c nor this module changed."""
    folder = Path(folder)
    program = folder / "formulations"
    stamp = folder / "formulations.stamp"
    key = f"{SOURCE.stat().st_mtime_ns} {Path(__file__).stat().st_mtime_ns} {CFLAGS}"
    if program.exists() and stamp.exists() and stamp.read_text() == key:
        return program
    write_kernels(folder)
    cc = os.environ.get("CC", "cc")
    subprocess.run([cc, *CFLAGS, "-I", str(folder), "-o", str(program), str(SOURCE),
                    str(folder / "ep_kernels.c"), "-lm"], check=True)
    stamp.write_text(key)
    return program


# ------------------------------------------------------------------------ the mechanism


def _normals(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors e, f with (e, f, axis) right-handed and orthonormal."""
    trial = np.eye(3)[int(np.argmin(np.abs(axis)))]
    e = _unit(trial - (trial @ axis) * axis)
    return e, _cross(axis, e)


def _lmatrix(p: np.ndarray) -> np.ndarray:
    return np.array([[-p[1], p[0], p[3], -p[2]], [-p[2], -p[3], p[0], p[1]],
                     [-p[3], p[2], -p[1], p[0]]])


def zyx_angles(R: np.ndarray) -> np.ndarray:
    """(psi, theta, phi) with R = Rz(psi) Ry(theta) Rx(phi), |theta| < 90 deg."""
    theta = -math.asin(max(-1.0, min(1.0, R[2, 0])))
    return np.array([math.atan2(R[1, 0], R[0, 0]), theta, math.atan2(R[2, 1], R[2, 2])])


@dataclass
class Mechanism:
    """Rigid bodies on hinges from the ground (a tree: each body's hinge joins it to an earlier
    body or the ground), or one free body (free=True: R0 and omega0, world frame, and no
    hinges). bodies: {"name", "m", "J" (3 x 3, about the centre, body frame)}; hinges, one per
    body: {"parent": index or -1, "axis", "point_a" (parent's frame), "point_b" (the body's)}.
    theta0, rate0: the hinges' initial angles and rates."""

    name: str
    bodies: list[dict]
    hinges: list[dict] = field(default_factory=list)
    gravity: tuple = (0.0, 0.0, 0.0)
    theta0: tuple = ()
    rate0: tuple = ()
    free: bool = False
    R0: np.ndarray | None = None
    omega0: np.ndarray | None = None

    def pose(self, theta, rate):
        """R (n, 3, 3), r (n, 3), omega and v (n, 3, world) of every body from the joints."""
        Rs, rs, ws, vs = [], [], [], []
        for i, h in enumerate(self.hinges):
            a = _unit(h["axis"])
            pa, pb = (np.asarray(h[k], dtype=float) for k in ("point_a", "point_b"))
            if h["parent"] < 0:
                Rp, rp, wp, vp = np.eye(3), np.zeros(3), np.zeros(3), np.zeros(3)
            else:
                j = h["parent"]
                Rp, rp, wp, vp = Rs[j], rs[j], ws[j], vs[j]
            P = rp + Rp @ pa
            vP = vp + _cross(wp, Rp @ pa)
            R = Rp @ _rodrigues(a, theta[i])
            w = wp + rate[i] * (Rp @ a)
            r = P - R @ pb
            Rs.append(R), rs.append(r), ws.append(w), vs.append(vP + _cross(w, r - P))
        return np.array(Rs), np.array(rs), np.array(ws), np.array(vs)

    def ep_state(self) -> np.ndarray:
        """Euler parameters' q0, qd0 (14 per body)."""
        if self.free:
            Rs, rs = [np.asarray(self.R0, float)], [np.zeros(3)]
            ws, vs = [np.asarray(self.omega0, float)], [np.zeros(3)]
        else:
            Rs, rs, ws, vs = self.pose(self.theta0, self.rate0)
        q, qd = [], []
        for R, r, w, v in zip(Rs, rs, ws, vs):
            p = _matrix_to_quaternion(R)
            q += [*r, *p]
            qd += [*v, *(0.5 * _lmatrix(p).T @ (R.T @ w))]  # p' = L^T omega' / 2
        return np.array(q + qd)

    def spec(self) -> str:
        """The description formulations.c reads."""
        lines = [f"bodies {len(self.bodies)}", "gravity " + _numbers(self.gravity)]
        for b in self.bodies:
            lines.append("body " + _numbers([b["m"], *np.asarray(b["J"], float).ravel()]))
        for i, h in enumerate(self.hinges):
            a = _unit(h["axis"])
            e, f = _normals(a)
            lines.append(f"hinge {i} " + _numbers([h["parent"], *h["point_a"], *h["point_b"],
                                                    *a, *e, *f, *a]))
        if self.free:
            R0, w0 = np.asarray(self.R0, float), np.asarray(self.omega0, float)
            lines += ["quat0 " + _numbers(_matrix_to_quaternion(R0)),
                      "w0 " + _numbers(R0.T @ w0), "euler0 " + _numbers(zyx_angles(R0))]
        else:
            lines += ["theta0 " + _numbers(self.theta0), "rate0 " + _numbers(self.rate0)]
        lines.append("ep_y0 " + _numbers(self.ep_state()))
        return "\n".join(lines) + "\n"

    def masses(self) -> np.ndarray:
        return np.array([b["m"] for b in self.bodies], dtype=float)


def _numbers(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def run(program: Path, mechanism: Mechanism, method: str, folder: Path, *, tol: float,
        t_end: float, dt_out: float, repeat: int = 0, time_rhs: bool = False,
        alpha: float | None = None) -> dict:
    """One process of the program: its statistics (the JSON line) and, from its first run,
    the outputs: "t" (n,), "r" (n, bodies, 3), "R" (n, bodies, 3, 3), "energy" (n,),
    "residual" (n,)."""
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}")
    folder = Path(folder)
    spec = folder / f"{mechanism.name}.spec"
    if not spec.exists() or spec.read_text() != mechanism.spec():
        spec.write_text(mechanism.spec())
    out = folder / f"{mechanism.name}_{method}_{tol:g}.csv"
    command = [str(program), method, str(spec), "--tol", repr(tol), "--t-end", repr(t_end),
               "--dt-out", repr(dt_out), "-o", str(out), "--repeat", str(repeat)]
    if time_rhs:
        command.append("--time-rhs")
    if alpha is not None:
        command += ["--alpha", repr(alpha)]
    done = subprocess.run(command, capture_output=True, text=True, check=True)
    stats = json.loads(done.stderr.strip().splitlines()[-1])
    stats.update(read_outputs(out, len(mechanism.bodies)))
    return stats


def derivative(program: Path, mechanism: Mechanism, method: str, folder: Path) -> np.ndarray:
    """The program's right side at the mechanism's initial state (y' of its method)."""
    spec = Path(folder) / f"{mechanism.name}.spec"
    spec.write_text(mechanism.spec())
    done = subprocess.run([str(program), method, str(spec), "--derivative"],
                          capture_output=True, text=True, check=True)
    return np.array(json.loads(done.stderr.strip().splitlines()[-1])["derivative"])


def read_outputs(path: Path, n_bodies: int) -> dict:
    data = np.loadtxt(path, delimiter=",", ndmin=2)
    t = data[:, 0]
    poses = data[:, 1:1 + 12 * n_bodies].reshape(len(t), n_bodies, 12)
    return {"t": t, "r": poses[:, :, :3], "R": poses[:, :, 3:].reshape(len(t), n_bodies, 3, 3),
            "energy": data[:, 1 + 12 * n_bodies], "residual": data[:, 2 + 12 * n_bodies]}


def potential(mechanism: Mechanism, r: np.ndarray) -> np.ndarray:
    """-sum m g . r at each output time (r: (n, bodies, 3))."""
    return -np.einsum("b,nbk,k->n", mechanism.masses(), r, np.asarray(mechanism.gravity, float))
