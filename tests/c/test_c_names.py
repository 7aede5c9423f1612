"""Model text reaches C only inside string literals and comments, escaped so that no name or
description can end them (`*/`, `"`, backslashes, trigraphs, newlines, non-ASCII); file and
program names are reduced to C identifiers."""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import replace

import pytest

import handmade
from depsim.codegen import derive, load_generated, numpy_source
from depsim.codegen.c_emit import PROGRAM_FILES, c_program_name, compile_c
from depsim.codegen.c_printer import c_comment, c_file_stem, c_string
from depsim.dsl import ir
from depsim.runtime import simulate
from depsim.runtime.binding import build_model_library, load_c_module
from depsim.runtime.core import compiler

HOSTILE_NAME = 'x; system("rm -rf ~"); /* */ int y'
HOSTILE_TEXT = ('ends */ a comment, "quotes", back\\slash\\, ??/ trigraph ??=,\nnew line\r, '
                '\x01 \t tab, 60\u00b0, \U0001F680 // and "\\" ?')


def hostile_model() -> ir.Model:
    """The cable pair with every kind of name made hostile."""
    base = handmade.cable_pair()
    bodies = (replace(base.bodies[0], name='yoke"*/'), replace(base.bodies[1], name="panel\n"))
    hinges = (replace(base.hinges[0], name="h1??/"), replace(base.hinges[1], name='h2"\\'))
    params = (replace(base.params[0], name='cable"k*/', unit='N/m"'),
              replace(base.params[1], name="pulley\\r"))
    outputs = (replace(base.outputs[0], name='theta"1/*', unit="rad\u00b0"),)
    cables = (replace(base.cables[0], name="loop*/1"),)
    return replace(base, name=HOSTILE_NAME, description=HOSTILE_TEXT,
                   source_file='dir/evil"*/.dep', bodies=bodies, hinges=hinges, params=params,
                   outputs=outputs, cables=cables)


@pytest.fixture(scope="module")
def hostile(tmp_path_factory):
    model = hostile_model()
    system = derive(model)
    root = tmp_path_factory.mktemp("hostile")
    folder = compile_c(model, root / "c", system)
    # compile_numpy names its file after the model; this name would leave the folder
    (root / "hostile.py").write_text(numpy_source(model, system), encoding="utf-8")
    module = load_generated(root / "hostile.py")
    return model, folder, module


def test_hostile_names_compile_warning_free(hostile, tmp_path):
    _, folder, _ = hostile
    for name in ("model.c", *PROGRAM_FILES):
        if not name.endswith(".c"):
            continue
        run = subprocess.run([*compiler(), "-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic",
                              "-Werror", "-c", name, "-o", str(tmp_path / f"{name}.o")],
                             cwd=folder, capture_output=True, text=True)
        assert run.returncode == 0, run.stderr


def test_hostile_names_read_back_exactly(hostile):
    model, folder, module = hostile
    c = load_c_module(build_model_library(folder))
    assert c.MODEL_NAME == HOSTILE_NAME and c.DESCRIPTION == HOSTILE_TEXT
    for constant in ("SOURCE_FILE", "COORDINATES", "PARAMETERS", "PARAMETER_UNITS",
                     "CONSTRAINTS", "CONSTRAINT_JOINTS", "HINGES", "OUTPUTS", "OUTPUT_UNITS",
                     "ENERGIES"):
        assert getattr(c, constant) == getattr(module, constant), constant
    assert 'cable"k*/' in c.PARAMETERS and "h1??/.x" in c.CONSTRAINTS


def test_library_defines_and_uses_only_its_own_functions(hostile):
    _, folder, _ = hostile
    if shutil.which("nm") is None:
        pytest.skip("nm (binutils) is not installed")
    library = str(build_model_library(folder))
    defined = subprocess.run(["nm", "-D", "--defined-only", library], capture_output=True,
                             text=True, check=True).stdout.split()
    names = [word for word in defined if re.fullmatch(r"[A-Za-z_]\w*", word)
             and word not in {"T", "D", "B", "R", "W", "A"}]
    assert all(re.match(r"(model_|dep_|depsim_model$|_init$|_fini$|_edata|_end|__bss)", n)
               for n in names), names
    undefined = subprocess.run(["nm", "-D", "--undefined-only", library], capture_output=True,
                               text=True, check=True).stdout
    assert "system" not in undefined


def test_program_name_is_an_identifier(hostile):
    model, folder, _ = hostile
    name = c_program_name(model)
    assert re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name)
    run = subprocess.run(["make", "-C", str(folder), name], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    listing = subprocess.run([str(folder / name), "--list"], capture_output=True, text=True)
    assert 'cable"k*/' in listing.stdout


def test_hostile_names_in_the_json_summary(hostile, tmp_path):
    """Quotes, backslashes, a new line and non-ASCII in names: the program's summary is the
    binding's json.dumps, byte for byte."""
    model, folder, _ = hostile
    name = c_program_name(model)
    assert subprocess.run(["make", "-C", str(folder), name], capture_output=True).returncode == 0
    ran = subprocess.run([str(folder / name), "--t-end", "0.05", "--summary",
                          tmp_path / "program.json"], capture_output=True, text=True)
    assert ran.returncode == 0, ran.stderr
    module = load_c_module(build_model_library(folder))
    simulate(module, t_end=0.05).to_json(tmp_path / "binding.json")
    written = (tmp_path / "program.json").read_bytes()
    assert written == (tmp_path / "binding.json").read_bytes()
    assert b'"h2\\"\\\\"' in written and written.isascii()


@pytest.mark.parametrize("name, stem", [("pendulum", "pendulum"), ("9lives", "model_9lives"),
                                         ("", "model_"), ("Makefile", "model_Makefile"),
                                         ("../../etc/x y", "______etc_x_y"),
                                         ("model", "model_model")])
def test_file_stems(name, stem):
    assert c_file_stem(name) == stem


def test_c_string_round_trips_every_byte(tmp_path):
    text = "".join(chr(i) for i in range(1, 128)) + "\u00b0\U0001F680??/??=\"\\*/"
    source = tmp_path / "echo.c"
    source.write_text('#include <stdio.h>\nint main(void) { fputs(' + c_string(text)
                      + ', stdout); return 0; }\n')
    build = subprocess.run([*compiler(), "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror",
                            "-o", str(tmp_path / "echo"), str(source)], capture_output=True,
                           text=True)
    assert build.returncode == 0, build.stderr
    out = subprocess.run([str(tmp_path / "echo")], capture_output=True).stdout
    assert out == text.encode("utf-8")


def test_c_comment_cannot_end_or_nest(tmp_path):
    line = c_comment(HOSTILE_TEXT + "*/*/ /*/ ???/ //")
    for forbidden in ("*/", "/*", "//", "??", "\n", "\r", "\t"):
        assert forbidden not in line
    assert "60\\u00b0" in line and line.isascii()
