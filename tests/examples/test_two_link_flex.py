"""examples/two_link_flex.dep (docs/examples.md, two flexible links, the paper's section 3 example) through the real
pipeline: load -> with_elements -> compile(target="numpy") -> the iterative integrator, and
the `--elements` option of the command line.

The links' axial modes (6.5e4 rad/s at two elements, growing like the element count;
docs/beams.md) would hold an explicit step near 1e-5 s; at the model's tol the run takes the
linearly implicit step instead (docs/method.md, 10), and runs here compare it with the explicit
one. bench/bench_beams.py runs the full 5 s and the 16-element mesh. Reference numbers and where they come from are given at each assertion.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import depsim
from depsim.codegen import load_generated
from depsim.dsl import evaluate, ir
from depsim.runtime.interface import initial_state, outputs_at
from e2e import EXAMPLES

MODEL = EXAMPLES / "two_link_flex.dep"
ENERGY_SPAN = 0.5  # s, the 2-element runs
SHORT_SPAN = 0.02  # s, the 4- and 8-element runs of the convergence check
DT_OUT = 0.001  # s
PHI2 = math.radians(5.0)

# The same pendulum with rigid links (uniform bars, 5 kg, J = m L^2 / 12): the limit EI -> inf.
RIGID = """\
model two_link_rigid
gravity = (0, -9.81) m/s^2
bar link1 { length = 1 m; mass = 5 kg; inertia = (5/12) kg*m^2 }
bar link2 { length = 1 m; mass = 5 kg; inertia = (5/12) kg*m^2 }
hinge h1 joins ground.origin to link1.a { angle = link1 - ground + 90 deg }
hinge h2 joins link1.b to link2.a { angle = link2 - link1 }
initial { h1 = 0 deg; h2 = 5 deg }
simulate { t_end = 0.5 s; tol = 1e-10; dt_out = 0.001 s }
output chord2 = link2.phi + 90 deg
"""


def compile_m2(out_dir, elements: int, target: str = "numpy"):
    model = depsim.load(MODEL).with_elements({"link1": elements, "link2": elements})
    return model.compile(target=target, out_dir=out_dir)


def rigid_pendulum(tmp_path):
    path = tmp_path / "two_link_rigid.dep"
    path.write_text(RIGID, encoding="utf-8")
    return depsim.load(path).compile(out_dir=tmp_path / "rigid")


@pytest.fixture(scope="module")
def m2(tmp_path_factory):
    """The example as written (two elements per link), compiled once."""
    return compile_m2(tmp_path_factory.mktemp("m2_2"), 2)


@pytest.fixture(scope="module")
def m2_runs(m2, tmp_path_factory):
    """elements per link -> Result: 2 over ENERGY_SPAN, 4 and 8 over SHORT_SPAN."""
    runs = {2: m2.run(t_end=ENERGY_SPAN, dt_out=DT_OUT)}
    for n in (4, 8):
        sim = compile_m2(tmp_path_factory.mktemp(f"m2_{n}"), n)
        runs[n] = sim.run(t_end=SHORT_SPAN, dt_out=DT_OUT)
    return runs


# -- the model is M2 -------------------------------------------------------------------------

def test_example_is_models_md_m2():
    model = depsim.load(MODEL).ir
    values = [p.default for p in model.params]

    def value(expr):
        return evaluate(expr, values)

    assert [value(g) for g in model.gravity] == [0.0, -9.81]
    assert not model.bodies and not model.sliders and not model.cables
    assert [b.name for b in model.beams] == ["link1", "link2"]
    for beam in model.beams:
        assert value(beam.length) == 1.0
        assert value(beam.EI) == pytest.approx(2e11 * 5e-9, rel=1e-15)  # 1000 N m^2
        assert value(beam.EA) == pytest.approx(2e11 * 2.449e-4, rel=1e-15)
        assert value(beam.mass_per_length) == 5.0  # 5 kg over 1 m
        assert beam.elements == 2 and beam.damping is None  # the paper: two elements per link
    ground, link1, link2 = (ir.Member(ir.MemberKind.GROUND, 0),
                            ir.Member(ir.MemberKind.BEAM, 0), ir.Member(ir.MemberKind.BEAM, 1))
    h1, h2 = model.hinges
    assert (h1.a.member, h1.a.point, h1.b.member, h1.b.point) == (ground, "origin", link1, "a")
    assert (h2.a.member, h2.a.point, h2.b.member, h2.b.point) == (link1, "b", link2, "a")
    for hinge in (h1, h2):  # free hinges
        assert all(getattr(hinge, name) is None for name in (
            "stiffness", "preload", "friction", "static_friction", "damping", "latch",
            "stop_min", "stop_max"))
        assert value(hinge.initial_rate) == 0.0
    assert value(h1.initial_angle) == 0.0 and value(h2.initial_angle) == pytest.approx(PHI2)
    assert [o.name for o in model.outputs] == ["chord2", "tip2"]
    assert [o.unit for o in model.outputs] == ["rad", "m"]
    assert model.simulation.t_end == 5.0


def test_initial_state_and_outputs_follow_the_m2_conventions(m2):
    """Link 1 hangs straight down, link 2 is straight at 5 deg from -y (counter-clockwise, tip
    at x > 0), undeformed and at rest; chord2 and tip2 are the docs/examples.md definitions."""
    module, p = m2.module, m2.defaults
    q0, qd0 = (np.asarray(a, dtype=float) for a in initial_state(module, p))
    index = {name: k for k, name in enumerate(module.COORDINATES)}

    def node(q, beam, k):
        return np.array([q[index[f"{beam}.n{k}.{c}"]] for c in ("x", "y", "dx", "dy")])

    assert np.allclose(node(q0, "link1", 2), [0, -1, 0, -1], atol=1e-15)
    assert np.allclose(node(q0, "link2", 0), [0, -1, math.sin(PHI2), -math.cos(PHI2)])
    assert np.allclose(node(q0, "link2", 2), [math.sin(PHI2), -1 - math.cos(PHI2),
                                              math.sin(PHI2), -math.cos(PHI2)])
    assert not qd0.any()
    assert np.allclose(outputs_at(module, q0, qd0, 0.0, p), [PHI2, 0.0], atol=1e-15)
    assert np.allclose(module.hinge_angles(q0, p), [0.0, PHI2], atol=1e-15)
    # a deformed state: chord angle from -y, and e_z . (t_base x (r_tip - r_base))
    rng = np.random.default_rng(7)
    for _ in range(3):
        q = q0 + 0.05 * rng.normal(size=q0.size)
        base, tip = node(q, "link2", 0), node(q, "link2", 2)
        chord = tip[:2] - base[:2]
        tangent = base[2:] / np.linalg.norm(base[2:])
        expected = [math.atan2(chord[0], -chord[1]), tangent[0] * chord[1] - tangent[1] * chord[0]]
        assert np.allclose(outputs_at(module, q, qd0, 0.0, p), expected, rtol=1e-13, atol=1e-15)


# -- the run ---------------------------------------------------------------------------------

def test_undamped_pendulum_conserves_energy(m2_runs, tmp_path):
    """Kinetic + gravity + elastic energy (the generated `energy`) over ENERGY_SPAN at the
    model's tol 1e-8, with the explicit step (DOPRI 5(4), every mode resolved). Measured
    drift: 2.2e-7 J, 3.2e-6 of the largest kinetic energy (6.8e-2 J). The bound, 1e-4 of it
    (6.8e-6 J), is 1/60 of the largest elastic energy (3.9e-4 J), so elastic forces doing
    spurious work of 2 % of the elastic energy (a force that is not the exact gradient of the
    energy) would fail it. The model's own run (auto: the linearly implicit step, which damps
    the modes it does not resolve) may only lose energy, and less than 2e-3 of it (measured
    3.8e-4; tests/runtime/test_implicit_step.py shows the loss falling with tol)."""
    explicit = compile_m2(tmp_path / "c", 2, target="c").run(
        t_end=ENERGY_SPAN, dt_out=DT_OUT, stepping="explicit")
    assert explicit.energy_names == ("kinetic", "gravity", "elastic.link1", "elastic.link2")
    assert explicit.dissipator_names == ()
    total = explicit.total_energy()
    kinetic = explicit.energy[:, 0]
    assert kinetic.max() > 1e-2  # the pendulum really swings
    assert np.max(np.abs(total - total[0])) < 1e-4 * kinetic.max()
    s = explicit.stats
    assert s.max_v_pos < 1e-9 and s.max_v_vel < 1e-12
    # the iteration (6) has no trouble: the predictor is within tolerance, one update for the
    # velocity and acceleration passes
    assert s.position.mean < 0.1 and s.velocity.max <= 2 and s.acceleration.max <= 2
    own = m2_runs[2]
    assert own.stats.implicit_from < 1e-3
    total = own.total_energy()
    assert np.max(total - total[0]) <= 1e-9 * kinetic.max()
    assert np.max(total[0] - total) < 2e-3 * kinetic.max()


def test_chord2_follows_the_rigid_double_pendulum(m2_runs, tmp_path):
    """With EI = 1000 N m^2 the links hardly bend (tip2 ~ 1e-4 m), so link 2's chord follows
    the rigid two-bar pendulum: measured 7.2e-5 rad apart over 0.5 s, while chord2 itself
    moves by 0.13 rad (and tip2 reaches 3.1e-4 m)."""
    rigid = rigid_pendulum(tmp_path).run()
    flexible = m2_runs[2]
    assert np.allclose(rigid.times, flexible.times)
    chord2 = flexible.output("chord2")
    assert np.ptp(chord2) > 0.1
    assert np.max(np.abs(chord2 - rigid.output("chord2"))) < 2e-4
    assert 5e-5 < np.max(np.abs(flexible.output("tip2"))) < 1e-3


def test_the_seeds_five_seconds_with_the_c_target(m2_runs, tmp_path):
    """The seed's full 0..5 s (its Figures 4 and 5) at the model's settings, with the C target
    (about 1 s: the linearly implicit step from the first milliseconds; the explicit step
    takes 7 s). Measured: energy lost 6.5e-5 J = 7.1e-4 of the largest kinetic energy (9.2e-2
    J) to the damping of the modes the step does not resolve, never gained; chord2 within
    6.2e-4 rad of the rigid pendulum, tip2 up to 3.1e-4 m. The first 0.5 s agree with the NumPy
    run's to 1.4e-9 (10 tol bounds it): the two targets' functions differ in round-off, so
    the step sequences part after a while and the runs then agree to the tolerance. Against
    the explicit step (bench/bench_beams.py): chord2 within 1e-5 rad, tip2 within 7e-5 m."""
    result = compile_m2(tmp_path / "c", 2, target="c").run()
    assert result.times[-1] == 5.0
    total, kinetic = result.total_energy(), result.energy[:, 0]
    assert np.max(total - total[0]) <= 1e-9 * kinetic.max()
    assert np.max(total[0] - total) < 2e-3 * kinetic.max()
    chord2, tip2 = result.output("chord2"), result.output("tip2")
    rigid = rigid_pendulum(tmp_path).run(t_end=5.0, dt_out=result.dt_out)
    assert np.max(np.abs(chord2 - rigid.output("chord2"))) < 2e-3
    assert np.max(np.abs(chord2)) < PHI2 + 1e-5  # it cannot swing higher than released
    assert 1e-4 < np.max(np.abs(tip2)) < 1e-3
    numpy_run = m2_runs[2]
    common = np.searchsorted(numpy_run.times, result.times[result.times <= ENERGY_SPAN])
    for name in ("chord2", "tip2"):
        early = result.output(name)[result.times <= ENERGY_SPAN]
        assert np.max(np.abs(early - numpy_run.output(name)[common])) < 10 * result.tol


def test_outputs_converge_as_the_links_are_refined(m2_runs):
    """chord2 and tip2 for 2, 4, 8 elements per link over SHORT_SPAN: the largest difference
    between successive meshes shrinks (measured: chord2 8.9e-6 then 3.9e-6 rad, tip2 9.0e-5
    then 3.0e-5 m). Longer spans and 16 elements: bench/bench_beams.py."""
    on_grid = {n: r.times <= SHORT_SPAN + 1e-12 for n, r in m2_runs.items()}
    assert np.allclose(m2_runs[2].times[on_grid[2]], m2_runs[8].times)
    for name in ("chord2", "tip2"):
        values = {n: r.output(name)[on_grid[n]] for n, r in m2_runs.items()}
        coarse = np.max(np.abs(values[4] - values[2]))
        fine = np.max(np.abs(values[8] - values[4]))
        assert fine < 0.7 * coarse, (name, coarse, fine)


# -- the command line ------------------------------------------------------------------------

def test_compile_with_elements_writes_the_refined_model(cli, tmp_path, monkeypatch):
    monkeypatch.setenv("DEPSIM_CACHE", str(tmp_path / "cache"))
    done = cli("compile", MODEL, "-o", tmp_path / "out", "--elements", "link1=3")
    assert done.returncode == 0, done.stderr
    module = load_generated(tmp_path / "out" / "two_link_flex.py")
    assert module.NQ == 4 * (3 + 1) + 4 * (2 + 1)  # link1 refined, link2 as written
    assert "link1.n3.dy" in module.COORDINATES and "link2.n3.x" not in module.COORDINATES


def test_run_with_elements_uses_them_and_plots(cli, tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("DEPSIM_CACHE", str(cache))
    done = cli("run", MODEL, "--elements", "link1=1,link2=3", "--t-end", "0.002",
               "--dt-out", "0.001", "-o", tmp_path / "out.csv", "--plot", tmp_path / "out.png")
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    (generated,) = cache.glob("models/*/two_link_flex.py")
    module = load_generated(generated)
    assert module.NQ == 4 * (1 + 1) + 4 * (3 + 1)
    lines = (tmp_path / "out.csv").read_text().splitlines()
    assert lines[0] == "t,chord2,tip2" and len(lines) == 1 + 3
    assert (tmp_path / "out.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("command", ["compile", "run"])
@pytest.mark.parametrize("elements, message", [
    ("link3=2", "unknown beam 'link3' (beams in this model: link1, link2)"),
    ("link1=0", "beam 'link1' must be a whole number from 1 to 100 (ASCII digits), got '0'"),
    ("link1=-2", "must be a whole number from 1 to 100"),
    ("link1=two", "must be a whole number from 1 to 100"),
    ("link1=\u0663", "(ASCII digits), got '\u0663'"),  # an Arabic-Indic 3
    ("link1=99999999999999999999", "must be a whole number from 1 to 100"),
    ("link1", "'link1' is not BEAM=N (e.g. link1=8)"),
])
def test_bad_element_counts_are_usage_errors(cli, tmp_path, monkeypatch, command, elements,
                                             message):
    monkeypatch.setenv("DEPSIM_CACHE", str(tmp_path / "cache"))
    extra = ["-o", tmp_path / "out"] if command == "compile" else ["--t-end", "0.001"]
    done = cli(command, MODEL, "--elements", elements, *extra)
    assert done.returncode == 2
    assert message in done.stderr
    assert "Traceback" not in done.stderr and done.stdout == ""
    assert not (tmp_path / "out").exists() and not (tmp_path / "cache").exists()
