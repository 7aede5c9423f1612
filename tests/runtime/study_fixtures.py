"""A study Dataset made by hand, with values known in advance: what a deployment study of
`latches` latching hinges looks like, for the summary and the plot (no simulation)."""

from __future__ import annotations

import functools
import types

import numpy as np

from depsim.runtime.sweep import make_design
from depsim.runtime.sweep.metrics import metric_attributes
from depsim.runtime.sweep.storage import build_dataset


def hinge_module(latches: int):
    """What a study's module tells the metrics about units: hinges, outputs, parameters."""
    hinges = tuple(f"h{k}" for k in range(1, latches + 1))
    return types.SimpleNamespace(
        MODEL_NAME="array", HINGES=hinges, OUTPUTS=("theta1", "tip_x", "tip_y"),
        OUTPUT_UNITS=("rad", "m", "m"), PARAMETERS=("friction", "preload", "length"),
        PARAMETER_DEFAULTS=(0.6, 1.7, 2.0), PARAMETER_UNITS=("N*m", "N*m", "m"))


def deployment_study(latches: int = 4, runs: int = 200, stuck_below: float = 1.55,
                     failed: tuple[int, ...] = (3, 7), seed: int = 2):
    """Runs with friction ~ U(0.5, 0.8) and preload ~ N(1.7, 0.1): latch k at t = 10 k +
    40 friction - 5 preload; a run deploys when preload >= `stuck_below` (else its last latch
    never comes); peak torques rise with preload; tip_x is 0 to round-off, theta1 is held at
    90 deg to 1e-11 rad, tip_y varies by millimetres. Runs `failed` failed."""
    module = hinge_module(latches)
    design = make_design(module.PARAMETERS, module.PARAMETER_DEFAULTS, runs=runs, seed=seed,
                         samples=["friction=uniform(0.5, 0.8)", "preload=normal(1.7, 0.1)"])
    rng = np.random.default_rng(seed)
    records = {}
    for i, (friction, preload, length) in enumerate(design.matrix):
        if i in failed:
            records[i] = {"run": i, "failed": True, "error": "SolverError: t = 3 s",
                          "values": {}, "wall": 0.01, "series": None}
            continue
        deployed = preload >= stuck_below
        values = {"deployed": float(deployed)}
        times = [10 * k + 40 * friction - 5 * preload for k in range(1, latches + 1)]
        if not deployed:
            times[-1] = np.nan
        values["time_to_deploy"] = times[-1]
        for k, t in enumerate(times, start=1):
            values[f"event.h{k}.latch.t"] = t
            values[f"event.h{k}.latch.impulse"] = -0.5 * preload * k
            values[f"event.h{k}.latch.angle"] = np.pi / 2 if k == 1 else np.pi
            values[f"peak.h{k}.torque"] = 4 * preload / k + 0.1 * friction
            values[f"peak.h{k}.force"] = 2 + friction
        values["final.theta1"] = np.pi / 2 + 1e-11 * rng.normal()
        values["final.tip_x"] = 2e-14 * rng.normal()
        values["final.tip_y"] = 4 * length + 1e-3 * friction
        values["stats.accepted_steps"] = float(1000 + int(100 * friction))
        records[i] = {"run": i, "failed": False, "error": "", "values": values,
                      "wall": 0.01, "series": None}
    return build_dataset(
        records, design, static_metrics=["deployed", "time_to_deploy"], user_metrics=[],
        output_names=module.OUTPUTS, time_grid=None,
        attrs={"title": "depsim parameter study of array", "study_kind": "monte_carlo",
               "seed": seed, "runs": runs, "varied": ", ".join(design.varied), "tol": 1e-8},
        describe=functools.partial(metric_attributes, module=module),
        parameter_units=module.PARAMETER_UNITS)
