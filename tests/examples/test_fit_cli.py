"""`depsim fit` (docs/calibration.md) end to end on INTELSAT V: a fit with its JSON and
figure, a pair the data cannot separate, and every kind of bad input: data errors as
`FILE:LINE: error: ...` with exit code 1, option errors with exit code 2, never a traceback
and never an output file. The error cases call the CLI's `main` in this process (each would
otherwise pay a Python start); one fit runs the real command."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

import depsim
from depsim.cli import main
from e2e import EXAMPLES

MODEL = EXAMPLES / "intelsat5.dep"
TRUTH = {"h1.friction": 0.62}
T_END = 72.0


@pytest.fixture(scope="module")
def ground_test(tmp_path_factory):
    """Files of a synthetic test: theta1..4 at 10 Hz in degrees, noise 1e-3 rad (seed 2), and
    the latch times with a sigma column in ms."""
    folder = tmp_path_factory.mktemp("ground")
    sim = depsim.load(MODEL).compile("c")
    run = sim.run(set=TRUTH, tol=1e-10, t_end=T_END, dt_out=0.1)
    noisy = run.outputs + np.random.default_rng(2).normal(0, 1e-3, run.outputs.shape)
    data = folder / "test.csv"
    header = "t [s], " + ", ".join(f"{name} [deg]" for name in run.output_names)
    data.write_text("# INTELSAT V, synthetic\n" + header + "\n" + "".join(
        f"{t:.1f}," + ",".join(f"{v:.6f}" for v in row) + "\n"
        for t, row in zip(run.times, np.degrees(noisy))))
    latches = folder / "latches.csv"
    latches.write_text("event, t [s], sigma [ms]\n" + "".join(
        f"{e.name},{e.t:.4f},10\n" for e in run.events if e.kind == "latch"))
    return data, latches


def fit_cli(capsys, *args):
    code = main(["fit", str(MODEL), *map(str, args)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_fit_writes_its_json_and_figure(cli, ground_test, tmp_path: Path):
    data, latches = ground_test
    out, figure = tmp_path / "fit.json", tmp_path / "fit.png"
    done = cli("fit", MODEL, "--data", data, "--latch-times", latches,
               "--free", "h1.friction=0.3:1.2 N*m", "--set", "h1.friction=0.5",
               "--sigma", "theta1=0.0573deg", "--t-end", T_END, "-o", out, "--plot", figure)
    assert done.returncode == 0, done.stderr
    assert "h1.friction" in done.stdout and "std error" in done.stdout
    found = json.loads(out.read_text())
    assert set(found) >= {"model", "data", "parameters", "correlation", "residuals", "events",
                          "events_rms", "cost", "iterations", "evaluations", "runs",
                          "wall_time", "converged", "status", "settings", "rejected"}
    entry = found["parameters"]["h1.friction"]
    assert set(entry) == {"unit", "start", "bounds", "estimate", "standard_error",
                          "interval_2sigma", "identifiable", "note"}
    assert entry["start"] == 0.5 and entry["bounds"] == [0.3, 1.2] and entry["unit"] == "N*m"
    low, high = entry["interval_2sigma"]
    assert low <= TRUTH["h1.friction"] <= high
    assert found["residuals"]["theta1"]["sigma"] == pytest.approx(1e-3, rel=1e-3)
    assert not found["residuals"]["theta1"]["sigma_estimated"]
    assert found["residuals"]["theta2"]["sigma_estimated"]
    assert [e["sigma"] for e in found["events"]] == [0.01] * 4
    picture = figure.read_bytes()
    assert picture[:8] == b"\x89PNG\r\n\x1a\n" and len(picture) > 20_000


def test_an_unidentifiable_pair_is_flagged(capsys, ground_test):
    data, _ = ground_test
    code, out, err = fit_cli(capsys, "--data", data, "--free", "cable_k=3000:6000",
                             "--free", "pulley_r=15:22 mm", "--free", "h1.friction",
                             "--t-end", T_END)
    assert code == 0, err
    assert out.count("not identifiable from these data") == 2
    assert "correlation -1.0000 with pulley_r" in out


def test_points_the_model_refuses_are_rejected(capsys, ground_test):
    """Without bounds, cable_k and pulley_r alone cannot explain the data and the search
    tries a negative cable stiffness: those trial points are rejected (the search steps
    shorter) and the report says so; the pair stays unidentifiable."""
    data, _ = ground_test
    code, out, err = fit_cli(capsys, "--data", data, "--free", "cable_k", "--free",
                             "pulley_r", "--t-end", T_END)
    assert code == 0, err
    assert "trial point(s) rejected" in out and "which the model refuses" in out
    assert out.count("not identifiable from these data") == 2


def test_a_start_the_model_refuses_is_a_usage_error(capsys, ground_test):
    """A start value the model refuses is refused before any run, naming it."""
    data, _ = ground_test
    code, _, err = fit_cli(capsys, "--data", data, "--free", "cable_k", "--set",
                           "cable_k=-5", "--t-end", T_END)
    assert code == 2, err
    assert "from cable_k=-5" in err


def bad(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


DATA_ERRORS = [
    ("empty.csv", "", 1, "the file is empty"),
    ("no_time.csv", "theta1 [deg]\n0, 1\n", 1, "the first column is the time 't'"),
    ("missing.csv", "t, theta1, theta2\n0, 0, 0\n0.1, 0\n", 3,
     "2 values, the header names 3 columns"),
    ("unknown.csv", "t, theta1, phi\n0, 0, 0\n", 1, "'phi' is not an output of the model"),
    ("unit.csv", "t, theta1 [mm]\n0, 0\n", 1, "column 'theta1': 'mm' is not a unit of"),
    ("time_unit.csv", "t [deg], theta1\n0, 0\n", 1, "column 't'"),
    ("nan.csv", "t, theta1\n0, 0\n0.1, nan\n", 3, "every value must be a finite number"),
    ("word.csv", "t, theta1\n0, 0\n0.1, x\n", 3, "'x' in column 'theta1' is not a number"),
    ("outside.csv", "t, theta1\n0, 0\n\n# late\n90, 0\n", 5, "outside the run, 0 to 80 s"),
    ("back.csv", "t, theta1\n0, 0\n2, 0\n1, 0\n", 4, "before the line above"),
    ("header_only.csv", "t, theta1\n", 1, "no rows of numbers"),
]


@pytest.mark.parametrize("name, text, line, message", DATA_ERRORS,
                         ids=[case[0] for case in DATA_ERRORS])
def test_bad_data_names_its_line(capsys, tmp_path, name, text, line, message):
    path = bad(tmp_path, name, text)
    out = tmp_path / "fit.json"
    code, _, err = fit_cli(capsys, "--data", path, "--free", "h1.friction", "-o", out)
    assert code == 1, err
    assert err.startswith(f"{path}:{line}: error: ") and message in err, err
    assert not out.exists()


LATCH_ERRORS = [
    ("h9.latch,50\n", 1, "'h9.latch' is not an event of this model"),
    ("h1.latch,50\nh3.latch,58\n", 2, "event h3.latch does not happen in the run at "
                                       "h1.friction = 0.68 N*m"),
    ("event,t,sigma\nh1.latch,50,-1\n", 2, "sigma -1 must be positive"),
]


@pytest.mark.parametrize("text, line, message", LATCH_ERRORS)
def test_bad_latch_times_name_their_line(capsys, tmp_path, text, line, message):
    path = bad(tmp_path, "latches.csv", text)
    out = tmp_path / "fit.json"
    code, _, err = fit_cli(capsys, "--latch-times", path, "--free", "h1.friction",
                           "--t-end", 60, "-o", out, "--plot", tmp_path / "fit.png")
    assert code == 1, err
    assert err.startswith(f"{path}:{line}: error: ") and message in err, err
    assert not out.exists() and not (tmp_path / "fit.png").exists()


OPTION_ERRORS = [
    (["--free", "h1.friction="], "expected NAME or NAME=LOW:HIGH"),
    (["--free", "h1.friction=0.3"], "expected LOW:HIGH"),
    (["--free", "h1.friktion"], "did you mean 'h1.friction'?"),
    (["--free", "h1.friction=1:0.5"], "lower bound 1 is not below the upper bound 0.5"),
    (["--free", "h1.friction=0.1:0.5 N*m"], "start value 0.68 N*m lies outside its bounds"),
    (["--free", "h1.friction=0.1:1 m"], "has another dimension"),
    (["--free", "h1.friction", "--free", "h1.friction"], "given twice"),
    (["--free", "h1.friction", "--sigma", "theta1=2 s"], "is not a unit of"),
    (["--free", "h1.friction", "--sigma", "theta9=1"], "not a measured column"),
    (["--free", "h1.friction", "--sigma", "theta1=-1"], "must be a positive number"),
    ([], "free at least one parameter"),
]


@pytest.mark.parametrize("options, message", OPTION_ERRORS)
def test_bad_options_are_usage_errors(capsys, ground_test, tmp_path, options, message):
    data, _ = ground_test
    out = tmp_path / "fit.json"
    code, _, err = fit_cli(capsys, "--data", data, *options, "-o", out)
    assert code == 2, err
    assert err.startswith("depsim: error: ") and message in err, err
    assert not out.exists()


def test_no_data_is_a_usage_error(capsys):
    code, _, err = fit_cli(capsys, "--free", "h1.friction")
    assert code == 2 and "give the measured data" in err


def test_the_calibration_figure_is_there():
    text = (EXAMPLES.parent / "docs" / "calibration.md").read_text()
    (figure,) = re.findall(r"!\[[^]]*\]\(([^)]*intelsat5-fit.png)\)", text)
    assert (EXAMPLES.parent / "docs" / figure).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
