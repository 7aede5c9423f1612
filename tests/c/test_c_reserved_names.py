"""No model name can collide with a make target or a file of its C folder:
a model named `clean` used to get a program rule that `clean:` replaced, so `make` built no
program."""

from __future__ import annotations

import re
import subprocess
from dataclasses import replace

import pytest

import handmade
from depsim.codegen.c_emit import c_program_name, c_sources, compile_c
from depsim.codegen.c_printer import RESERVED_STEMS, c_file_stem


def targets_and_files(folder) -> set[str]:
    """Every rule target of the folder's Makefile and every file in the folder."""
    makefile = (folder / "Makefile").read_text(encoding="utf-8")
    targets = set()
    for line in makefile.splitlines():
        match = re.match(r"^([^\s#=:][^=:]*):(?!=)", line)
        if match:
            targets.update(match.group(1).split())
    return targets | {path.name for path in folder.iterdir()}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return compile_c(handmade.pendulum(), tmp_path_factory.mktemp("c") / "pendulum")


def test_no_model_name_becomes_a_target_or_a_file_of_the_folder(folder):
    fixed = targets_and_files(folder) - {"pendulum", "libpendulum.so"}
    assert {"all", "clean", "Makefile", "model.c", "main.c"} <= fixed
    for name in fixed:
        for spelling in (name, name.upper(), name.capitalize()):
            stem = c_file_stem(spelling)
            assert stem.lower() not in {n.lower() for n in fixed}, (spelling, stem)
            assert f"lib{stem}.so".lower() not in {n.lower() for n in fixed}


@pytest.mark.parametrize("name", ["clean", "all", "Clean", "MAKEFILE"])
def test_reserved_names_get_a_prefix(name):
    assert name.lower() in RESERVED_STEMS and c_file_stem(name) == f"model_{name}"


def test_make_builds_the_program_of_a_model_named_clean(tmp_path):
    model = replace(handmade.pendulum(), name="clean")
    folder = compile_c(model, tmp_path / "clean")
    run = subprocess.run(["make", "-C", str(folder)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "warning" not in run.stderr.lower(), run.stderr
    program = folder / c_program_name(model)
    assert program.name == "model_clean" and program.exists()
    listing = subprocess.run([str(program), "--list"], capture_output=True, text=True)
    assert listing.returncode == 0 and "parameter" in listing.stdout
    assert "clean:" in c_sources(model)["Makefile"]
