"""The emitted NumPy module: golden file, byte-for-byte determinism, the documented interface,
and numpy-only imports."""

from __future__ import annotations

import ast
import difflib
import inspect
import os
import subprocess
import sys
from pathlib import Path

import pytest

import depsim
import handmade
from codegen_cases import load_example
from depsim import __version__
from depsim.codegen import compile_numpy, load_generated, numpy_source
from depsim.runtime.interface import initial_state, outputs_at

GOLDEN = Path(__file__).resolve().parents[1] / "golden"
HERE = Path(__file__).resolve().parent

# docs/generated-module.md: every function and its arguments.
INTERFACE = {
    "mass_matrix": ("p",),
    "phi": ("q", "t", "p"), "phi_q": ("q", "t", "p"),
    "phi_q_transpose_times": ("q", "t", "p", "lam"), "phi_t": ("q", "t", "p"),
    "gamma": ("q", "qd", "t", "p"), "force": ("q", "qd", "t", "p"),
    "hinge_angles": ("q", "p"), "hinge_rates": ("q", "qd", "p"), "hinge_jacobian": ("q", "p"),
    "hinge_gamma": ("q", "qd", "p"), "hinge_properties": ("p",),
    "outputs": ("q", "qd", "t", "p", "lam", "w"), "energy": ("q", "qd", "t", "p"),
    "dissipation": ("q", "qd", "t", "p"),
}
CONSTANTS = ("MODEL_NAME", "DESCRIPTION", "SOURCE_FILE", "SOURCE_SHA256", "DEPSIM_VERSION",
             "NQ", "NC", "NP",
             "COORDINATES", "PARAMETERS", "PARAMETER_DEFAULTS", "PARAMETER_UNITS", "CONSTRAINTS",
             "CONSTRAINT_JOINTS", "CONSTRAINT_HINGES", "CONSTRAINT_SLIDERS", "PHI_Q_ROWS",
             "PHI_Q_COLS", "HINGES", "HINGE_PROPERTIES",
             "SLIDERS", "OUTPUTS", "OUTPUT_UNITS", "ENERGIES", "DISSIPATORS", "T_END", "TOL",
             "DT_OUT", "RUN_VALUES")


def test_pendulum_golden(request):
    """Refresh with `pytest tests/codegen --update-golden` after an intended change. The
    depsim version in the header is written as <version>, so a release needs no refresh."""
    source = numpy_source(load_example("pendulum"))
    for text in (f"depsim {__version__} from", f"DEPSIM_VERSION = {__version__!r}"):
        assert text in source
        source = source.replace(text, text.replace(__version__, "<version>"))
    path = GOLDEN / "pendulum.py"
    if request.config.getoption("--update-golden"):
        path.write_text(source, encoding="utf-8", newline="\n")
    expected = path.read_text(encoding="utf-8")
    diff = "".join(difflib.unified_diff(expected.splitlines(True), source.splitlines(True),
                                        "tests/golden/pendulum.py", "emitted"))
    assert not diff, "emitted module differs from the golden file " \
                     "(pytest tests/codegen --update-golden):\n" + diff


def test_emission_is_deterministic_in_process(tmp_path):
    model = handmade.slider_crank()
    first = compile_numpy(model, tmp_path / "a").read_bytes()
    second = compile_numpy(model, tmp_path / "b").read_bytes()
    assert first == second


def test_emission_does_not_depend_on_hash_seed():
    """sympy orders some sets by hash: a fresh interpreter with another seed must agree."""
    script = ("import sys; sys.path.insert(0, sys.argv[1]); import handmade; "
              "from depsim.codegen import numpy_source; "
              "sys.stdout.write(numpy_source(handmade.cable_pair()) + "
              "numpy_source(handmade.slider_crank()))")
    expected = numpy_source(handmade.cable_pair()) + numpy_source(handmade.slider_crank())
    for seed in ("1", "2"):
        run = subprocess.run([sys.executable, "-c", script, str(HERE)], capture_output=True,
                             text=True, env=os.environ | {"PYTHONHASHSEED": seed}, check=True)
        assert run.stdout == expected


def test_module_has_the_documented_interface(compiled):
    m = compiled.module
    for name in CONSTANTS:
        assert hasattr(m, name), name
    for name, args in INTERFACE.items():
        assert tuple(inspect.signature(getattr(m, name)).parameters) == args, name
    assert m.NQ == len(m.COORDINATES) and m.NC == len(m.CONSTRAINTS) == len(m.CONSTRAINT_JOINTS)
    assert m.NP == len(m.PARAMETERS) == len(m.PARAMETER_DEFAULTS) == len(m.PARAMETER_UNITS)
    assert len(m.OUTPUTS) == len(m.OUTPUT_UNITS)
    assert m.MODEL_NAME == compiled.model.name
    assert m.DEPSIM_VERSION == depsim.__version__
    assert "/" not in m.SOURCE_FILE and m.SOURCE_SHA256 == compiled.model.source_sha256


def test_module_shapes(compiled):
    m = compiled.module
    p = __import__("numpy").array(m.PARAMETER_DEFAULTS)
    q, qd = initial_state(m, p)
    assert m.mass_matrix(p).shape == (len(m.MASS_ROWS),)
    assert q.shape == qd.shape == (m.NQ,)
    assert m.phi(q, 0.0, p).shape == m.phi_t(q, 0.0, p).shape == (m.NC,)
    assert m.gamma(q, qd, 0.0, p).shape == (m.NC,)
    assert m.phi_q(q, 0.0, p).shape == (len(m.PHI_Q_ROWS),)
    assert m.force(q, qd, 0.0, p).shape == (m.NQ,)
    assert m.hinge_jacobian(q, p).shape == (len(m.HINGE_JACOBIAN_ROWS),)
    assert m.hinge_gamma(q, qd, p).shape == (len(m.HINGES),)
    assert m.hinge_properties(p).shape == (len(m.HINGES), len(m.HINGE_PROPERTIES))
    assert outputs_at(m, q, qd, 0.0, p).shape == (len(m.OUTPUTS),)
    assert m.energy(q, qd, 0.0, p).shape == (len(m.ENERGIES),)
    assert m.dissipation(q, qd, 0.0, p).shape == (len(m.DISSIPATORS),)


def test_module_imports_numpy_and_math_only(tmp_path):
    tree = ast.parse(compile_numpy(handmade.cable_pair(), tmp_path).read_text())
    imported = {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                for alias in node.names}
    assert imported == {"math", "numpy"}
    assert not any(isinstance(node, ast.ImportFrom) for node in ast.walk(tree))


def test_load_generated_keeps_modules_apart(tmp_path):
    first = load_generated(compile_numpy(handmade.pendulum(), tmp_path / "a"))
    second = load_generated(compile_numpy(handmade.cable_pair(), tmp_path / "b"))
    assert (first.MODEL_NAME, second.MODEL_NAME) == ("pendulum", "cable_pair")
    assert "depsim_generated_pendulum" not in sys.modules


@pytest.mark.parametrize("name", ["energies", "dissipators"])
def test_energy_and_dissipator_names(compiled_cases, name):
    m = compiled_cases("handmade:pendulum_variant").module
    expected = {"energies": ("kinetic", "spring.pivot", "gravity"),
                "dissipators": ("damping.pivot",)}[name]  # friction: the runtime's
    assert getattr(m, name.upper()) == expected


def test_hinge_properties(compiled_cases):
    """Latch, stops and friction settings reach the runtime as numbers; nan when not given."""
    import numpy as np

    m = compiled_cases("handmade:pendulum_variant").module
    properties = dict(zip(m.HINGE_PROPERTIES, m.hinge_properties(np.ones(m.NP))[0]))
    assert properties["friction"] == 0.3 and properties["slip_rate"] == 0.1
    assert np.isnan(properties["latch"]) and np.isnan(properties["static_friction"])


def test_user_text_cannot_break_the_module(tmp_path):
    from dataclasses import replace

    model = replace(handmade.cable_pair(), description='ends in """ and \\ \n and a newline')
    module = load_generated(compile_numpy(model, tmp_path))
    assert '"""' in module.__doc__ and "\\" in module.__doc__
