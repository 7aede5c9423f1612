"""Fixtures of the codegen tests: each model case derived and compiled once per session."""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType

import pytest

from codegen_cases import build, case_names
from depsim.codegen import SymbolicSystem, compile_numpy, derive, load_generated
from depsim.dsl import ir


@dataclass(frozen=True)
class Compiled:
    """A model case: its IR, symbolic system and loaded generated module."""

    case: str
    model: ir.Model
    system: SymbolicSystem
    module: ModuleType


@pytest.fixture(scope="session")
def compiled_cases(tmp_path_factory):
    """case name -> Compiled, built on first use."""
    cache: dict[str, Compiled] = {}

    def get(case: str) -> Compiled:
        if case not in cache:
            with pytest.MonkeyPatch.context() as monkeypatch:
                model = build(case, monkeypatch)
                system = derive(model)
            out_dir = tmp_path_factory.mktemp(case.replace(":", "_"))
            cache[case] = Compiled(case, model, system,
                                   load_generated(compile_numpy(model, out_dir, system)))
        return cache[case]

    return get


@pytest.fixture(params=case_names())
def compiled(request, compiled_cases) -> Compiled:
    """Every model case in turn."""
    return compiled_cases(request.param)
