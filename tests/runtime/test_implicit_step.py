"""The linearly implicit step for stiff elastic forces (runtime/c/rosenbrock.c, docs/method.md
section 10), through the real pipeline with the C target.

References: examples/two_link_flex.dep integrated with the explicit step (DOPRI 5(4), which
resolves every mode) at tol 1e-10; beam theory for the cantilever. The explicit run agrees with
an independent solver (scipy Radau on the augmented system, bench/beam_reference.py) to
1.3e-7 rad over the full 5 s, so it is the converged solution of the same mesh here.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import depsim
from depsim.runtime.results import Stats

MODEL = Path(__file__).resolve().parents[2] / "examples" / "two_link_flex.dep"
SPAN = 0.5  # s
DT_OUT = 0.001  # s

RIGID = """\
model rigid_pair
gravity = (0, -9.81) m/s^2
bar link { length = 1 m; mass = 5 kg; inertia = (5/12) kg*m^2 }
hinge pin joins ground.origin to link.a { angle = link - ground + 90 deg }
initial { pin = 5 deg }
simulate { t_end = 0.1 s; tol = 1e-8; dt_out = 0.01 s }
"""

# An exact clamp (a slider along the beam's axis) and a stiff beam: EA / EI = 1e4 m^-2 puts
# the axial modes 70 times above the first bending mode.
CANTILEVER = """\
model cantilever "clamped beam released in gravity"
gravity = (0, -9.81) m/s^2
beam arm { length = 1 m; EI = 100 N*m^2; EA = 1e6 N; mass_per_length = 1 kg/m; elements = 4 }
slider clamp joins ground.origin to arm.a { axis = (1, 0) }
simulate { t_end = 0.45 s; tol = 1e-8; dt_out = 0.001 s }
output deflection = arm.tip_deflection
"""
CANTILEVER_ROOT = 1.8751040687119611  # cos b cosh b = -1


@pytest.fixture(scope="module")
def pendulum(tmp_path_factory):
    """two_link_flex (two elements per link), C target, and its explicit reference run."""
    sim = depsim.load(MODEL).compile(target="c", out_dir=tmp_path_factory.mktemp("m2"))
    reference = sim.run(t_end=SPAN, dt_out=DT_OUT, tol=1e-10, stepping="explicit")
    return sim, reference


def run(sim, tol, stepping):
    return sim.run(t_end=SPAN, dt_out=DT_OUT, tol=tol, stepping=stepping)


def worst(result, reference, name):
    return float(np.max(np.abs(result.output(name) - reference.output(name))))


def test_auto_takes_the_implicit_step_only_where_the_explicit_one_is_stability_bound(pendulum):
    """At tol 1e-8 DOPRI's step would sit at the axial modes' stability bound (h omega_max ~ 1,
    omega_max = 6.5e4 rad/s): auto switches within the first steps and says so. At tol 1e-10
    accuracy holds the explicit step far below that bound, and it stays explicit."""
    sim, _ = pendulum
    switched = run(sim, 1e-8, "auto")
    assert 0.0 < switched.stats.implicit_from < 1e-3
    # the rate that held it: the axial modes' (omega_max, or Hairer's estimate if larger)
    assert 0.95 * 6.5e4 < switched.stats.stiff_rate < 2 * 6.5e4
    assert "linearly implicit steps from t = " in switched.report_text
    accurate = run(sim, 1e-10, "auto")
    assert accurate.stats.implicit_from is None
    assert "linearly implicit" not in accurate.report_text
    forced = run(sim, 1e-8, "implicit")
    assert forced.stats.implicit_from == 0.0 and forced.stats.stiff_rate is None
    assert "linearly implicit steps throughout" in forced.report_text
    assert run(sim, 1e-8, "explicit").stats.implicit_from is None
    assert Stats().implicit_from is None


def test_the_implicit_steps_error_falls_with_tol(pendulum):
    """chord2 and tip2 against the explicit reference: the error falls as tol falls (measured
    chord2 4.3e-5, 7.9e-7, 1.6e-8 rad and tip2 8.6e-5, 2.0e-5, 2.2e-7 m at tol 1e-6, 1e-8,
    1e-10), and at the model's tol 1e-8 it is inside the accuracy asked of a 16-element run
    against the converged solution (2e-5 rad, 1e-4 m raw)."""
    sim, reference = pendulum
    errors = {tol: run(sim, tol, "implicit") for tol in (1e-6, 1e-8, 1e-10)}
    chord = {tol: worst(r, reference, "chord2") for tol, r in errors.items()}
    tip = {tol: worst(r, reference, "tip2") for tol, r in errors.items()}
    assert chord[1e-6] > chord[1e-8] > 10 * chord[1e-10]
    assert tip[1e-6] > tip[1e-8] > 10 * tip[1e-10]
    assert chord[1e-8] < 2e-5 and tip[1e-8] < 1e-4
    assert chord[1e-10] < 1e-7 and tip[1e-10] < 1e-6
    for result in errors.values():  # the position level holds at every step: each row
        # within constraint_tol of its size sum_k |J_ik| (s_k + |q_k|), s_k = 1 m (the
        # links' length), |q| <= 2 m: at most a few metres for the hinges' and nodes' rows
        assert result.stats.max_v_pos <= 10 * result.constraint_tol


def test_the_implicit_step_only_damps(pendulum):
    """The undamped pendulum's energy (kinetic + gravity + elastic). The L-stable step damps
    the modes it does not resolve, so the energy may only fall: it never rises above its
    start by more than round-off, and the loss shrinks with tol (measured 3.4e-4, 6.0e-5,
    1.1e-5 of the largest kinetic energy at tol 1e-8, 1e-9, 1e-10). The explicit step keeps
    it to 1e-4 of it (tests/examples/test_two_link_flex.py). Looser tolerances let the step
    pass the first axial mode's period and the energy may rise (docs/method.md, 10)."""
    sim, _ = pendulum
    losses = []
    for tol in (1e-8, 1e-9, 1e-10):
        result = run(sim, tol, "implicit")
        total, kinetic = result.total_energy(), result.energy[:, 0]
        assert np.max(total - total[0]) <= 1e-9 * kinetic.max()
        losses.append(np.max(total[0] - total) / kinetic.max())
    assert losses[0] < 2e-3
    assert losses[0] > losses[1] > losses[2]


def test_the_stiff_modes_do_not_hold_the_implicit_step(tmp_path):
    """two_link_flex at 8 elements per link, 0.2 s, against the explicit step at tol 1e-9. With
    the acceleration pass's multipliers in the profile's history, the reactions of the stiff
    modes the step damps came back through the profile, and the step sat where that loop
    stops being stable (h omega of about 5 for the fastest bending mode, the same at tol 1e-6
    and 1e-8; docs/method.md, 10). With those modes left out of the kept multipliers, the step
    follows tol (measured 240, 858 and 1971 steps at tol 1e-6, 1e-7, 1e-8, the longest 6 times
    shorter at 1e-8 than at 1e-6), passes far beyond the fastest mode's rate (max step times
    it: 38 at 1e-8), and the error falls with tol (chord2 1.4e-5, 3.3e-6, 6.8e-7 rad, tip2
    6.2e-5, 2.8e-5, 5.1e-6 m)."""
    model = depsim.load(MODEL).with_elements({"link1": 8, "link2": 8})
    sim = model.compile(target="c", out_dir=tmp_path)
    reference = sim.run(t_end=0.2, dt_out=DT_OUT, tol=1e-9, stepping="explicit")
    runs = {tol: sim.run(t_end=0.2, dt_out=DT_OUT, tol=tol) for tol in (1e-6, 1e-7, 1e-8)}
    steps = [runs[tol].stats.accepted_steps for tol in (1e-6, 1e-7, 1e-8)]
    assert steps[0] < steps[1] < steps[2] and 4 * steps[0] < steps[2]
    held = runs[1e-8].stats
    assert held.implicit_from is not None and held.max_step * held.stiff_rate > 20
    chord = [worst(runs[tol], reference, "chord2") for tol in (1e-6, 1e-7, 1e-8)]
    tip = [worst(runs[tol], reference, "tip2") for tol in (1e-6, 1e-7, 1e-8)]
    assert chord[0] > chord[1] > chord[2] and tip[0] > tip[1] > tip[2]
    assert chord[2] < 2e-6 and tip[2] < 2e-5


def beam_chain(bars: int) -> str:
    """A 2-element beam hinged to the ground with `bars` rigid bars hinged after it."""
    lines = ["model beam_chain", "gravity = (0, -9.81) m/s^2",
             "beam arm { length = 0.5 m; EI = 50 N*m^2; EA = 1e5 N; mass_per_length = 2 kg/m; "
             "elements = 2 }",
             "hinge h0 joins ground.origin to arm.a { angle = arm - ground + 90 deg }"]
    for i in range(bars):
        before = "arm" if i == 0 else f"b{i - 1}"
        lines += [f"bar b{i} {{ length = 0.2 m; mass = 0.4 kg; inertia = 0.0013 kg*m^2 }}",
                  f"hinge h{i + 1} joins {before}.b to b{i}.a {{ angle = b{i} - {before} }}"]
    lines += ["initial { h0 = 20 deg }", "simulate { t_end = 0.3 s; tol = 1e-8; dt_out = 0.01 s }"]
    return "\n".join(lines) + "\n"


def test_many_rows_keep_their_multipliers_by_the_iteration(tmp_path):
    """With more than 16 rows (here 18) the multipliers kept under the linearly implicit step
    come from the iteration (6) with the Schur cache's A rather than one block of solves
    (stepper.c, FILTER_DIRECT_ROWS): against the explicit step at tol 1e-10 the hinge angles
    agree to 3.7e-5 and 4.4e-6 rad at tol 1e-6 and 1e-8 (453 and 1971 steps over 0.3 s; the
    explicit step at tol 1e-8 would sit at the beam's axial stability bound)."""
    path = tmp_path / "beam_chain.dep"
    path.write_text(beam_chain(8))
    sim = depsim.load(path).compile(target="c", out_dir=tmp_path / "c")
    assert sim.module.NC > 16
    reference = sim.run(tol=1e-10, stepping="explicit")
    errors, steps = [], []
    for tol in (1e-6, 1e-8):
        result = sim.run(tol=tol, stepping="implicit")
        errors.append(float(np.max(np.abs(result.hinge_angles - reference.hinge_angles))))
        steps.append(result.stats.accepted_steps)
    assert errors[0] > errors[1] and errors[1] < 2e-5
    assert 2 * steps[0] < steps[1]


def test_numpy_and_c_take_the_same_implicit_steps(tmp_path):
    """The one integrator drives either target: the same steps, outputs to round-off."""
    model = depsim.load(MODEL)
    runs = [model.compile(target=target, out_dir=tmp_path / target).run(
        t_end=0.02, dt_out=DT_OUT, stepping="implicit") for target in ("numpy", "c")]
    assert runs[0].stats.accepted_steps == runs[1].stats.accepted_steps
    for name in ("chord2", "tip2"):
        assert np.max(np.abs(runs[0].output(name) - runs[1].output(name))) < 1e-12


def test_a_stiff_cantilever_vibrates_at_beam_theory_frequency(tmp_path):
    """Released undeformed, the clamped beam swings about its static sag w L^4 / (8 EI) at
    beam theory's first frequency; its axial modes (about 7,800 rad/s) are left to the
    implicit step. Four elements: the element's own frequency error is 5e-5."""
    path = tmp_path / "cantilever.dep"
    path.write_text(CANTILEVER, encoding="utf-8")
    result = depsim.load(path).compile(target="c", out_dir=tmp_path / "c").run(
        stepping="implicit")
    deflection = -result.output("deflection")
    times = result.times
    centred = deflection - deflection.mean()
    crossings = np.nonzero(np.sign(centred[1:]) != np.sign(centred[:-1]))[0]
    omega = math.pi / np.mean(np.diff(times[crossings]))
    assert omega == pytest.approx(CANTILEVER_ROOT ** 2 * 10.0, rel=5e-3)
    assert deflection.mean() == pytest.approx(9.81 / (8 * 100.0), rel=0.05)


def test_implicit_stepping_needs_stiff_forces(tmp_path):
    path = tmp_path / "rigid.dep"
    path.write_text(RIGID, encoding="utf-8")
    sim = depsim.load(path).compile(target="c", out_dir=tmp_path / "c")
    with pytest.raises(ValueError, match="stepping implicit needs stiff forces"):
        sim.run(stepping="implicit")
    with pytest.raises(ValueError, match="stepping must be one of auto, explicit, implicit"):
        sim.run(stepping="euler")
    assert sim.run().stats.implicit_from is None


def test_a_step_costs_three_force_evaluations(pendulum):
    """ROS34PW2 evaluates the force at three of its four stages; the first stage's is the
    acceleration pass's of the step before (same t, q, qd), and the position pass moves the
    step's end by its linear response instead of integrating again while that is accurate
    (docs/method.md, 10). So a step costs about three evaluations (measured 3.0x at 2 and 16
    elements; it was 7 with every step integrated twice and its first stage evaluated)."""
    sim, _ = pendulum
    stats = run(sim, 1e-8, "implicit").stats
    evaluations = stats.rhs_evaluations / (stats.accepted_steps + stats.rejected_steps)
    assert 2.9 < evaluations < 3.3, evaluations
