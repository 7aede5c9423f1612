"""`depsim modes` end to end: the table, the JSON, the figure, the animation; bad requests
(exit 2, one line) and a model that does not deploy."""

import json

import pytest

from e2e import run_cli

PENDULUM = """model hang "a bar hanging at rest"
gravity = (0, -9.81) m/s^2
bar rod { length = 1 m; mass = 1 kg; inertia = 0.0833 kg*m^2 }
hinge pivot joins ground.origin to rod.a { angle = rod - ground + 90 deg; latch = 30 deg }
simulate { t_end = 1 s }
"""


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    path = tmp_path_factory.mktemp("modes") / "hang.dep"
    path.write_text(PENDULUM)
    return path


def test_modes_prints_the_table_and_writes_json_figure_and_animation(model, tmp_path):
    done = run_cli("modes", model, "--json", tmp_path / "m.json", "--plot", tmp_path / "m.png",
                   "--animate", tmp_path / "m.gif")
    assert done.returncode == 0, done.stderr
    assert "hang: natural frequencies at t = 0 s" in done.stdout
    assert "1 degrees of freedom; locked: none" in done.stdout
    found = json.loads((tmp_path / "m.json").read_text())
    assert found["degrees_of_freedom"] == 1 and len(found["frequencies_hz"]) == 1
    assert found["modes"][0]["hinges_rad"]["pivot"] > 0
    assert (tmp_path / "m.png").stat().st_size > 1000
    assert (tmp_path / "m.gif").stat().st_size > 1000


@pytest.mark.parametrize("at, message", [
    ("t=-1", "must be zero or positive"), ("t=2 m", "a time is in s"),
    ("later", "expected t=TIME (s) or deployed")])
def test_a_bad_at_is_a_usage_error(model, at, message):
    done = run_cli("modes", model, "--at", at)
    assert done.returncode == 2
    assert message in done.stderr and "Traceback" not in done.stderr


def test_deployed_needs_every_latch_latched(model):
    done = run_cli("modes", model, "--at", "deployed")
    assert done.returncode == 2
    assert "the run does not deploy (pivot still open at t = 1 s)" in done.stderr


def test_an_output_path_is_checked_before_anything_runs(model, tmp_path):
    done = run_cli("modes", model, "--plot", tmp_path / "m.xyz")
    assert done.returncode == 2 and "unknown format '.xyz'" in done.stderr
