"""`depsim run` end to end: files written, parameter overrides, usage and solver failures."""

import csv
import json

from e2e import EXAMPLES


def test_run_writes_csv_summary_and_png(cli, tmp_path):
    out, summary, plot = tmp_path / "p.csv", tmp_path / "p.json", tmp_path / "p.png"
    done = cli("run", EXAMPLES / "pendulum.dep", "--t-end", "1", "--dt-out", "0.1",
               "-o", out, "--summary", summary, "--plot", plot)
    assert done.returncode == 0, done.stderr
    rows = list(csv.reader(out.open()))
    assert rows[0] == ["t", "theta", "omega", "tip_x", "tip_y"]
    assert len(rows) == 12 and float(rows[-1][0]) == 1.0
    assert abs(float(rows[1][1]) - 1.0471975511965976) < 0.01   # starts at 60 deg
    info = json.loads(summary.read_text())
    assert info["model"] == "pendulum" and "events" in info and "statistics" in info
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_set_with_units_changes_the_run(cli, tmp_path):
    short, long_ = tmp_path / "a.csv", tmp_path / "b.csv"
    assert cli("run", EXAMPLES / "pendulum.dep", "--t-end", "0.5", "-o", short).returncode == 0
    done = cli("run", EXAMPLES / "pendulum.dep", "--t-end", "0.5", "--set", "L=400cm",
               "-o", long_)
    assert done.returncode == 0, done.stderr
    # a longer pendulum falls more slowly: smaller angle change after 0.5 s
    a = list(csv.reader(short.open()))[-1]
    b = list(csv.reader(long_.open()))[-1]
    assert abs(1.0471975511965976 - float(b[1])) < abs(1.0471975511965976 - float(a[1]))


def test_unknown_parameter_and_bad_value_are_usage_errors(cli, tmp_path):
    done = cli("run", EXAMPLES / "intelsat5.dep", "--set", "h2.fricton=0.7")
    assert done.returncode == 2 and "did you mean 'h2.friction'" in done.stderr
    done = cli("run", EXAMPLES / "intelsat5.dep", "--set", "h1.preload=1.5kg")
    assert done.returncode == 2 and "h1.preload" in done.stderr
    done = cli("run", EXAMPLES / "intelsat5.dep", "--set", "loop1.stiffness=2")
    assert done.returncode == 2 and "cable_k" in done.stderr
    done = cli("run", EXAMPLES / "intelsat5.dep", "--t-end", "-1")
    assert done.returncode == 2
    assert "Traceback" not in done.stderr


def test_stepping_is_checked_before_anything_is_written(cli, tmp_path):
    """--stepping implicit needs stiff forces (a model with beams); a name that is not one
    of the three is argparse's usage error."""
    out = tmp_path / "p.csv"
    done = cli("run", EXAMPLES / "pendulum.dep", "--stepping", "implicit", "-o", out)
    assert done.returncode == 2 and "stepping implicit needs stiff forces" in done.stderr
    done = cli("run", EXAMPLES / "pendulum.dep", "--stepping", "euler", "-o", out)
    assert done.returncode == 2 and "invalid choice: 'euler'" in done.stderr
    assert "Traceback" not in done.stderr
    assert list(tmp_path.iterdir()) == []


def test_solver_failure_exits_3_names_the_joint_and_writes_nothing(cli, tmp_path):
    # rod as long as the crank: the slider-crank starts at its dead point
    out = tmp_path / "sc.csv"
    done = cli("run", EXAMPLES / "slider_crank.dep", "--set", "l=0.1m", "-o", out,
               "--summary", tmp_path / "sc.json")
    assert done.returncode == 3
    # which row of the singular loop is named first is round-off; that it is one is not
    assert any(f"hinge {joint}" in done.stderr for joint in ("crank_pin", "wrist", "gudgeon"))
    assert "dead point" in done.stderr and "hint:" in done.stderr
    assert "Traceback" not in done.stderr
    assert list(tmp_path.iterdir()) == []


def test_animate_writes_a_gif(cli, tmp_path):
    gif = tmp_path / "slider.gif"
    done = cli("run", EXAMPLES / "slider_crank.dep", "--t-end", "0.2", "--dt-out", "0.02",
               "--animate", gif)
    assert done.returncode == 0, done.stderr
    assert gif.read_bytes()[:6] in (b"GIF89a", b"GIF87a")


def test_without_a_c_compiler_the_error_says_what_to_install(tmp_path):
    """The integrator core is built with the machine's C compiler on first use: without one,
    `depsim run` (either target) stops with exit 2 and names what to install."""
    import os
    import subprocess
    import sys

    bare = tmp_path / "bin"
    bare.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "CC"}
    env.update(PATH=str(bare), DEPSIM_CACHE=str(tmp_path / "cache"))
    for target in ("numpy", "c"):
        done = subprocess.run([sys.executable, "-m", "depsim", "run", EXAMPLES / "pendulum.dep",
                               "--target", target, "-o", tmp_path / "out.csv"], env=env,
                              capture_output=True, text=True)
        assert done.returncode == 2, done.stderr
        assert "no C compiler found" in done.stderr and "apt install gcc" in done.stderr
        assert "Traceback" not in done.stderr
    env["CC"] = "/no/such/cc"
    done = subprocess.run([sys.executable, "-m", "depsim", "run", EXAMPLES / "pendulum.dep"],
                          env=env, capture_output=True, text=True)
    assert done.returncode == 2 and "CC is set to '/no/such/cc'" in done.stderr
    assert not (tmp_path / "out.csv").exists()


def test_run_with_sensitivities_writes_their_columns_and_event_times(cli, tmp_path):
    """--sensitivity: the outputs' derivatives as CSV columns and each event time's in the
    summary and the report (the values: tests/runtime/test_sensitivities.py)."""
    import json

    csv, summary = tmp_path / "out.csv", tmp_path / "summary.json"
    done = cli("run", EXAMPLES / "intelsat5.dep", "--target", "c", "--sensitivity",
               "h1.friction", "--sensitivity", "cable_k", "--dt-out", "1", "-o", csv,
               "--summary", summary)
    assert done.returncode == 0, done.stderr
    header = csv.read_text().splitlines()[0].split(",")
    assert header[5:7] == ["d(theta1)/d(h1.friction)", "d(theta2)/d(h1.friction)"]
    assert header[-1] == "d(theta4)/d(cable_k)"
    first = json.loads(summary.read_text())["events"][0]
    assert first["name"] == "h1.latch" and set(first["dt_dp"]) == {"h1.friction", "cable_k"}
    assert "event time sensitivities" in done.stdout
    done = cli("run", EXAMPLES / "pendulum.dep", "--sensitivity", "nope", "--t-end", "0.1")
    assert done.returncode == 2 and "not a parameter" in done.stderr
    assert "Traceback" not in done.stderr
