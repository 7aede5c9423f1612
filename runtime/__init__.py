"""depsim.runtime: integrates generated modules with the seed paper's iterative multiplier
method and returns plain results. Imports neither sympy nor depsim.dsl / depsim.codegen.

    from depsim.runtime import simulate
    result = simulate(module)              # module: see docs/generated-module.md
    result.to_csv("out.csv"); result.to_json("out.json")
    result.deployment, result.hinge_loads, result.peak_loads   # docs/deployment.md
    animate(result, module, "out.gif")

Latches, hard stops and stick-slip friction come from the module's `hinge_properties` and are
applied by default (`simulate(..., mechanics=False)` turns them off).
"""

from .constraints import ConstraintSet, HingeLock, LinearConstraint
from .direct import simulate_direct
from .errors import SolverError
from .events import Event, EventHit, EventResponse
from .animation import animate
from .integrator import simulate
from .loads import Deployment, HingeLoad, LatchRecord, PeakLoad
from .results import EventRecord, PassStats, Result, Stats


__all__ = ["simulate", "simulate_direct", "Result", "Stats", "PassStats", "EventRecord",
           "SolverError", "Event", "EventHit", "EventResponse", "ConstraintSet", "HingeLock",
           "LinearConstraint", "Deployment", "HingeLoad", "LatchRecord", "PeakLoad", "animate"]
