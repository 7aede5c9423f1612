"""depsim: a modelling language and compiler for deployable spacecraft mechanisms.

    import depsim
    sim = depsim.load("examples/intelsat5.dep").compile()
    result = sim.run(set={"h2.friction": 0.7})
"""

__all__ = ["Model", "Simulator", "fit", "load", "local_study", "sweep", "__version__"]


def __getattr__(name: str):
    if name == "__version__":  # pyproject.toml's, as installed, read on first use: importing
        from importlib.metadata import version  # it takes 40 ms a study's worker needs not

        globals()["__version__"] = value = version("depsim")
        return value
    # The facade is imported on first use, so `import depsim.dsl` stays independent of it.
    if name in ("Model", "Simulator", "load", "local_study", "sweep"):
        from depsim import api

        return getattr(api, name)
    if name == "fit":
        from depsim.calibration import fit

        return fit
    raise AttributeError(f"module 'depsim' has no attribute '{name}'")
