"""Random states for finite-difference checks of generated modules."""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType

import numpy as np
from depsim.runtime.interface import initial_state


@dataclass(frozen=True)
class State:
    q: np.ndarray
    qd: np.ndarray
    t: float
    p: np.ndarray
    lam: np.ndarray  # multipliers of the model's rows (outputs may use them)
    w: np.ndarray  # run values (outputs may use them)


def random_states(module: ModuleType, count: int = 3, seed: int = 7) -> list[State]:
    """Random states near the assembled initial pose, with perturbed positive parameters."""
    rng = np.random.default_rng(seed)
    states = []
    defaults = np.array(module.PARAMETER_DEFAULTS)
    for _ in range(count):
        p = _moments_together(module, defaults, defaults * rng.uniform(0.9, 1.1, module.NP))
        p = universal_axes_kept(module, defaults, p)
        q0, _ = initial_state(module, p)
        q = q0 + 0.05 * rng.standard_normal(module.NQ)
        states.append(State(q, rng.standard_normal(module.NQ), float(rng.uniform(0, 2)), p,
                            rng.standard_normal(module.NC),
                            rng.uniform(0.5, 2.0, len(module.RUN_VALUES))))
    return states


def _moments_together(module: ModuleType, defaults: np.ndarray, p: np.ndarray) -> np.ndarray:
    """p with each spatial body's three principal moments scaled by one factor (its x
    moment's): a thin panel's moments meet the strict triangle inequality only by m t^2 / 6,
    which perturbing them apart would break (a mass matrix that is not positive definite)."""
    names = {name: i for i, name in enumerate(module.PARAMETERS)}
    for name, i in names.items():
        head, _, tail = name.rpartition(".inertia_x")
        if tail or f"{head}.inertia_y" not in names or f"{head}.inertia_z" not in names:
            continue
        for other in (names[f"{head}.inertia_y"], names[f"{head}.inertia_z"]):
            p[other] = defaults[other] * p[i] / defaults[i]
    return p


def universal_axes_kept(module: ModuleType, defaults: np.ndarray, p: np.ndarray) -> np.ndarray:
    """p with the orientations and universal joints' axes at their defaults in a model with a
    universal joint: its axes must stay normal where the orientations place them (a range
    check), which perturbing either apart would break."""
    names = module.PARAMETERS
    if not any(name.endswith(".axis_a_x") for name in names):
        return p
    p = p.copy()
    for i, name in enumerate(names):
        if ".orientation_" in name or ".axis_a_" in name or ".axis_b_" in name:
            p[i] = defaults[i]
    return p
