"""The generated C functions agree with the NumPy module's at random states (to 1e-12 relative
to each array's scale), the name tables and defaults are the same, and model.c compiles
warning-free under strict C99."""

from __future__ import annotations

import inspect
import subprocess

import numpy as np
import pytest

from depsim.runtime.core import compiler
from depsim.runtime.interface import FUNCTION_NAMES
from depsim.runtime.interface import initial_state

STRICT = ("-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror")
CONSTANTS = ("MODEL_NAME", "DESCRIPTION", "SOURCE_FILE", "SOURCE_SHA256", "DEPSIM_VERSION",
             "NQ", "NC", "NP",
             "COORDINATES", "PARAMETERS", "PARAMETER_DEFAULTS", "PARAMETER_UNITS", "CONSTRAINTS",
             "CONSTRAINT_JOINTS", "CONSTRAINT_HINGES", "CONSTRAINT_SLIDERS", "PHI_Q_ROWS",
             "PHI_Q_COLS", "HINGES", "HINGE_PROPERTIES",
             "SLIDERS", "OUTPUTS", "OUTPUT_UNITS", "ENERGIES", "DISSIPATORS", "T_END", "TOL",
             "DT_OUT", "RUN_VALUES")


def random_states(module, count=4, seed=11):
    """(v, vd, q, qd, t, p, lam, w) near the assembled pose with parameters perturbed by up to
    10 %, random multipliers and run values."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        p = np.array(module.PARAMETER_DEFAULTS) * rng.uniform(0.9, 1.1, module.NP)
        q0, _ = initial_state(module, p)
        q = q0 + 0.05 * rng.standard_normal(module.NQ)
        v = module.tree_values(p)[0] + 0.1 * rng.standard_normal(len(module.TREE_JOINTS))
        vd = rng.standard_normal(len(module.TREE_JOINTS))
        yield (v, vd, q, rng.standard_normal(module.NQ), float(rng.uniform(0, 2)), p,
               rng.standard_normal(module.NC), rng.uniform(0.5, 2.0, len(module.RUN_VALUES)))


def test_tables_and_settings_match(built):
    for name in CONSTANTS:
        assert getattr(built.c, name) == getattr(built.numpy, name), name


@pytest.mark.parametrize("function", FUNCTION_NAMES)
def test_functions_match_numpy(built, function):
    numpy_function, c_function = getattr(built.numpy, function), getattr(built.c, function)
    args = tuple(inspect.signature(numpy_function).parameters)
    for v, vd, q, qd, t, p, lam, w in random_states(built.numpy):
        values = {"v": v, "vd": vd, "q": q, "qd": qd, "t": t, "p": p, "lam": lam, "w": w}
        expected = numpy_function(*(values[a] for a in args))
        got = c_function(*(values[a] for a in args))
        for e, g in zip(*(x if isinstance(x, tuple) else (x,) for x in (expected, got))):
            e, g = np.asarray(e, dtype=float), np.asarray(g, dtype=float)
            assert e.shape == g.shape
            scale = max(1.0, float(np.nanmax(np.abs(e), initial=0.0)))
            np.testing.assert_allclose(g, e, rtol=0, atol=1e-12 * scale, equal_nan=True,
                                       err_msg=f"{built.case}: {function}")


def generated_c(folder) -> str:
    """The text of a C folder's generated model files (model.c and any model_<name>.c)."""
    return "".join(path.read_text() for path in sorted(folder.glob("model*.c")))


def test_model_compiles_under_strict_c99(built, tmp_path):
    for source in sorted(built.folder.glob("model*.c")):
        run = subprocess.run([*compiler(), *STRICT, "-c", str(source),
                              "-o", str(tmp_path / f"{source.stem}.o")],
                             capture_output=True, text=True)
        assert run.returncode == 0, run.stderr


def test_a_chains_tree_is_placed_by_kernels(built_cases):
    """tests/codegen/models/spatial_chain.dep: each hinge's placement of a kind that repeats
    is a kernel's call reading its parent's coordinates (rates) from the result, the bars
    placed in the tree's order though listed from the tip; the tangent reads the pose that
    tree_pose wrote (test_functions_match_numpy checks their values)."""
    text = generated_c(built_cases("model:spatial_chain").folder)
    pose = text[text.index("void model_tree_pose("):text.index("void model_tree_tangent(")]
    tangent = text[text.index("void model_tree_tangent("):]
    tangent = tangent[:tangent.index("\n}\n")]
    calls = [line.strip() for line in pose.splitlines() if "tree_pose_hinge_0(" in line]
    assert calls == ["tree_pose_hinge_0(a, c, q + 36);", "tree_pose_hinge_0(q + 36, c, q + 24);",
                     "tree_pose_hinge_0(q + 24, c, q + 12);", "tree_pose_hinge_0(q + 12, c, q);"]
    assert "model_tree_pose(v, p, pose);" in tangent
    assert "tree_tangent_hinge_0(pose + 12, qd + 12, c, qd);" in tangent


def test_a_chains_system_state_adds_each_bodys_terms(built_cases):
    """The momenta and the angular momentum of spatial_chain.dep's five equal bars: each
    bar's terms a kernel's call adding them (test_functions_match_numpy checks the values)."""
    text = generated_c(built_cases("model:spatial_chain").folder)
    state = text[text.index("void model_system_state("):]
    state = state[:state.index("\n}\n")]
    assert [line.strip() for line in state.splitlines() if "system_state_body_0(" in line] \
        == [f"system_state_body_0({q}, {q.replace('q', 'qd')}, p, out);"
            for q in ("q", "q + 12", "q + 24", "q + 36", "q + 48")]
    assert state.count("s[7] += out[3];") == 5
