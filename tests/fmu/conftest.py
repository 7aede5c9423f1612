"""Fixtures of the FMU tests: each model's FMU built once per session with the real C
compiler, and FMU instances driven call by call (fmu_helpers.Slave)."""

from __future__ import annotations

from pathlib import Path

import pytest

from depsim.codegen.fmu import compile_fmu
from depsim.dsl import load_model
from fmu_helpers import Slave, model_path


@pytest.fixture(scope="session")
def fmu_path(tmp_path_factory):
    """fmu_path(name, sanitize=False) -> the model's FMU, built on first use."""
    built: dict[tuple[str, bool], Path] = {}

    def get(name: str, sanitize: bool = False) -> Path:
        key = (name, sanitize)
        if key not in built:
            folder = tmp_path_factory.mktemp(f"fmu-{name}{'-asan' if sanitize else ''}")
            built[key] = compile_fmu(load_model(model_path(name)), folder / f"{name}.fmu",
                                     sanitize=sanitize)
        return built[key]

    return get


@pytest.fixture
def slave():
    """slave(path, loggingOn=False) -> a Slave, freed after the test."""
    made: list[Slave] = []

    def make(path: Path, loggingOn: bool = False) -> Slave:
        made.append(Slave(path, loggingOn))
        return made[-1]

    yield make
    for instance in made:
        instance.free()
