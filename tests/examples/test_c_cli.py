"""The C target from the command line: compile a folder, build it with make, and check that
the standalone program reproduces `depsim run --target c` byte for byte."""

import os
import subprocess

from e2e import EXAMPLES


def test_standalone_program_reproduces_depsim_run(cli, tmp_path):
    folder = tmp_path / "slider"
    done = cli("compile", EXAMPLES / "slider_crank.dep", "--target", "c", "-o", folder)
    assert done.returncode == 0, done.stderr
    subprocess.run(["make", "-s", "-C", str(folder)], check=True, capture_output=True)
    program_csv, library_csv = tmp_path / "program.csv", tmp_path / "library.csv"
    # the program needs neither Python nor a PATH
    ran = subprocess.run([str(folder / "slider_crank"), "--t-end", "0.3", "--set", "r=0.12",
                          "-o", str(program_csv)], env={}, capture_output=True, text=True)
    assert ran.returncode == 0, ran.stderr
    done = cli("run", EXAMPLES / "slider_crank.dep", "--target", "c", "--t-end", "0.3",
               "--set", "r=0.12", "-o", library_csv)
    assert done.returncode == 0, done.stderr
    assert program_csv.read_bytes() == library_csv.read_bytes()


def test_program_usage_errors_exit_2(tmp_path, cli):
    folder = tmp_path / "pendulum"
    assert cli("compile", EXAMPLES / "pendulum.dep", "--target", "c", "-o", folder).returncode == 0
    subprocess.run(["make", "-s", "-C", str(folder)], check=True, capture_output=True)
    ran = subprocess.run([str(folder / "pendulum"), "--set", "nosuch=1"], capture_output=True,
                         text=True, env=dict(os.environ))
    assert ran.returncode == 2 and "nosuch" in ran.stderr
