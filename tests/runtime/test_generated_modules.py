"""The runtime on modules generated from examples/*.dep, cross-checked against the hand-made
modules of tests/runtime/models (written independently from the interface document)."""

from pathlib import Path

import numpy as np
import pytest

from depsim.runtime import simulate
from depsim.runtime.interface import dense
from depsim.runtime.interface import initial_state

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    import depsim.codegen as codegen
    import depsim.dsl as dsl
    out = tmp_path_factory.mktemp("generated")
    return {name: codegen.load_generated(codegen.compile_numpy(
        dsl.load_model(EXAMPLES / f"{name}.dep"), out)) for name in ("pendulum", "slider_crank")}


@pytest.mark.parametrize("name", ["pendulum", "slider_crank"])
def test_generated_functions_agree_with_the_hand_made_module(generated, request, name):
    gen, hand = generated[name], request.getfixturevalue(name)
    pg, ph = np.array(gen.PARAMETER_DEFAULTS, float), np.array(hand.PARAMETER_DEFAULTS, float)
    assert gen.COORDINATES == hand.COORDINATES and gen.CONSTRAINTS == hand.CONSTRAINTS
    assert gen.OUTPUTS == hand.OUTPUTS and gen.HINGES == hand.HINGES
    q0g, qd0g = initial_state(gen, pg)
    q0h, qd0h = initial_state(hand, ph)
    assert np.allclose(q0g, q0h, atol=1e-14) and np.allclose(qd0g, qd0h, atol=1e-14)
    assert np.allclose(dense(gen, "mass_matrix", pg), dense(hand, "mass_matrix", ph),
                       rtol=1e-14)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, qd = q0h + 0.1 * rng.normal(size=hand.NQ), rng.normal(size=hand.NQ)
        t = float(rng.uniform(0, 1))
        # rows may differ in sign between the two writings; compare up to a row sign
        sign = np.sign(np.sum(dense(gen, "phi_q", q, t, pg) * dense(hand, "phi_q", q, t, ph), 1))
        assert np.allclose(sign * gen.phi(q, t, pg), hand.phi(q, t, ph), atol=1e-13)
        assert np.allclose(sign[:, None] * dense(gen, "phi_q", q, t, pg),
                           dense(hand, "phi_q", q, t, ph), atol=1e-13)
        assert np.allclose(sign * gen.gamma(q, qd, t, pg), hand.gamma(q, qd, t, ph), atol=1e-12)
        assert np.allclose(gen.force(q, qd, t, pg), hand.force(q, qd, t, ph), atol=1e-12)
        lam, w = np.zeros(gen.NC), np.zeros(len(gen.RUN_VALUES))
        assert np.allclose(gen.outputs(q, qd, t, pg, lam, w), hand.outputs(q, qd, t, ph, lam, w),
                           atol=1e-13)
        assert np.allclose(gen.hinge_angles(q, pg), hand.hinge_angles(q, ph), atol=1e-13)
        assert np.allclose(dense(gen, "hinge_jacobian", q, pg),
                           dense(hand, "hinge_jacobian", q, ph), atol=1e-13)
        assert np.allclose(np.sum(gen.energy(q, qd, t, pg)), np.sum(hand.energy(q, qd, t, ph)),
                           atol=1e-12)


@pytest.mark.parametrize("name, t_end", [("pendulum", 1.0), ("slider_crank", 0.5)])
def test_generated_module_runs_like_the_hand_made_one(generated, request, name, t_end):
    gen, hand = generated[name], request.getfixturevalue(name)
    from_dep = simulate(gen, t_end=t_end, tol=1e-10)
    by_hand = simulate(hand, t_end=t_end, tol=1e-10, dt_out=gen.DT_OUT)
    assert from_dep.model == name and np.array_equal(from_dep.times, by_hand.times)
    assert np.max(np.abs(from_dep.outputs - by_hand.outputs)) < 1e-9
    assert from_dep.stats.max_v_pos <= from_dep.constraint_tol * max(1, np.abs(from_dep.q).max())
