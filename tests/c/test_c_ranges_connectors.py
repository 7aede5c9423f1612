"""The range checks of the connectors and members of issue 34 (particles, spring-dampers,
welds, hold-downs) in every entry point of the core, from the one table the model text's
checker fills (Model.limits -> LIMITS, LIMIT_MESSAGES, parameter_checks): a particle's mass
> 0, a spring's stiffness, free length and damping >= 0, a hold-down's release >= 0; a weld's
angle has no range. The NumPy module and the C model word them as depsim.dsl.check_parameters,
dep_simulate refuses them, and so do the standalone program, `depsim run` and `depsim modes`
(exit 2, the same message)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from depsim.codegen.c_emit import c_program_name, compile_c
from depsim.dsl import check_parameters, load_model
from depsim.dsl.limits import LIMIT_KINDS, message_format
from depsim.runtime import simulate

from test_c_ranges import c_check

ROOT = Path(__file__).resolve().parents[2]
FREE_FLYER = ROOT / "examples" / "free_flyer.dep"

# tests/codegen/models/connectors.dep: (parameter, value, the one message)
CONNECTOR_CASES = [
    ("tip.mass", -0.5, "tip.mass must be positive, got -0.5 kg"),
    ("rider.mass", 0.0, "rider.mass must be positive, got 0 kg"),
    ("drifter.mass", -0.1, "drifter.mass must be positive, got -0.1 kg"),
    ("kick.stiffness", -300.0, "kick.stiffness must not be negative, got -300 N/m"),
    ("kick.free_length", -0.4, "kick.free_length must not be negative, got -0.4 m"),
    ("kick.damping", -1.5, "kick.damping must not be negative, got -1.5 kg/s"),
    ("tether.stiffness", -80.0, "tether.stiffness must not be negative, got -80 N/m"),
    ("link.damping", -0.2, "link.damping must not be negative, got -0.2 kg/s"),
    ("h1.release", -1.0, "h1.release must not be negative, got -1 s"),
]
NEW_CHECKS = {"tip.mass", "rider.mass", "drifter.mass", "h1.release", "kick.stiffness",
              "kick.free_length", "kick.damping", "tether.stiffness", "tether.free_length",
              "link.stiffness", "link.free_length", "link.damping"}


def test_the_connectors_checks_are_the_models_limits(built_cases):
    """The generated tables are Model.limits, the new connectors' checks among them."""
    built = built_cases("model:connectors")
    limits = built.model.limits
    assert NEW_CHECKS <= {limit.what for limit in limits}
    for module in (built.numpy, built.c):
        assert tuple(module.LIMITS) == tuple(limit.what for limit in limits)
        assert tuple(module.LIMIT_KINDS) == tuple(LIMIT_KINDS.index(limit.kind)
                                                  for limit in limits)
        assert tuple(module.LIMIT_MESSAGES) == tuple(message_format(limit) for limit in limits)
    assert not any(limit.what.startswith(("w1.", "w2.")) for limit in limits)  # welds: none


@pytest.mark.parametrize("name, value, message", CONNECTOR_CASES,
                         ids=[case[0] for case in CONNECTOR_CASES])
def test_the_core_refuses_the_connectors_values_out_of_range(built_cases, name, value,
                                                             message):
    """dep_check_parameters (C model and NumPy module) says what check_parameters says, and
    dep_simulate of either target refuses the vector with it."""
    built = built_cases("model:connectors")
    p = np.array(built.c.PARAMETER_DEFAULTS)
    p[list(built.c.PARAMETERS).index(name)] = value
    assert check_parameters(built.model, list(p)) == [message]
    assert c_check(built.c, p) == message
    assert c_check(built.numpy, p) == message
    for module in (built.c, built.numpy):
        with pytest.raises(ValueError) as caught:
            simulate(module, p, t_end=0.01)
        assert str(caught.value) == message


def test_a_welds_angle_takes_any_value(built_cases):
    built = built_cases("model:connectors")
    p = np.array(built.c.PARAMETER_DEFAULTS)
    p[list(built.c.PARAMETERS).index("w2.angle")] = -3.0
    assert check_parameters(built.model, list(p)) == []
    assert c_check(built.c, p) == c_check(built.numpy, p) == ""


def test_a_release_time_from_a_parameter_names_it(built_cases):
    """examples/free_flyer.dep: both hold-downs release at t_release; a negative one breaks
    both checks, each naming the parameter."""
    built = built_cases("example:free_flyer")
    p = np.array(built.c.PARAMETER_DEFAULTS)
    p[list(built.c.PARAMETERS).index("t_release")] = -1.0
    expected = ("h1.release must not be negative, got -1 s (from t_release = -1 s); "
                "h2.release must not be negative, got -1 s (from t_release = -1 s)")
    assert "; ".join(check_parameters(built.model, list(p))) == expected
    assert c_check(built.c, p) == c_check(built.numpy, p) == expected


@pytest.fixture(scope="module")
def free_flyer_program(tmp_path_factory) -> Path:
    model = load_model(FREE_FLYER)
    folder = compile_c(model, tmp_path_factory.mktemp("free_flyer"))
    run = subprocess.run(["make", "-j2", "-C", str(folder), c_program_name(model)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    return folder / c_program_name(model)


# (--set item, the message of the standalone program: the checker's words for the vector)
FREE_FLYER_CASES = [
    ("kick.stiffness=-1000", "kick.stiffness must not be negative, got -1000 N/m"),
    ("kick.free_length=-0.08", "kick.free_length must not be negative, got -0.08 m"),
    ("panel1.mass=-10", "panel1.mass must be positive, got -10 kg"),
    ("t_release=-2", "h1.release must not be negative, got -2 s (from t_release = -2 s); "
                     "h2.release must not be negative, got -2 s (from t_release = -2 s)"),
]


@pytest.mark.parametrize("item, message", FREE_FLYER_CASES,
                         ids=[case[0] for case in FREE_FLYER_CASES])
def test_the_program_refuses_the_free_flyers_values_out_of_range(free_flyer_program,
                                                                 tmp_path, item, message):
    """Exit 2 with the checker's words, nothing written."""
    out = tmp_path / "summary.json"
    done = subprocess.run([str(free_flyer_program), "--set", item, "--t-end", "0.1",
                           "--summary", str(out)], env={}, capture_output=True, text=True)
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stderr == f"{free_flyer_program.name}: error: {message}\n"
    assert done.stdout == "" and not out.exists()
    model = load_model(FREE_FLYER)
    name, value = item.split("=")
    p = [q.default for q in model.params]
    p[[q.name for q in model.params].index(name)] = float(value)
    assert "; ".join(check_parameters(model, p)) == message


@pytest.mark.parametrize("item, message", FREE_FLYER_CASES,
                         ids=[case[0] for case in FREE_FLYER_CASES])
def test_depsim_modes_refuses_what_depsim_run_refuses(tmp_path, item, message):
    """`depsim modes --set` is held to the checks of `depsim run --set`: exit 2, the same
    line (the value named as given), nothing written, nothing run."""
    lines = {}
    for command, option in (("run", "--summary"), ("modes", "--json")):
        out = tmp_path / f"{command}.json"
        done = subprocess.run([sys.executable, "-m", "depsim", command, str(FREE_FLYER),
                               "--set", item, "--target", "c", option, str(out)],
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 2, done.stdout + done.stderr
        assert "Traceback" not in done.stderr and not out.exists()
        lines[command] = done.stderr.splitlines()[-1]
    assert lines["modes"] == lines["run"]
    given = message.replace("t_release = -2 s", item)
    assert lines["run"] in (f"depsim: error: {given}", f"depsim: error: {given} (from {item})")
