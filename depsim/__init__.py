"""depsim: a modelling language and compiler for deployable spacecraft mechanisms.

    import depsim
    sim = depsim.load("examples/intelsat5.dep").compile()
    result = sim.run(set={"h2.friction": 0.7})
"""

__version__ = "0.1.0"

from depsim.api import Model, Simulator, load  # noqa: E402  (the version comes first)

__all__ = ["Model", "Simulator", "load", "__version__"]
