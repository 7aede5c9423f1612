"""The standalone program's --input NAME=FILE.csv: a time table read with the rules and the
messages of `depsim run --input` (depsim.runtime.tables.read_table), no Python needed. Each
file is read by both: an error is the same line (exit 2), a table drives the same run."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from depsim.codegen.c_emit import compile_c
from depsim.dsl import load_model
from depsim.runtime import simulate
from depsim.runtime.binding import load_folder
from depsim.runtime.tables import read_table

ROOT = Path(__file__).resolve().parents[2]
MOTOR = ROOT / "tests" / "fmu" / "models" / "motor.dep"

GOOD = {
    "header": "t,u\n0,0\n1,2\n",
    "bom_crlf_named_header": "\ufefftime,T_motor\r\n0,0\r\n0.04,2\r\n",
    "lone_cr": "0,0\r0.02,1\r0.04,-1",
    "comments_blank_lines": "# the motor\n\n   \n0, 0 # start\n\t0.01 ,1\n",
    "jump": "0,0\n0.01,0\n0.01,3\n2,3\n",
    "underscores_signs": "0,1_0\n+1.5e-2,-.5\n.02,5.\n1_0.5,1e0_1\n",
    "unicode_space": "0,\u00a01\n0.01,\u20032\u3000\n\x1c0.02,3\x1f\n",
    "one_row": "0,0.3\n",
}

BAD = {
    "nan": "0,nan\n",
    "infinity": "Infinity,1\n",
    "decreasing": "0,0\n2,1\n1,1\n",
    "three_fields": "0,1,2\n",
    "one_field": "0\n",
    "tab": "0\t1\n",
    "empty_field": "0,\n",
    "name_in_data": "0,abc\n",
    "not_a_name": "0,1x\n",
    "underscore_first": "0,1\n_1,2\n",
    "double_underscore": "1__0,1\n",
    "hex": "0x10,1\n",
    "bare_exponent": "1e,2\n",
    "header_three": "a,b,c\n0,1\n",
    "header_trailing_comma": "t,u,\n0,1\n",
    "header_later": "0,1\nt,u\n",
    "empty": "",
    "header_only": "t,u\n",
    "comments_only": "# nothing\n\n",
    "nan_header": "nan,nan\n",
}


def table_file(folder: Path, name: str, content: str | bytes) -> Path:
    path = folder / f"{name}.csv"
    path.write_bytes(content.encode("utf-8") if isinstance(content, str) else content)
    return path


@pytest.fixture(scope="module")
def motor(tmp_path_factory):
    """The motor model's C target folder, built by make, and its binding."""
    folder = compile_c(load_model(MOTOR), tmp_path_factory.mktemp("motor"))
    made = subprocess.run(["make", "-j2", "-C", str(folder)], capture_output=True, text=True)
    assert made.returncode == 0, made.stdout + made.stderr
    return folder / "motor", load_folder(folder)


def run_program(program: Path, *args, cwd=None):
    return subprocess.run([str(program), *map(str, args)], capture_output=True, text=True,
                          env={}, cwd=cwd)


def python_says(path) -> str | np.ndarray:
    try:
        return read_table(path)
    except ValueError as exc:
        return str(exc)


@pytest.mark.parametrize("name", sorted(GOOD))
def test_a_table_drives_the_run_as_depsim_run(motor, tmp_path, name):
    program, module = motor
    path = table_file(tmp_path, name, GOOD[name])
    rows = python_says(path)
    assert isinstance(rows, np.ndarray), rows
    ran = run_program(program, "--input", f"T_motor={path}", "--t-end", "0.05", "-o",
                      tmp_path / "program.csv")
    assert ran.returncode == 0, ran.stderr
    simulate(module, t_end=0.05, inputs={"T_motor": rows}).to_csv(tmp_path / "binding.csv")
    assert (tmp_path / "program.csv").read_bytes() == (tmp_path / "binding.csv").read_bytes()


@pytest.mark.parametrize("name", sorted(BAD))
def test_a_bad_table_is_the_same_error(motor, tmp_path, name):
    program, _ = motor
    path = table_file(tmp_path, name, BAD[name])
    message = python_says(path)
    assert isinstance(message, str), name
    ran = run_program(program, "--input", f"T_motor={path}", "--t-end", "0.05")
    assert ran.returncode == 2 and ran.stdout == ""
    assert ran.stderr == f"motor: error: --input T_motor: {message}\n"


def test_files_that_cannot_be_tables(motor, tmp_path):
    """A missing file, a folder, bytes that are not UTF-8 (a data error in an earlier block of
    lines comes first, as Python reads them block by block), the path printed as pathlib
    prints it."""
    program, _ = motor
    (tmp_path / "sub").mkdir()
    long_valid = "".join(f"{k * 1e-3},1\n" for k in range(40000))
    cases = {
        "missing": tmp_path / "nosuch.csv",
        "folder": tmp_path / "sub",
        "latin1": table_file(tmp_path, "latin1", b"t,u\n0,1\n\xff,2\n"),
        "late_latin1": table_file(tmp_path, "late", long_valid.encode() + b"\xe9,1\n"),
        "error_first": table_file(tmp_path, "first", b"0,1\n0,x1\n"
                                  + long_valid.encode() + b"\xff\n"),
        "decreasing_late": table_file(tmp_path, "late_order", (long_valid + "1,1\n").encode()),
    }
    for name, path in cases.items():
        message = python_says(path)
        assert isinstance(message, str), name
        ran = run_program(program, "--input", f"T_motor={path}", "--t-end", "0.05")
        assert (ran.returncode, ran.stderr) == (2, f"motor: error: --input T_motor: {message}\n")
    table_file(tmp_path / "sub", "x", "0,1\n")
    ran = run_program(program, "--input", " T_motor = ./sub//x.csv/ ", "--t-end", "0.01",
                      "-o", "out.csv", cwd=tmp_path)
    assert ran.returncode == 2  # a trailing '/' names a folder: not a file
    assert ran.stderr == f"motor: error: --input T_motor: {python_says('./sub//x.csv/')}\n"
    ran = run_program(program, "--input", " T_motor = ./sub//x.csv ", "--t-end", "0.01",
                      "-o", "out.csv", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr


@pytest.fixture(scope="module")
def depsim_run_errors(tmp_path_factory):
    """The messages of `depsim run --input` for the command lines of the program's usage
    errors (the CLI, once per case)."""
    folder = tmp_path_factory.mktemp("cli")
    table = table_file(folder, "torque", "0,1\n")

    def says(*args) -> str:
        done = subprocess.run([sys.executable, "-m", "depsim", "run", MOTOR, *map(str, args),
                               "--t-end", "0.01"], capture_output=True, text=True, cwd=folder)
        assert done.returncode == 2, done.stderr
        return done.stderr.removeprefix("depsim: ")

    return table, says


@pytest.mark.parametrize("args", [
    ("--input", "T_motor"),
    ("--input", "=torque.csv"),
    ("--input", "T_motor=torque.csv", "--input", "T_motor=torque.csv"),
    ("--input", "T_motor=torque.csv", "--set", "T_motor.rate=1"),
    ("--input", "T_motr=torque.csv"),
    ("--set", "T_motor=1", "--set", "T_motor=2 "),
])
def test_usage_errors_are_depsim_runs(motor, depsim_run_errors, args):
    program, _ = motor
    table, says = depsim_run_errors
    ran = run_program(program, *args, "--t-end", "0.01", cwd=table.parent)
    assert ran.returncode == 2 and ran.stderr == f"motor: {says(*args)}"


def test_tables_and_summary_run_clean_under_sanitizers(motor, tmp_path):
    """The program's own files (the table reader, the JSON writer, the outputs) under
    AddressSanitizer and UBSan, on good and bad tables."""
    from depsim.codegen.c_emit import PROGRAM_FILES
    from depsim.runtime.core import compiler

    folder = motor[0].parent
    library = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*.c")
                     if p.name not in PROGRAM_FILES and "build" not in p.relative_to(folder).parts)
    program = tmp_path / "checked"
    build = subprocess.run([*compiler(), "-O0", "-g", "-std=c99", "-fsanitize=address,undefined",
                            "-fno-sanitize-recover=all", "-o", str(program),
                            *[n for n in PROGRAM_FILES if n.endswith(".c")], *library, "-lm"],
                           cwd=folder, capture_output=True, text=True)
    if build.returncode != 0 and "sanitize" in build.stderr:
        pytest.skip("the compiler has no sanitizer runtime")
    assert build.returncode == 0, build.stderr
    for name, content in [*GOOD.items(), *BAD.items()]:
        path = table_file(tmp_path, name, content)
        ran = run_program(program, "--input", f"T_motor={path}", "--t-end", "0.05", "-o",
                          tmp_path / "out.csv", "--summary", tmp_path / "out.json")
        assert ran.returncode in (0, 2) and "Sanitizer" not in ran.stderr, ran.stderr
        assert "runtime error" not in ran.stderr, ran.stderr
