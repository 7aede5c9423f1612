"""The tangent functions (interface.TANGENTS) against central finite differences of their base
functions, on both targets (the NumPy module and the C model through the binding), at random
states and random directions of models that between them have every kind of part: planar
loops (fourbar; slider_crank, whose loop-closing hinge has a given initial angle: its
loop_targets), the INTELSAT V array (cables, springs), a spatial arm (reflector_arm), a
flexible beam with outputs of its reaction force and lock torque (boom: lam and w), and a
free flyer with a one-sided kick-off spring and outputs of lam and w (free_flyer)."""

from __future__ import annotations

import subprocess
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from codegen_cases import load_example
from fd_states import random_states
from depsim.codegen import compile_c, compile_numpy, derive, load_generated
from depsim.runtime import interface
from depsim.runtime.binding import CModule, load_folder
from depsim.runtime.core import compiler, ffi

MODELS = ("fourbar", "slider_crank", "intelsat5", "reflector_arm", "boom", "free_flyer")
BASES = {f.name: f for f in interface.FUNCTIONS}
STRICT = ("-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror")

# The directions carry each argument's scale (a coordinate's size, a parameter's own value),
# so one step H moves every argument by about 1e-6 of itself. A central difference then errs
# by H^2 |f'''| / 6 ~ 1e-12 of the values' size (truncation) plus eps |f| / H ~ 1e-10 of it
# (round-off, more where f sums terms that cancel): RTOL = 1e-6 of the largest value in play
# (the function's, its difference quotient's) leaves a margin of 1e4 over both, and ATOL is
# the floor for a function that is zero.
H = 1e-6
RTOL = 1e-6
ATOL = 1e-12


@dataclass(frozen=True)
class Targets:
    """One model compiled with tangents: its NumPy module, its C model and C folder."""

    name: str
    numpy: ModuleType
    c: CModule
    folder: Path


@pytest.fixture(scope="module", params=MODELS)
def targets(request, tmp_path_factory) -> Targets:
    """Each model derived once and compiled with tangents to both targets."""
    model = load_example(request.param)
    system = derive(model)
    root = tmp_path_factory.mktemp(f"tangents_{request.param}")
    module = load_generated(compile_numpy(model, root / "numpy", system, tangents=True))
    folder = compile_c(model, root / "c", system, tangents=True)
    return Targets(request.param, module, load_folder(folder), folder)


def points(module, count: int = 2, seed: int = 5):
    """(values, directions): random states (fd_states) with tree values, and random
    directions of every argument, each of its argument's scale."""
    rng = np.random.default_rng(seed)
    for s in random_states(module, count=count, seed=seed):
        nv = len(module.TREE_JOINTS)
        scales = np.asarray(module.coordinate_scales(s.p), dtype=float)
        p_scale = np.where(s.p != 0, np.abs(s.p), 1.0)
        values = {"v": module.tree_values(s.p)[0] + 0.1 * rng.standard_normal(nv),
                  "vd": rng.standard_normal(nv), "q": s.q, "qd": s.qd, "t": s.t, "p": s.p,
                  "lam": s.lam, "w": s.w}
        directions = {"dv": rng.standard_normal(nv), "dvd": rng.standard_normal(nv),
                      "dq": scales * rng.standard_normal(module.NQ),
                      "dqd": scales * rng.standard_normal(module.NQ),
                      "dp": p_scale * rng.standard_normal(module.NP),
                      "dlam": rng.standard_normal(module.NC),
                      "dw": rng.standard_normal(len(s.w))}
        yield values, directions


def results(value) -> tuple[np.ndarray, ...]:
    return tuple(np.asarray(v, dtype=float) for v in (value if isinstance(value, tuple)
                                                      else (value,)))


def central_difference(function, base: interface.Function, values, directions):
    """(f(x + H dx) - f(x - H dx)) / 2H of each result, and f(x)'s."""
    def at(step):
        return results(function(*(values[a] if a == "t" else
                                  values[a] + step * directions[interface.direction(a)]
                                  for a in base.args)))
    ahead, behind = at(H), at(-H)
    return tuple((a - b) / (2 * H) for a, b in zip(ahead, behind)), at(0.0)


@pytest.mark.parametrize("target", ("numpy", "c"))
@pytest.mark.parametrize("tangent", interface.TANGENTS, ids=lambda f: f.name)
def test_tangent_is_the_directional_derivative(targets, target, tangent):
    module = getattr(targets, target)
    base = BASES[tangent.name.removesuffix("_tangent")]
    assert tangent.args[:len(base.args)] == base.args
    for values, directions in points(targets.numpy):
        arguments = {**values, **directions}
        got = results(getattr(module, tangent.name)(*(arguments[a] for a in tangent.args)))
        differences, at = central_difference(getattr(module, base.name), base, values,
                                             directions)
        for name, g, d, f in zip((r.name for r in tangent.results), got, differences, at):
            assert g.shape == f.shape, name
            # nan where the base is (not given): its tangent is 0 there, and nan in outputs
            # outside a function's domain is nan in both
            expected = np.where(np.isnan(f), 0.0 if base.name != "outputs" else np.nan, d)
            scale = float(np.nanmax(np.abs(np.concatenate([d.ravel(), f.ravel()])),
                                    initial=0.0))
            np.testing.assert_allclose(g, expected, rtol=0, atol=RTOL * scale + ATOL,
                                       equal_nan=True,
                                       err_msg=f"{targets.name} ({target}): {name}")


def test_the_c_model_with_tangents_compiles_under_strict_c99(targets, tmp_path):
    for source in [targets.folder / "model.c", *sorted(targets.folder.glob("model_*.c"))]:
        run = subprocess.run([*compiler(), *STRICT, f"-I{targets.folder}", "-c", str(source),
                              "-o", str(tmp_path / "model.o")], capture_output=True, text=True)
        assert run.returncode == 0, run.stderr


def test_a_model_with_tangents_has_all_of_them(targets):
    names = interface.TANGENT_NAMES
    assert all(callable(getattr(targets.numpy, name)) for name in names)
    assert interface.has_tangents(targets.numpy) and targets.c.tangents
    assert getattr(targets.c.pointer, interface.TANGENT_FLAG) == 1
    assert all(getattr(targets.c.pointer, name) != ffi().NULL for name in names)


def test_a_model_without_tangents_has_none(tmp_path):
    model = load_example("pendulum")
    module = load_generated(compile_numpy(model, tmp_path / "numpy"))
    assert not any(hasattr(module, name) for name in interface.TANGENT_NAMES)
    assert not interface.has_tangents(module)
    c = load_folder(compile_c(model, tmp_path / "c"))
    assert getattr(c.pointer, interface.TANGENT_FLAG) == 0 and not c.tangents
    assert all(getattr(c.pointer, name) == ffi().NULL for name in interface.TANGENT_NAMES)
    assert not any(hasattr(c, name) for name in interface.TANGENT_NAMES)
