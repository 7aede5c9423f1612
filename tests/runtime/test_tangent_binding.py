"""The tangent functions as the core sees them: a NumPy module's binding fills their dep_model
pointers and sets `tangents` when the module has them (all of them: some only is refused),
leaves them NULL otherwise, and the pointers call the module's functions; a model compiled
with tangents is a cache entry of its own (their values: tests/codegen/test_tangents.py)."""

from __future__ import annotations

import math
import types
from pathlib import Path

import numpy as np
import pytest

import depsim
from depsim.runtime import interface, simulate
from depsim.runtime.binding import NumpyModel, bind, load_module
from depsim.runtime.core import ffi

FOURBAR = Path(__file__).resolve().parents[2] / "examples" / "fourbar.dep"


@pytest.fixture(scope="module")
def with_tangents(tmp_path_factory):
    """examples/fourbar.dep (a loop) compiled to NumPy with tangents."""
    folder = tmp_path_factory.mktemp("fourbar_tangents")
    return depsim.load(FOURBAR).compile("numpy", out_dir=folder, tangents=True).module


def _lengths(module) -> dict[str, int]:
    lengths = {"v": len(module.TREE_JOINTS), "vd": len(module.TREE_JOINTS), "q": module.NQ,
               "qd": module.NQ, "p": module.NP, "lam": module.NC, "w": len(module.RUN_VALUES)}
    return lengths | {interface.direction(name): n for name, n in lengths.items()}


def test_the_binding_fills_the_tangent_pointers(with_tangents):
    """Each pointer calls the module's function: the same values through the callback."""
    binding = NumpyModel(with_tangents)
    assert binding.tangents and getattr(binding.pointer, interface.TANGENT_FLAG) == 1
    lengths, sizes = _lengths(with_tangents), binding.sizes
    rng = np.random.default_rng(2)
    for function in interface.TANGENTS:
        values = {name: (0.3 if name == "t" else rng.standard_normal(lengths[name]))
                  for name in function.args}
        values["p"] = np.array(with_tangents.PARAMETER_DEFAULTS)
        outputs = [ffi().new("double[]", math.prod(sizes[s] for s in r.shape))
                   for r in function.results]
        arguments = [values[a] if a == "t" else ffi().new("double[]", list(values[a]))
                     for a in function.args]
        with binding.running():  # as a run calls them
            getattr(binding.pointer, function.name)(*arguments, *outputs)
            assert binding.failure is None
        expected = getattr(with_tangents, function.name)(*(values[a] for a in function.args))
        expected = expected if isinstance(expected, tuple) else (expected,)
        for out, value in zip(outputs, expected):
            value = np.asarray(value, dtype=float).ravel()
            np.testing.assert_array_equal(np.frombuffer(ffi().buffer(out), dtype=float), value,
                                          err_msg=function.name)


def test_a_model_with_tangents_runs_as_one_without(with_tangents):
    assert simulate(with_tangents, t_end=0.05).times[-1] == 0.05


def test_without_tangents_the_pointers_are_null(pendulum):
    binding = bind(pendulum)
    assert not binding.tangents and getattr(binding.pointer, interface.TANGENT_FLAG) == 0
    assert all(getattr(binding.pointer, name) == ffi().NULL
               for name in interface.TANGENT_NAMES)


def test_a_module_with_some_tangents_only_is_refused(with_tangents):
    names = {k: v for k, v in vars(with_tangents).items()
             if not k.startswith("__") and k != "phi_tangent"}
    with pytest.raises(TypeError, match="some tangent functions but not all: missing "
                                        "phi_tangent"):
        bind(types.SimpleNamespace(**names))


def test_tangents_are_a_cache_entry_of_their_own(tmp_path, monkeypatch):
    monkeypatch.setenv("DEPSIM_CACHE", str(tmp_path / "cache"))
    model = depsim.load(FOURBAR)
    with_path, reused = model.generated_code("numpy", tangents=True)
    assert not reused and model.generated_code("numpy", tangents=True) == (with_path, True)
    without_path, reused = model.generated_code("numpy")
    assert not reused and without_path.parent != with_path.parent
    assert model.cached_code("numpy", tangents=True) == with_path
    assert interface.has_tangents(load_module(with_path))
    assert not interface.has_tangents(load_module(without_path))
