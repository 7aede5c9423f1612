"""`depsim run --input NAME=FILE`: an input driven by a CSV time table (docs/language.md,
Inputs); bad tables are usage errors (exit 2) naming the file and line, nothing written."""

from pathlib import Path

import numpy as np
import pytest

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


def test_a_byte_order_mark_keeps_the_first_row_and_a_typo_is_no_header(cli, tmp_path: Path):
    """Excel writes a byte-order mark: the first row of a headerless table stays a row (it
    was taken for a header and dropped); a mistyped first row is an error, not a header."""
    marked = tmp_path / "marked.csv"
    marked.write_bytes(b"\xef\xbb\xbf0,1\n2,1\n")
    out = tmp_path / "o.csv"
    done = cli("run", MODEL, "--input", f"T={marked}", "-o", out, "--t-end", "1")
    assert done.returncode == 0, done.stderr
    t, theta = np.loadtxt(out, delimiter=",", skiprows=1)[:, :2].T
    assert np.abs(theta - t ** 2 / 2 / I_PIVOT).max() < 1e-8  # torque 1 from t = 0
    typo = tmp_path / "typo.csv"
    typo.write_text("0,1O\n2,1\n")
    done = cli("run", MODEL, "--input", f"T={typo}", "-o", tmp_path / "p.csv")
    assert done.returncode == 2 and f"{typo}:1: expected two numbers 't,u', got '0,1O'" in \
        done.stderr
    assert not (tmp_path / "p.csv").exists()


def test_an_input_or_parameter_given_twice_is_refused(cli, tmp_path: Path):
    table = tmp_path / "t.csv"
    table.write_text("0,1\n")
    out = tmp_path / "o.csv"
    for arguments, message in [
        (["--input", f"T={table}", "--input", f"T={table}"], "--input T is given twice"),
        (["--input", f"T={table}", "--set", "T=2"],
         "input T is given both a table (--input T=...) and a value (--set T=...)"),
        (["--set", "T.rate=2", "--input", f"T={table}"], "(--set T.rate=...)"),
        (["--set", "T=1", "--set", "T=2"], "--set T is given twice (1 and 2)"),
    ]:
        done = cli("run", MODEL, *arguments, "-o", out, "--t-end", "0.1")
        assert done.returncode == 2 and message in done.stderr, (arguments, done.stderr)
        assert "Traceback" not in done.stderr and not out.exists()


def test_the_api_refuses_a_table_and_a_value_for_one_input():
    import depsim
    from depsim.errors import UsageError

    sim = depsim.load(MODEL).compile("c")
    with pytest.raises(UsageError, match=r"input 'F.x' is given both a time table .* "
                                         r"\(set\['F.x.rate'\]\)"):
        sim.run(set={"F.x.rate": 1.0}, inputs={"F.x": [[0.0, 1.0]]}, t_end=0.1)
