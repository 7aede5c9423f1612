"""The model text's range checks in the integrator core: the generated model carries them
(LIMITS, LIMIT_KINDS, LIMIT_MESSAGES, parameter_checks), and every entry point of the core
refuses a parameter vector that breaks one, with the words of `depsim.dsl.check_parameters`:
dep_check_parameters, dep_simulate and dep_open (the binding of either target, a C target's
shared library), the standalone program (exit 2); `depsim run` keeps its own diagnostics."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from depsim.codegen.c_emit import c_program_name, compile_c
from depsim.dsl import check_parameters, load_model
from depsim.runtime import simulate
from depsim.runtime.binding import bind
from depsim.runtime.core import core, ffi

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted(path.stem for path in (ROOT / "examples").glob("*.dep"))
HERE = Path(__file__).resolve().parent


def c_check(module, p, only=None) -> str:
    """dep_check_parameters of the core on `module` (a NumPy module or a CModule): "" when
    every range holds, else the error's message."""
    view, library = ffi(), core()
    binding = bind(module)
    error = view.new("dep_error *")
    flags = view.NULL if only is None else view.new("unsigned char[]", list(only) or [0])
    with binding.running():
        status = library.dep_check_parameters(binding.pointer,
                                              view.new("double[]", list(p) or [0.0]), flags,
                                              error)
    message = view.string(error.message).decode()
    assert (status == library.DEP_OK) == (message == ""), (status, message)
    assert status in (library.DEP_OK, library.DEP_SETTINGS_ERROR)
    return message


def broken_vectors(model):
    """Parameter vectors each breaking something: every parameter in turn negated (0 made
    -1), and each ordered pair turned round."""
    defaults = [p.default for p in model.params]
    for j in range(len(defaults)):
        p = list(defaults)
        p[j] = -p[j] if p[j] != 0 else -1.0
        yield p
    names = {p.name: j for j, p in enumerate(model.params)}
    for limit in model.limits:
        if limit.bound is not None and limit.what in names and limit.bound_what in names:
            p = list(defaults)
            a, b = names[limit.what], names[limit.bound_what]
            p[a], p[b] = p[b] + 1.0, p[a]
            yield p


@pytest.mark.parametrize("name", EXAMPLES)
def test_the_core_words_every_broken_range_as_the_model_checker(example_builds, name):
    """On every example, for vectors breaking each of its ranges: the core's message (C
    model and NumPy module alike) is check_parameters' messages joined by '; '."""
    built = example_builds(name)
    model = built.model
    assert len(built.numpy.LIMITS) == len(model.limits) > 0
    assert c_check(built.c, built.c.PARAMETER_DEFAULTS) == ""
    broken = 0
    for p in broken_vectors(model):
        expected = "; ".join(check_parameters(model, p))
        broken += bool(expected)
        assert c_check(built.c, p) == expected
        assert c_check(built.numpy, p) == expected
    assert broken >= len({limit.what for limit in model.limits if limit.bound is None}) // 2


def test_an_ordered_pair_names_both_ends(tmp_path):
    """stop_min < stop_max of a model with hard stops: the C model's words are the checker's."""
    from depsim.runtime.binding import load_folder

    model = load_model(HERE / "models" / "pendulum_stops.dep")
    names = [p.name for p in model.params]
    below = next(limit for limit in model.limits if limit.kind == "below")
    c_model = load_folder(compile_c(model, tmp_path / "c"))
    p = [q.default for q in model.params]
    p[names.index(below.what)] = 10.0
    (expected,) = check_parameters(model, p)
    assert expected.startswith(f"{below.what} must be less than {below.bound_what}, got 10 rad")
    assert c_check(c_model, p) == expected


def test_pendulum_inertia_names_its_parameters(example_builds):
    built = example_builds("pendulum")
    p = list(built.c.PARAMETER_DEFAULTS)
    p[built.c.PARAMETERS.index("L")] = 0.0
    assert c_check(built.c, p) == ("rod.length must be positive, got 0 m (from L = 0 m); "
                                   "rod.inertia must be positive, got 0 kg*m^2 (from L = 0 m)")


def test_only_the_checks_of_the_given_parameters(example_builds):
    """`only`: a check is applied when every parameter it depends on is flagged (an FMU
    checks a value as it is set, a pair of values once both are)."""
    built = example_builds("pendulum")
    names = built.c.PARAMETERS
    p = list(built.c.PARAMETER_DEFAULTS)
    p[names.index("L")], p[names.index("m")] = -1.0, -2.0
    length = "rod.length must be positive, got -1 m (from L = -1 m)"
    mass = "rod.mass must be positive, got -2 kg (from m = -2 kg)"
    inertia = "rod.inertia must be positive, got -0.166667 kg*m^2 (from L = -1 m, m = -2 kg)"
    assert c_check(built.c, p, [name == "L" for name in names]) == length
    assert c_check(built.c, p, [name == "m" for name in names]) == mass  # inertia: m and L
    assert c_check(built.c, p, [name in ("L", "m") for name in names]) == \
        f"{length}; {mass}; {inertia}"
    assert c_check(built.c, p, [False] * len(names)) == ""


@pytest.mark.parametrize("target", ["numpy", "c"])
def test_simulate_refuses_a_vector_out_of_range(example_builds, target):
    """The binding (dep_simulate) of either target raises ValueError with the message, and
    runs nothing."""
    built = example_builds("fourbar")
    module = built.numpy if target == "numpy" else built.c
    p = np.array(module.PARAMETER_DEFAULTS)
    p[list(module.PARAMETERS).index("crank")] = -0.1
    expected = "; ".join(check_parameters(built.model, list(p)))
    assert expected.startswith("crank_bar.length must be positive, got -0.1 m")
    with pytest.raises(ValueError) as caught:
        simulate(module, p, t_end=0.1)
    assert str(caught.value) == expected


def test_a_hand_written_module_is_checked_through_its_callback():
    from depsim.runtime.binding import load_module

    module = load_module(ROOT / "tests" / "runtime" / "models" / "pendulum.py")
    p = np.array(module.PARAMETER_DEFAULTS)
    p[0] = -2.0
    expected = r"^rod.length must be positive, got -2 m \(from L = -2 m\)$"
    with pytest.raises(ValueError, match=expected):
        simulate(module, p, t_end=0.1)


@pytest.fixture(scope="module")
def programs(tmp_path_factory):
    """name -> the folder of the example's C target, built by its Makefile."""
    made = {}

    def get(name: str) -> Path:
        if name not in made:
            model = load_model(ROOT / "examples" / f"{name}.dep")
            folder = compile_c(model, tmp_path_factory.mktemp(name))
            run = subprocess.run(["make", "-j2", "-C", str(folder)], capture_output=True,
                                 text=True)
            assert run.returncode == 0, run.stdout + run.stderr
            made[name] = folder
        return made[name]

    return get


CASES = [("intelsat5", "h2.friction=-0.7", "h2.friction must not be negative, got -0.7 N*m"),
         ("intelsat5", "h1.stiffness=-5", "h1.stiffness must not be negative, got -5 N*m/rad"),
         ("intelsat5", "panel1.length=-1.965", "panel1.length must be positive, got -1.965 m"),
         ("pendulum", "L=-1", "rod.length must be positive, got -1 m (from L = -1 m)")]


@pytest.mark.parametrize("name, item, message", CASES)
def test_the_program_refuses_values_out_of_range(programs, tmp_path, name, item, message):
    """Exit 2 with the message, nothing written; the values depsim run refuses too."""
    folder = programs(name)
    out = tmp_path / "out.csv"
    run = subprocess.run([str(folder / name), "--set", item, "--t-end", "0.1", "-o", str(out)],
                         env={}, capture_output=True, text=True)
    assert run.returncode == 2, run.stdout + run.stderr
    assert run.stderr == f"{name}: error: {message}\n"
    assert run.stdout == "" and not out.exists()
    model = load_model(ROOT / "examples" / f"{name}.dep")
    key, value = item.split("=")
    p = [q.default for q in model.params]
    p[[q.name for q in model.params].index(key)] = float(value)
    assert check_parameters(model, p) == [message]
    done = subprocess.run([sys.executable, "-m", "depsim", "run", ROOT / "examples" / f"{name}.dep",
                           "--set", item, "--t-end", "0.1"], capture_output=True, text=True)
    assert done.returncode == 2 and message.split(" (from")[0] in done.stderr, done.stderr


def test_the_shared_library_refuses_values_out_of_range(programs):
    """A C target's lib<name>.so: dep_simulate and dep_open return DEP_SETTINGS_ERROR with
    the message; dep_check_parameters says the same."""
    folder = programs("intelsat5")
    view = ffi()
    stem = c_program_name(load_model(ROOT / "examples" / "intelsat5.dep"))
    library = view.dlopen(str(folder / f"lib{stem}.so"))
    model = view.addressof(library, "depsim_model")
    names = [view.string(model.parameter_names[i]).decode() for i in range(model.np)]
    p = view.new("double[]", [model.parameter_defaults[i] for i in range(model.np)])
    p[names.index("h2.friction")] = -0.7
    error = view.new("dep_error *")
    result = view.new("dep_result *")
    expected = "h2.friction must not be negative, got -0.7 N*m"
    assert library.dep_simulate(model, p, view.NULL, view.NULL, 0, result,
                                error) == library.DEP_SETTINGS_ERROR
    assert view.string(error.message).decode() == expected
    run = view.new("dep_run **")
    assert library.dep_open(model, p, view.NULL, run, error) == library.DEP_SETTINGS_ERROR
    assert view.string(error.message).decode() == expected and run[0] == view.NULL
    assert library.dep_check_parameters(model, p, view.NULL, error) == library.DEP_SETTINGS_ERROR
    assert view.string(error.message).decode() == expected
