"""depsim.runtime: integrates generated modules with the seed paper's iterative multiplier
method and returns plain results. Imports neither sympy nor depsim.dsl / depsim.codegen.

    from depsim.runtime import simulate
    result = simulate(module)              # module: see docs/generated-module.md
    result.to_csv("out.csv"); result.to_json("out.json")
"""

from .constraints import ConstraintSet, HingeLock, LinearConstraint
from .direct import simulate_direct
from .errors import SolverError
from .events import Event, EventHit, EventResponse
from .integrator import simulate
from .results import EventRecord, PassStats, Result, Stats

__all__ = ["simulate", "simulate_direct", "Result", "Stats", "PassStats", "EventRecord",
           "SolverError", "Event", "EventHit", "EventResponse", "ConstraintSet", "HingeLock",
           "LinearConstraint"]
