"""Fixtures of the C-target tests: each model case compiled to NumPy and to a C library once per
session. The cases are those of tests/codegen (examples, hand-made IR, a fake beam)."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import pytest

CODEGEN_TESTS = Path(__file__).resolve().parents[1] / "codegen"
if str(CODEGEN_TESTS) not in sys.path:
    sys.path.insert(0, str(CODEGEN_TESTS))

from codegen_cases import build, case_names  # noqa: E402
from depsim.codegen import compile_numpy, derive, load_generated  # noqa: E402
from depsim.codegen.c_emit import compile_c  # noqa: E402
from depsim.dsl import ir, load_model  # noqa: E402
from depsim.runtime.binding import CModule, build_model_library, load_c_module  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted(path.stem for path in (ROOT / "examples").glob("*.dep"))


@dataclass(frozen=True)
class Built:
    """A model case in both backends: its IR, the C folder and library, both modules."""

    case: str
    model: ir.Model
    folder: Path
    library: Path
    numpy: ModuleType
    c: CModule


@pytest.fixture(scope="session")
def built_cases(tmp_path_factory):
    """case name -> Built, built on first use."""
    cache: dict[str, Built] = {}

    def get(case: str) -> Built:
        if case not in cache:
            with pytest.MonkeyPatch.context() as monkeypatch:
                model = build(case, monkeypatch)
                system = derive(model)
            root = tmp_path_factory.mktemp(case.replace(":", "_"))
            module = load_generated(compile_numpy(model, root / "numpy", system))
            folder = compile_c(model, root / "c", system)
            library = build_model_library(folder)
            cache[case] = Built(case, model, folder, library, module, load_c_module(library))
        return cache[case]

    return get


@pytest.fixture(params=case_names())
def built(request, built_cases) -> Built:
    """Every model case in turn."""
    return built_cases(request.param)


@pytest.fixture(scope="session")
def example_builds(tmp_path_factory):
    """example name -> Built (NumPy module and C library of examples/<name>.dep)."""
    cache: dict[str, Built] = {}

    def get(name: str) -> Built:
        if name not in cache:
            model = load_model(ROOT / "examples" / f"{name}.dep")
            system = derive(model)
            root = tmp_path_factory.mktemp(name)
            module = load_generated(compile_numpy(model, root / "numpy", system))
            folder = compile_c(model, root / "c", system)
            library = build_model_library(folder)
            cache[name] = Built(name, model, folder, library, module, load_c_module(library))
        return cache[name]

    return get
