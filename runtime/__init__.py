"""depsim.runtime: runs models through the one integrator core (runtime/c) and returns plain
results. Imports neither sympy nor depsim.dsl / depsim.codegen.

    from depsim.runtime import simulate
    result = simulate(module)              # module: see docs/generated-module.md
    result.to_csv("out.csv"); result.to_json("out.json")
    result.deployment, result.hinge_loads, result.peak_loads   # docs/deployment.md
    animate(result, module, "out.gif")

Latches, hard stops and stick-slip friction come from the module's `hinge_properties` and are
applied by default (`simulate(..., mechanics=False)` turns them off). The names below are
imported on first use, so `depsim.runtime.interface` (the model interface the code generator
also reads) loads without numpy, cffi or matplotlib.
"""

import importlib

_EXPORTS = {
    "simulate": "runner", "RunEnds": "runner", "SolverError": "errors", "Event": "events",
    "EventHit": "events", "EventResponse": "events", "ConstraintSet": "constraints",
    "HingeLock": "constraints", "LinearConstraint": "constraints", "Result": "results",
    "RunEnd": "results", "Stats": "results", "PassStats": "results", "EventRecord": "results",
    "Deployment": "loads", "HingeLoad": "loads", "LatchRecord": "loads", "PeakLoad": "loads",
    "animate": "animation", "CModule": "binding", "load_folder": "binding",
    "CBuildError": "core",
}

__all__ = sorted(_EXPORTS)


def lazy_exports(package: str, exports: dict, namespace: dict):
    """A package's module __getattr__ that imports each name of `exports` (name -> its
    submodule) on first use and keeps it in the package's `namespace`."""

    def get(name: str):
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module '{package}' has no attribute '{name}'")
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        namespace[name] = value
        return value

    return get


__getattr__ = lazy_exports(__name__, _EXPORTS, globals())
