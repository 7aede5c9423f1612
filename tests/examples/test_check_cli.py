"""`depsim check` end to end: exit codes, stdout/stderr split, no tracebacks."""

import pytest

from e2e import EXAMPLES


@pytest.mark.parametrize("example", sorted(p.name for p in EXAMPLES.glob("*.dep")))
def test_every_example_checks_clean(cli, example):
    done = cli("check", EXAMPLES / example)
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""
    # the mobility line: a planar model's degrees of freedom, a spatial one's Grubler count
    assert any(line in done.stdout for line in ("degrees of freedom", "Grubler count",
                                                "beams ("))


def test_bad_model_reports_every_error_with_position_and_exit_1(cli, tmp_path):
    bad = tmp_path / "bad.dep"
    bad.write_text("model m\nbar b {\n  length = 1 m\n  mass = 2 N\n  inertia = 1 kg*m^2\n}\n"
                   "hinge h joins ground.origin to bb.a\n")
    done = cli("check", bad)
    assert done.returncode == 1
    assert done.stdout == ""
    assert f"{bad}:4:10: error[E030]" in done.stderr
    assert "expected mass (kg), got force (N)" in done.stderr
    assert f"{bad}:7:32: error[E012]" in done.stderr and "did you mean 'b'?" in done.stderr
    assert "Traceback" not in done.stderr


def test_missing_and_binary_files_are_model_errors(cli, tmp_path):
    done = cli("check", tmp_path / "nowhere.dep")
    assert done.returncode == 1 and "error[E002]" in done.stderr
    binary = tmp_path / "blob.dep"
    binary.write_bytes(bytes(range(256)))
    done = cli("check", binary)
    assert done.returncode == 1 and "error[E003]" in done.stderr
    assert "Traceback" not in done.stderr


def test_usage_errors_exit_2(cli):
    done = cli("check")
    assert done.returncode == 2
    done = cli("frobnicate", EXAMPLES / "pendulum.dep")
    assert done.returncode == 2
