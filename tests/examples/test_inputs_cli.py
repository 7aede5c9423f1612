"""`depsim run --input NAME=FILE`: an input driven by a CSV time table (docs/language.md,
Inputs); bad tables are usage errors (exit 2) naming the file and line, nothing written."""

from pathlib import Path

import numpy as np

from e2e import ROOT

MODEL = ROOT / "tests" / "runtime" / "models" / "driven.dep"
I_PIVOT = 1.25


def test_a_csv_table_drives_the_run(cli, tmp_path: Path):
    table = tmp_path / "torque.csv"
    table.write_text("t,T  # N*m\n0,0\n0.5,0\n0.5,1\n# a comment\n\n2,1\n")
    out = tmp_path / "o.csv"
    done = cli("run", MODEL, "--input", f"T={table}", "-o", out)
    assert done.returncode == 0, done.stderr
    rows = np.loadtxt(out, delimiter=",", skiprows=1)
    t, theta = rows[:, 0], rows[:, 1]
    exact = np.clip(t - 0.5, 0, None) ** 2 / 2 / I_PIVOT
    assert np.abs(theta - exact).max() < 1e-8  # 100 tol (the model's tol is 1e-10)


def test_bad_tables_are_usage_errors(cli, tmp_path: Path):
    bad = tmp_path / "bad.csv"
    bad.write_text("0,1\n0.5,x\n")
    backwards = tmp_path / "backwards.csv"
    backwards.write_text("t,u\n1,0\n0.5,1\n")
    out = tmp_path / "o.csv"
    cases = [
        (f"T={bad}", f"--input T: {bad}:2: expected two numbers 't,u', got '0.5,x'"),
        (f"T={backwards}", f"{backwards}:3: time 0.5 s is before the line above (1 s)"),
        (f"T={tmp_path / 'none.csv'}", "none.csv: no such file"),
        (f"T={tmp_path}", "not a regular file"),
        (f"Q={bad.with_name('ok.csv')}", None),
        ("T", "expected NAME=FILE"),
    ]
    bad.with_name("ok.csv").write_text("0,1\n")
    for argument, message in cases:
        done = cli("run", MODEL, "--input", argument, "-o", out, "--t-end", "0.1")
        assert done.returncode == 2, (argument, done.stderr)
        assert "Traceback" not in done.stderr
        assert (message or "unknown input 'Q'; the model's inputs: T, F.x, F.y") in done.stderr
        assert not out.exists()
