"""The integrator core stays in layers (runtime/c/README.md): each layer's folder has one header
that includes only the layer below it, every source includes its own layer's header alone, no
source calls a function of a layer above it, no two sources call each other round a circle, and
no source grows past the house's length. Checked on the sources themselves."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from depsim.runtime.core import (FMU_SOURCES, LAYERS, LIBRARY_SOURCE, PROGRAM_SOURCES,
                                 SOURCE_DIR, core_files)

ROOT = Path(__file__).resolve().parents[2]
MOST_LINES = 700  # a source over this is split by what it does
INCLUDE = re.compile(r'^#include "([^"]+)"', re.MULTILINE)
DEFINITION = re.compile(r"^(?!static\b)[A-Za-z_][\w \t*]*?\b(dep_\w+)\s*\(", re.MULTILINE)
CALL = re.compile(r"\b(dep_\w+)\s*\(")
COMMENT = re.compile(r"/\*.*?\*/", re.DOTALL)


def sources() -> dict[str, str]:
    """Every core source and header by its path under runtime/c, comments removed."""
    return {name: COMMENT.sub("", (SOURCE_DIR / name).read_text(encoding="utf-8"))
            for name in core_files() if name.endswith((".c", ".h"))}


def layer_of(name: str) -> int:
    """The layer's rank (0: base); the entry points above them all."""
    top = name.split("/", 1)[0]
    return LAYERS.index(top) if top in LAYERS else len(LAYERS)


def test_every_file_of_runtime_c_is_a_layer_file_or_a_target():
    on_disk = {path.relative_to(SOURCE_DIR).as_posix() for path in SOURCE_DIR.rglob("*")
               if path.is_file() and "__pycache__" not in path.parts}
    named = set(core_files()) | {*PROGRAM_SOURCES, *FMU_SOURCES, "README.md"}
    assert on_disk == named


def test_each_layer_has_one_header_including_the_layer_below():
    for rank, layer in enumerate(LAYERS):
        headers = sorted(p.name for p in (SOURCE_DIR / layer).glob("*.h"))
        assert headers == [f"{layer}.h"], layer
        text = COMMENT.sub("", (SOURCE_DIR / layer / f"{layer}.h").read_text())
        below = "../include/depsim.h" if rank == 0 else f"../{LAYERS[rank - 1]}/{LAYERS[rank - 1]}.h"
        assert INCLUDE.findall(text) == [below], layer


def test_each_source_includes_its_layer_header_alone():
    for name, text in sources().items():
        if not name.endswith(".c"):
            continue
        layer = name.split("/", 1)[0]
        includes = INCLUDE.findall(text)
        if name == LIBRARY_SOURCE:
            assert includes == ["../run/run.h"], name
        elif name == "base/decimal.c":
            assert includes == ["base.h", "decimal_powers.inc"], name
        else:
            assert includes == [f"{layer}.h"], name
    # the program and the FMU wrapper see the public interface and the model only
    public = {"core/include/depsim.h", "model.h", "fmi2.h", "fmu.h", "program.h"}
    for target in (*PROGRAM_SOURCES, *FMU_SOURCES):
        includes = set(INCLUDE.findall((SOURCE_DIR / target).read_text()))
        assert includes <= public and "core/include/depsim.h" in includes | set(
            INCLUDE.findall((SOURCE_DIR / "targets/fmu/fmu.h").read_text())
            + INCLUDE.findall((SOURCE_DIR / "targets/program/program.h").read_text())), target


def calls() -> dict[str, set[str]]:
    """Which source calls a function another source defines."""
    texts = {name: text for name, text in sources().items() if name.endswith(".c")}
    defined = {function: name for name, text in texts.items()
               for function in DEFINITION.findall(text)}
    graph = {name: set() for name in texts}
    for name, text in texts.items():
        for function in set(CALL.findall(text)):
            if defined.get(function, name) != name:
                graph[name].add(defined[function])
    return graph


def test_no_source_calls_a_layer_above_it():
    for name, called in calls().items():
        for other in called:
            assert layer_of(other) <= layer_of(name), f"{name} calls {other}"


def test_no_sources_call_each_other_round_a_circle():
    graph = calls()
    state: dict[str, int] = {}

    def visit(name: str, path: list[str]) -> None:
        state[name] = 1
        for other in sorted(graph[name]):
            assert state.get(other) != 1, " -> ".join(path + [name, other])
            if other not in state:
                visit(other, path + [name])
        state[name] = 2

    for name in sorted(graph):
        if name not in state:
            visit(name, [])
    assert len(graph) > 30 and sum(map(len, graph.values())) > 50  # the check saw the calls


def test_no_source_is_longer_than_the_house_allows():
    for name in [*core_files(), *PROGRAM_SOURCES, *FMU_SOURCES]:
        if name.endswith(".c"):
            lines = (SOURCE_DIR / name).read_text().count("\n")
            assert lines <= MOST_LINES, f"{name}: {lines} lines"


def test_pyproject_ships_every_folder_of_the_core():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    folders = {path.relative_to(SOURCE_DIR).as_posix() for path in SOURCE_DIR.rglob("*")
               if path.is_dir() and "__pycache__" not in path.parts}
    for folder in folders | {""}:
        package = "depsim.runtime.c" + ("." + folder.replace("/", ".") if folder else "")
        assert package in listed, package
