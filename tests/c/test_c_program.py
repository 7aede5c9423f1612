"""The C target folder: byte-for-byte reproducible, warning-free under strict C99, clean under
AddressSanitizer and UndefinedBehaviorSanitizer, built by `make` alone; its program runs
without Python and writes the CSV of the ctypes run; usage errors exit 2, solver failures 3."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from depsim.codegen.c_emit import PROGRAM_FILES, c_program_name, c_sources, compile_c
from depsim.runtime import simulate
from depsim.runtime.core import compiler

HERE = Path(__file__).resolve().parent
STRICT = ("-O2", "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror")
SANITIZE = ("-O0", "-g", "-std=c99", "-fno-omit-frame-pointer", "-fsanitize=address,undefined",
            "-fno-sanitize-recover=all")
SHORT = {"pendulum": 0.5, "slider_crank": 0.2, "intelsat5": 0.3, "two_link_flex": 0.002}
EXAMPLES = list(SHORT)


def cc(*arguments, cwd):
    return subprocess.run([*compiler(), *map(str, arguments)], cwd=cwd,
                          capture_output=True, text=True)


PROGRAM_C = [name for name in PROGRAM_FILES if name.endswith(".c")]  # main.c, program_*.c


def sources(folder: Path) -> list[str]:
    """The library's C files of a C target folder (its model*.c and core/), as relative paths."""
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*.c")
                  if p.name not in PROGRAM_FILES and "build" not in p.relative_to(folder).parts)


def test_emission_is_deterministic(example_builds, tmp_path):
    model = example_builds("slider_crank").model
    first = compile_c(model, tmp_path / "a")
    second = compile_c(model, tmp_path / "b")
    for path in sorted(first.rglob("*")):
        if path.is_file():
            relative = path.relative_to(first)
            assert path.read_bytes() == (second / relative).read_bytes(), relative


def test_emission_does_not_depend_on_hash_seed(example_builds):
    script = ("import sys; from depsim.dsl import load_model; "
              "from depsim.codegen import c_sources; "
              "s = c_sources(load_model(sys.argv[1])); "
              "sys.stdout.write(''.join(s[k] for k in sorted(s)))")
    model = example_builds("intelsat5").model
    expected = "".join(v for _, v in sorted(c_sources(model).items()))
    path = str(Path(__file__).resolve().parents[2] / "examples" / "intelsat5.dep")
    for seed in ("1", "2"):
        run = subprocess.run([sys.executable, "-c", script, path], capture_output=True,
                             text=True, env=os.environ | {"PYTHONHASHSEED": seed}, check=True)
        assert run.stdout == expected


def test_generated_header_names_model_and_source(example_builds):
    built = example_builds("pendulum")
    text = (built.folder / "model.c").read_text()
    assert text.startswith("/* pendulum: ")
    assert f"Source SHA-256: {built.model.source_sha256}" in text
    assert not re.search(r"\b(19|20)\d\d-\d\d-\d\d|\d\d:\d\d:\d\d", text)  # no timestamp


def test_long_functions_in_their_own_files_give_the_same_program(example_builds, tmp_path,
                                                                  monkeypatch):
    """With every function long enough to go into a file of its own (model_<name>.c), the
    folder still builds warning-free, with `make -j2` and through depsim, and the program
    writes byte for byte the CSV of the one-file folder."""
    from depsim.codegen import c_emit
    from depsim.runtime.binding import build_model_library, load_c_module

    built = example_builds("slider_crank")
    monkeypatch.setattr(c_emit, "OWN_FILE_CHARS", 0)
    folder = compile_c(built.model, tmp_path / "split")
    own = sorted(p.name for p in folder.glob("model_*.c"))
    assert len(own) > 10 and "model_phi_q.c" in own
    assert "void model_phi_q(" not in (folder / "model.c").read_text()
    assert "const dep_model depsim_model" in (folder / "model.c").read_text()
    for name in own:
        run = cc(*STRICT, "-c", name, "-o", tmp_path / f"{name.replace('/', '_')}.o",
                 cwd=folder)
        assert run.returncode == 0, f"{name}:\n{run.stderr}"
    made = subprocess.run(["make", "-j2", "-C", str(folder)], capture_output=True, text=True)
    assert made.returncode == 0, made.stdout + made.stderr
    monkeypatch.undo()
    one = compile_c(built.model, tmp_path / "one")
    assert not list(one.glob("model_*.c"))
    subprocess.run(["make", "-C", str(one)], capture_output=True, check=True)
    for where in (folder, one):
        run = subprocess.run([str(where / c_program_name(built.model)), "--t-end", "0.2",
                              "-o", tmp_path / f"{where.name}.csv"],
                             capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
    assert (tmp_path / "split.csv").read_bytes() == (tmp_path / "one.csv").read_bytes()
    split = simulate(load_c_module(build_model_library(folder)), t_end=0.2)
    np.testing.assert_array_equal(split.q, simulate(built.c, t_end=0.2).q)


def test_runtime_compiles_warning_free(example_builds, tmp_path):
    folder = example_builds("pendulum").folder
    for name in sources(folder) + PROGRAM_C:
        run = cc(*STRICT, "-c", name, "-o", tmp_path / f"{name.replace('/', '_')}.o",
                 cwd=folder)
        assert run.returncode == 0, f"{name}:\n{run.stderr}"


@pytest.mark.parametrize("name", EXAMPLES)
def test_models_compile_warning_free(example_builds, tmp_path, name):
    folder = example_builds(name).folder
    for source in sorted(folder.glob("model*.c")):
        run = cc(*STRICT, "-c", source.name, "-o", tmp_path / f"{source.stem}.o", cwd=folder)
        assert run.returncode == 0, run.stderr


@pytest.mark.parametrize("name", EXAMPLES)
def test_runs_clean_under_sanitizers(example_builds, tmp_path, name):
    folder = example_builds(name).folder
    program = tmp_path / "checked"
    build = cc(*SANITIZE, "-o", program, *PROGRAM_C, *sources(folder), "-lm", cwd=folder)
    if build.returncode != 0 and "sanitize" in build.stderr:
        pytest.skip(f"the compiler has no sanitizer runtime: {build.stderr[:200]}")
    assert build.returncode == 0, build.stderr
    run = subprocess.run([program, "--t-end", str(SHORT[name]), "-o", tmp_path / "out.csv"],
                         capture_output=True, text=True)
    assert run.returncode == 0 and "runtime error" not in run.stderr, run.stderr
    assert "Sanitizer" not in run.stderr, run.stderr


def test_mechanics_run_clean_under_sanitizers(tmp_path):
    """Hard stops (impacts, releases) and stick-slip friction: transitions.c, impacts.c."""
    from depsim.dsl import load_model
    folder = compile_c(load_model(HERE / "models" / "pendulum_stops.dep"), tmp_path / "c")
    program = tmp_path / "checked"
    build = cc(*SANITIZE, "-o", program, *PROGRAM_C, *sources(folder), "-lm", cwd=folder)
    if build.returncode != 0 and "sanitize" in build.stderr:
        pytest.skip("the compiler has no sanitizer runtime")
    assert build.returncode == 0, build.stderr
    run = subprocess.run([program, "--t-end", "2", "-o", tmp_path / "out.csv"],
                         capture_output=True, text=True)
    assert run.returncode == 0 and "runtime error" not in run.stderr, run.stderr
    assert "Sanitizer" not in run.stderr, run.stderr


def test_events_run_clean_under_sanitizers(example_builds, tmp_path):
    folder = example_builds("pendulum").folder
    program = tmp_path / "events"
    build = cc(*SANITIZE, "-I", folder, "-o", program, HERE / "event_driver.c",
               *[folder / s for s in sources(folder)], "-lm", cwd=tmp_path)
    if build.returncode != 0 and "sanitize" in build.stderr:
        pytest.skip("the compiler has no sanitizer runtime")
    assert build.returncode == 0, build.stderr
    run = subprocess.run([program], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    assert [line.split()[0] for line in run.stdout.splitlines()] == ["bottom", "late"]


@pytest.fixture(scope="module")
def made(example_builds, tmp_path_factory):
    """The slider-crank folder built by its Makefile alone."""
    built = example_builds("slider_crank")
    folder = compile_c(built.model, tmp_path_factory.mktemp("made"))
    run = subprocess.run(["make", "-C", str(folder)], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    return built, folder, folder / c_program_name(built.model)


def test_make_builds_program_and_library(made):
    built, folder, program = made
    assert program.is_file() and (folder / f"lib{program.name}.so").is_file()
    again = subprocess.run(["make", "-C", str(folder)], capture_output=True, text=True)
    assert "Nothing to be done" in again.stdout or again.stdout.count("cc") == 0


def test_program_runs_without_python_and_matches_the_binding(made, tmp_path):
    built, folder, program = made
    run = subprocess.run([str(program), "--t-end", "0.5", "--set", "r=0.11", "-o", "out.csv"],
                         cwd=tmp_path, env={}, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith("slider_crank: 101 output times to t = 0.5 s")
    p = np.array(built.c.PARAMETER_DEFAULTS)
    p[built.c.PARAMETERS.index("r")] = 0.11
    simulate(built.c, p, t_end=0.5).to_csv(tmp_path / "binding.csv")
    assert (tmp_path / "out.csv").read_bytes() == (tmp_path / "binding.csv").read_bytes()


def test_program_writes_csv_to_stdout(made):
    _, _, program = made
    run = subprocess.run([str(program), "--t-end", "0.01", "--dt-out", "0.005"], env={},
                         capture_output=True, text=True)
    assert run.returncode == 0
    assert run.stdout.splitlines()[0] == "t,crank_angle,piston_x,rod_angle"
    assert len(run.stdout.splitlines()) == 4


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs POSIX pipes and links")
def test_program_writes_pipes_in_place_follows_links_and_refuses_folders(made, tmp_path):
    """-o as `depsim run` treats it: a pipe (like /dev/null, a device) is written in place and
    never replaced (a rename over /dev/null, as root, would replace the device with a file);
    a symbolic link keeps pointing at its target, whose content is replaced; a folder is
    refused with nothing written."""
    built, folder, program = made
    arguments = [str(program), "--t-end", "0.01", "--dt-out", "0.005", "-o"]
    pipe = tmp_path / "pipe"
    os.mkfifo(pipe)
    reader = subprocess.Popen(["cat", str(pipe)], stdout=subprocess.PIPE)
    run = subprocess.run([*arguments, str(pipe)], capture_output=True, text=True, timeout=60)
    read = reader.communicate(timeout=60)[0].decode()
    assert run.returncode == 0, run.stderr
    assert read.splitlines()[0] == "t,crank_angle,piston_x,rod_angle"
    assert len(read.splitlines()) == 4 and pipe.is_fifo()
    target = tmp_path / "target.csv"
    target.write_text("old\n")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    run = subprocess.run([*arguments, str(link)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert link.is_symlink() and target.read_text() == read
    run = subprocess.run([*arguments, str(tmp_path)], capture_output=True, text=True)
    assert run.returncode == 1 and "it is a folder" in run.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.csv", "pipe", "target.csv"]


@pytest.mark.parametrize("arguments, message", [
    (["--set", "rr=0.1"], "unknown parameter 'rr'; did you mean 'r'?"),
    (["--set", "nonsense=1"], "unknown parameter 'nonsense'"),
    (["--set", "r=0.1 m"], "bad value for 'r': '0.1 m' is not a finite number"),
    (["--set", "r=abc"], "plain SI numbers (m for this parameter)"),
    (["--set", "r=nan"], "bad value for 'r'"),
    (["--set", "r"], "expected NAME=VALUE"),
    (["--t-end", "-1"], "argument --t-end: '-1' must be a positive number"),
    (["--tol", "x"], "argument --tol: 'x' is not a number"),
    (["--dt-out"], "argument --dt-out: expected a value"),
    (["--bogus"], "unrecognized argument '--bogus'"),
    (["--stepping", "rk4"], "argument --stepping: 'rk4' is not one of auto, explicit, implicit"),
    (["--tol", "0.5", "--dt-out", "1e-20", "--t-end", "1"], "asks for 1e+20 output times"),
])
def test_usage_errors_exit_2(made, arguments, message):
    _, _, program = made
    run = subprocess.run([str(program), *arguments], capture_output=True, text=True, env={})
    assert run.returncode == 2, run.stderr
    assert message in run.stderr


def test_stepping_implicit_needs_stiff_forces(made):
    """The slider-crank has no beams: forcing the linearly implicit step is refused as a
    setting, as simulate(stepping="implicit") refuses it; explicit runs."""
    _, _, program = made
    run = subprocess.run([str(program), "--stepping", "implicit"], capture_output=True,
                         text=True, env={})
    assert run.returncode == 2 and "stepping implicit needs stiff forces" in run.stderr
    run = subprocess.run([str(program), "--stepping", "explicit", "--t-end", "0.01"],
                         capture_output=True, text=True, env={})
    assert run.returncode == 0, run.stderr


def test_solver_failure_exits_3_with_the_python_message(made):
    built, _, program = made
    run = subprocess.run([str(program), "--set", "crank_pin.initial_angle=2"],
                         capture_output=True, text=True, env={})
    assert run.returncode == 3
    p = np.array(built.numpy.PARAMETER_DEFAULTS)
    p[built.numpy.PARAMETERS.index("crank_pin.initial_angle")] = 2.0
    from depsim.runtime import SolverError, simulate
    with pytest.raises(SolverError) as expected:
        simulate(built.numpy, p)
    assert run.stderr == f"{program.name}: solver failure: {expected.value}\n"


def test_program_lists_parameters_and_helps(made):
    _, _, program = made
    listing = subprocess.run([str(program), "--list"], capture_output=True, text=True)
    assert listing.returncode == 0 and "crank_pin.stiffness" in listing.stdout
    helped = subprocess.run([str(program), "--help"], capture_output=True, text=True)
    assert helped.returncode == 0 and "plain number in SI units" in helped.stdout


def test_program_prints_numbers_as_python_does(made):
    """--help's defaults and --list's values in the shortest form that reads back exactly,
    Python's repr (0.01, not 0.01000000000000000021)."""
    built, _, program = made
    helped = subprocess.run([str(program), "--help"], capture_output=True, text=True).stdout
    for option, value in (("--t-end", built.c.T_END), ("--dt-out", built.c.DT_OUT),
                          ("--tol", built.c.TOL)):
        (line,) = [line for line in helped.splitlines() if line.strip().startswith(option)]
        assert line.endswith(f"(default {value!r})"), line
    listing = subprocess.run([str(program), "--list"], capture_output=True, text=True).stdout
    rows = {line.split()[0]: line.split()[-1] for line in listing.splitlines()[1:]}
    for name, value in zip(built.c.PARAMETERS, built.c.PARAMETER_DEFAULTS):
        assert rows[name] == repr(value), name


def test_short_functions_gathered_in_files_give_the_same_run(example_builds, tmp_path,
                                                             monkeypatch):
    """Short functions are gathered in order into files of about OWN_FILE_CHARS (each named
    by its first function) when a model's code is long: every function is in exactly one
    file, model.c keeps the tables and the struct, the folder builds warning-free, and the
    library runs bit for bit as the one-file folder's."""
    from depsim.codegen import c_emit
    from depsim.runtime.binding import build_model_library, load_c_module
    from depsim.runtime.interface import FUNCTION_NAMES

    built = example_builds("slider_crank")
    monkeypatch.setattr(c_emit, "OWN_FILE_CHARS", 1500)
    folder = compile_c(built.model, tmp_path / "gathered")
    defined = {}
    for source in sorted(folder.glob("model*.c")):
        names = re.findall(r"^void model_(\w+)\(", source.read_text(), flags=re.MULTILINE)
        defined.update((name, source.name) for name in names)
        if source.name != "model.c":
            assert source.name == f"model_{names[0]}.c"
        run = cc(*STRICT, "-c", source.name, "-o", tmp_path / f"{source.stem}.o", cwd=folder)
        assert run.returncode == 0, f"{source.name}:\n{run.stderr}"
    assert sorted(defined) == sorted(FUNCTION_NAMES)
    gathered = [name for name in set(defined.values()) if name != "model.c"
                and sum(f == name for f in defined.values()) > 1]
    assert gathered, defined
    assert "const dep_model depsim_model" in (folder / "model.c").read_text()
    split = simulate(load_c_module(build_model_library(folder)), t_end=0.2)
    np.testing.assert_array_equal(split.q, simulate(built.c, t_end=0.2).q)


def test_a_value_stored_into_many_entries_is_a_loop(built_cases):
    """The five equal bars of tests/codegen/models/spatial_chain.dep: each bar's mass stored
    into its three translation entries of M is one loop over the 15 entries, not 15 stores
    (test_c_model_functions checks the values against the NumPy module)."""
    text = "".join(p.read_text() for p in
                   sorted(built_cases("model:spatial_chain").folder.glob("model*.c")))
    mass = text[text.index("void model_mass_matrix("):]
    mass = mass[:mass.index("\n}\n")]
    assert "static const int at[15] = {" in mass
    assert "M[at[k]] = p[" in mass


def test_files_compiled_while_generating_are_what_the_library_links(example_builds, tmp_path,
                                                                     monkeypatch):
    """Model.compile("c") compiles each generated model*.c as soon as it is written
    (ModelPrebuild, beside the lowering of the next); the library is then linked from those
    objects without compiling any file again."""
    import depsim
    from depsim.runtime import core
    from depsim.runtime.binding import OBJECTS, build_model_library

    folder = tmp_path / "c"
    depsim.load(HERE.parents[1] / "examples" / "slider_crank.dep").compile("c", out_dir=folder)
    objects = sorted(p.name.rsplit("-", 1)[0] for p in (folder / OBJECTS).glob("*.o"))
    assert objects == sorted(p.stem for p in folder.glob("model*.c"))
    commands = []
    compile_all = core.run_compilers
    monkeypatch.setattr(core, "run_compilers",
                        lambda cmds, *a, **k: (commands.extend(cmds), compile_all(cmds, *a, **k)))
    for library in (folder / "build").glob("*/libdepsim_model.so"):
        library.unlink()
    build_model_library(folder)
    assert len(commands) == 1 and "-shared" in commands[0]  # the link alone
