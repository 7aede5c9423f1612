"""The two-link flexible pendulum in Exudyn, for bench/bench_exudyn.py.

examples/two_link_flex.dep (M2 of the shared models) built in Exudyn. Exudyn is not a
dependency of depsim: `pip install exudyn` (1.13.x) to run this.

    .venv/bin/python bench/exudyn_two_link_flex.py --elements 8 --h 1e-4 --out run.npz
    .venv/bin/python bench/exudyn_two_link_flex.py --check      # the element against theory

The element is Exudyn's ObjectANCFCable2D: the planar gradient-deficient ANCF beam, nodes
of NodePoint2DSlope1 carrying position and slope (x, y, dx/ds, dy/ds), cubic Hermite
interpolation, a constant consistent mass matrix. Those are depsim's beam coordinates,
interpolation and mass matrix exactly (docs/beams.md). The elastic energy differs in form
and agrees in the limit: Exudyn integrates EA/2 (|r'| - 1)^2 + EI/2 kappa^2 over the element
by Gauss quadrature (kappa = r' x r'' / |r'|^2), depsim evaluates the Euler-Bernoulli
energy in each element's chord frame in closed form. Both are Euler-Bernoulli with
geometrically exact large rotation, so they converge to the same solution as the mesh is
refined. ObjectBeamGeometricallyExact2D would add shear (Timoshenko), a different model.

The model: two links of L = 1 m, EI = 1000 N m^2, EA = 2e11 * 2.449e-4 N, 5 kg/m, cut into
n elements each; link 1 hinged to the ground at the origin, link 2 hinged to link 1's tip
(ObjectJointRevolute2D on the end nodes' positions: each link keeps its own end node and
slope, as a hinge does); gravity 9.81 m/s^2 along -y as a mass-proportional load on every
element; link 1 hanging straight down, link 2 straight at 5 deg from -y, undeformed, at rest.

A run records link 2's end nodes (coordinates and velocities) every 0.5 ms, at the first
step at or after each multiple (recording at every step cost Exudyn a tenth more); the bench
interpolates them (cubic Hermite) onto the output grid and forms chord2 and tip2 there as
depsim defines them. `--fast` loads Exudyn's module without range checks (exudynCPPfast,
about a fifth faster here), as Exudyn's documentation describes (sys.exudynFast = True).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

if "--fast" in sys.argv:  # Exudyn's documented switch to its module without range checks
    sys.exudynFast = True
import exudyn as exu  # noqa: E402
from exudyn.itemInterface import (  # noqa: E402
    LoadForceVector, LoadMassProportional, MarkerBodyMass, MarkerBodyPosition,
    MarkerNodeCoordinate, MarkerNodePosition, NodePoint2DSlope1, NodePointGround,
    ObjectANCFCable2D, ObjectConnectorCoordinate, ObjectGround, ObjectJointRevolute2D,
    SensorNode)

LENGTH = 1.0  # m, each link
EI = 2e11 * 5e-9  # N m^2
EA = 2e11 * 2.449e-4  # N
RHO_A = 5.0  # kg/m
GRAVITY = 9.81  # m/s^2
PHI2 = np.radians(5.0)  # link 2's initial angle from -y, counter-clockwise
DT_OUT = 5e-4  # s: link 2's nodes are recorded at the first step at or after each multiple


def add_link(mbs, start, angle: float, elements: int, gravity: float = GRAVITY,
             ei: float = EI, ea: float = EA, rho_a: float = RHO_A, length: float = LENGTH):
    """A straight undeformed link from `start` at `angle` (rad, from -y counter-clockwise),
    cut into `elements` ANCFCable2D elements; returns its node numbers."""
    d = np.array([np.sin(angle), -np.cos(angle)])
    l = length / elements
    nodes = [mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=[
        start[0] + k * l * d[0], start[1] + k * l * d[1], d[0], d[1]]))
        for k in range(elements + 1)]
    for k in range(elements):
        element = mbs.AddObject(ObjectANCFCable2D(
            nodeNumbers=[nodes[k], nodes[k + 1]], length=l, massPerLength=rho_a,
            bendingStiffness=ei, axialStiffness=ea))
        if gravity:
            mass = mbs.AddMarker(MarkerBodyMass(bodyNumber=element))
            mbs.AddLoad(LoadMassProportional(markerNumber=mass, loadVector=[0, -gravity, 0]))
    return nodes


def two_link_flex(elements: int, record: bool = True):
    """M2 with `elements` elements per link, assembled: (SystemContainer, MainSystem, the
    sensors [base coordinates, base velocities, tip coordinates, tip velocities] of link 2,
    link 2's base and tip node numbers)."""
    container = exu.SystemContainer()
    mbs = container.AddSystem()
    ground = mbs.AddObject(ObjectGround())
    pivot = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=[0, 0, 0]))
    link1 = add_link(mbs, (0.0, 0.0), 0.0, elements)
    link2 = add_link(mbs, (0.0, -LENGTH), PHI2, elements)

    def at(node):
        return mbs.AddMarker(MarkerNodePosition(nodeNumber=node))

    mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[pivot, at(link1[0])]))  # h1
    mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[at(link1[-1]), at(link2[0])]))  # h2
    sensors = []
    if record:
        for node in (link2[0], link2[-1]):
            for kind in (exu.OutputVariableType.Coordinates,
                         exu.OutputVariableType.Coordinates_t):
                sensors.append(mbs.AddSensor(SensorNode(
                    nodeNumber=node, storeInternal=True, writeToFile=False,
                    outputVariableType=kind)))
    mbs.Assemble()
    return container, mbs, sensors, (link2[0], link2[-1])


def settings(h: float, t_end: float, rho: float, newton_rtol: float,
             modified_newton: bool = True, sparse: bool = True) -> exu.SimulationSettings:
    """Generalized-alpha at fixed step h (index 3, spectral radius rho), Newton to the
    relative tolerance newton_rtol (Exudyn's default 1e-8), modified Newton, Eigen's sparse
    LU; nothing written to files; the sensors written every DT_OUT."""
    s = exu.SimulationSettings()
    s.timeIntegration.endTime = t_end
    s.timeIntegration.numberOfSteps = int(round(t_end / h))
    s.timeIntegration.generalizedAlpha.spectralRadius = rho
    s.timeIntegration.newton.useModifiedNewton = modified_newton
    s.timeIntegration.newton.relativeTolerance = newton_rtol
    s.timeIntegration.verboseMode = 0
    s.linearSolver.solverType = (exu.LinearSolverType.EigenSparse if sparse
                                 else exu.LinearSolverType.EXUdense)
    s.solution.file.write = False
    s.solution.sensors.writePeriod = DT_OUT  # the output grid, as depsim writes
    return s


def run(elements: int, h: float, t_end: float, rho: float, newton_rtol: float,
        out: Path | None, record: bool = True) -> dict:
    """One solve; its time alone (mbs.SolveDynamic: wall and this process's CPU time), the
    solver's counters (steps, Newton iterations, Jacobians, rejected modified Newton steps)
    and, with `out`, link 2's recorded nodes written there (.npz)."""
    start = time.perf_counter()
    _, mbs, sensors, nodes = two_link_flex(elements, record)
    sim = settings(h, t_end, rho, newton_rtol)
    built, cpu = time.perf_counter(), time.process_time()
    ok = mbs.SolveDynamic(sim, solverType=exu.DynamicSolverType.GeneralizedAlpha)
    solved, cpu = time.perf_counter(), time.process_time() - cpu
    it = mbs.sys["dynamicSolver"].it
    info = {"ok": bool(ok), "build": built - start, "solve": solved - built, "solve_cpu": cpu,
            "steps": int(it.currentStepIndex), "newton": int(it.newtonStepsCount),
            "jacobians": int(it.newtonJacobiCount),
            "rejected": int(it.rejectedModifiedNewtonSteps)}
    if out is not None:
        data = {f"s{k}": mbs.GetSensorStoredData(s) for k, s in enumerate(sensors)}
        references = {f"r{k}": np.array(mbs.GetNodeParameter(n, "referenceCoordinates"))
                      for k, n in enumerate(nodes)}
        np.savez(out, **data, **references, **info)
    return info


# ---- the element against beam theory ---------------------------------------------------------

CANTILEVER_ROOT = 1.8751040687119611  # cos b cosh b = -1


def cantilever(elements: int, clamp: bool):
    """A cantilever of M2's values along +x, no gravity: (mbs, tip node). With `clamp`, node
    0's x, y and slope y component are held by coordinate constraints (for the static solve);
    without, the eigenvalue solve removes those coordinates (0, 1 and 3 of the ODE2 vector)."""
    container = exu.SystemContainer()
    mbs = container.AddSystem()
    nodes = add_link(mbs, (0.0, 0.0), np.pi / 2, elements, gravity=0.0)  # along +x
    if clamp:
        ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()),
                                                    coordinate=0))
        for coordinate in (0, 1, 3):
            root = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=coordinate))
            mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[ground, root]))
    return container, mbs, nodes[-1]


def check(elements: int = 8) -> list[str]:
    """Static tip deflection under a 1 mm load and the first bending frequency of the
    clamped cantilever, against Euler-Bernoulli theory."""
    lines = []
    container, mbs, tip = cantilever(elements, clamp=True)
    load = 3 * EI * 1e-3 / LENGTH**3  # N: 1 mm by P L^3 / (3 EI)
    mbs.AddLoad(LoadForceVector(markerNumber=mbs.AddMarker(MarkerNodePosition(nodeNumber=tip)),
                                loadVector=[0, -load, 0]))
    mbs.Assemble()
    s = exu.SimulationSettings()
    s.staticSolver.newton.relativeTolerance = 1e-7  # round-off stops it near 5e-9 at 16
    s.staticSolver.newton.absoluteTolerance = 1e-12
    s.staticSolver.verboseMode = 0
    s.solution.file.write = False
    mbs.SolveStatic(s)
    deflection = -mbs.GetNodeOutput(tip, exu.OutputVariableType.Displacement)[1]
    exact = load * LENGTH**3 / (3 * EI)
    lines.append(f"Exudyn ANCFCable2D cantilever, {elements} elements, tip load {load:g} N: "
                 f"deflection {deflection:.9e} m, P L^3/(3 EI) {exact:.9e} m, "
                 f"error {deflection / exact - 1:+.1e}")
    container, mbs, tip = cantilever(elements, clamp=False)
    mbs.Assemble()
    # node 0's x, y and slope y are coordinates 0, 1 and 3 of the ODE2 vector
    values, _ = mbs.ComputeODE2Eigenvalues(constrainedCoordinates=[0, 1, 3],
                                           ignoreAlgebraicEquations=True)
    del container
    omegas = np.sqrt(np.abs(np.sort(values)))
    omega1 = omegas[omegas > 1.0][0]
    exact = CANTILEVER_ROOT**2 * np.sqrt(EI / (RHO_A * LENGTH**4))
    lines.append(f"Exudyn ANCFCable2D cantilever, {elements} elements: omega_1 = {omega1:.6f} "
                 f"rad/s, beam theory {exact:.6f} rad/s, error {omega1 / exact - 1:+.1e}")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, default=8, help="elements per link")
    parser.add_argument("--h", type=float, default=1e-4, help="fixed step (s)")
    parser.add_argument("--t-end", type=float, default=5.0)
    parser.add_argument("--rho", type=float, default=0.9, help="generalized-alpha rho_inf")
    parser.add_argument("--newton-rtol", type=float, default=1e-8)
    parser.add_argument("--out", type=Path, help="write link 2's recorded nodes here (.npz)")
    parser.add_argument("--fast", action="store_true",
                        help="Exudyn's module without range checks (exudynCPPfast)")
    parser.add_argument("--check", action="store_true",
                        help="check the element against beam theory instead")
    args = parser.parse_args()
    if args.check:
        for n in (4, 8, 16):
            print("\n".join(check(n)))
        return
    info = run(args.elements, args.h, args.t_end, args.rho, args.newton_rtol, args.out)
    print(" ".join(f"{key}={value}" for key, value in info.items()))


if __name__ == "__main__":
    main()
