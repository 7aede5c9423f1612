"""Fixtures for the runtime tests."""

import pytest

from depsim.codegen import compile_numpy, load_generated
from depsim.dsl import load_model
from runtime_helpers import load_handmade


@pytest.fixture(scope="session")
def pendulum():
    return load_handmade("pendulum")


@pytest.fixture(scope="session")
def slider_crank():
    return load_handmade("slider_crank")


@pytest.fixture(scope="module")
def build(tmp_path_factory):
    """build(text) -> the generated NumPy module of a .dep model given as text (cached)."""
    folder = tmp_path_factory.mktemp("models")
    cache = {}

    def get(text):
        if text not in cache:
            source = folder / f"model{len(cache)}.dep"
            source.write_text(text)
            cache[text] = load_generated(compile_numpy(load_model(source),
                                                       folder / f"out{len(cache)}"))
        return cache[text]

    return get


@pytest.fixture(scope="module")
def build_c(tmp_path_factory):
    """build_c(text or path) -> the compiled C model (a CModule) of a .dep model (cached)."""
    from pathlib import Path

    from depsim.codegen import compile_c
    from depsim.runtime.binding import load_folder

    folder = tmp_path_factory.mktemp("c_models")
    cache = {}

    def get(model):
        key = str(model)
        if key not in cache:
            source = Path(model) if isinstance(model, Path) else folder / f"model{len(cache)}.dep"
            if not isinstance(model, Path):
                source.write_text(model)
            cache[key] = load_folder(compile_c(load_model(source), folder / f"c{len(cache)}"))
        return cache[key]

    return get
