"""A plain (non-editable) install works from any folder: the wheel built from this checkout,
installed into a fresh virtual environment, runs `depsim check`, `run` on both targets and a
small `sweep` in a folder outside the checkout.

The fresh environment gets depsim from the wheel only; its dependencies come from the test
environment's site-packages through a .pth file (no download), and `pip check` confirms the
wheel's declared requirements are all met there."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


def run(*arguments, cwd=None, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([str(a) for a in arguments], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=600)


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(the fresh environment's depsim command, its environment variables, a work folder)."""
    root = tmp_path_factory.mktemp("install")
    build = root / "build"
    shutil.copytree(ROOT, build, ignore=shutil.ignore_patterns(
        ".venv", ".git", "results", "build", "*.egg-info", "__pycache__", ".pytest_cache",
        ".hypothesis"))
    built = run(sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                "-w", root / "dist", build)
    assert built.returncode == 0, built.stdout + built.stderr
    (wheel,) = (root / "dist").glob("depsim-*.whl")
    venv = root / "venv"
    made = run(sys.executable, "-m", "venv", venv)
    assert made.returncode == 0, made.stderr
    python = venv / "bin" / "python"
    site = run(python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])")
    Path(site.stdout.strip(), "test-environment.pth").write_text(
        sysconfig.get_paths()["purelib"] + "\n")
    done = run(python, "-m", "pip", "install", "--no-deps", "--no-index", wheel)
    assert done.returncode == 0, done.stdout + done.stderr
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH",)}
    env["DEPSIM_CACHE"] = str(root / "cache")
    work = root / "work"
    work.mkdir()
    return venv / "bin" / "depsim", env, work, wheel, python


def test_the_wheel_holds_every_package_and_the_core_sources(installed):
    *_, wheel, _ = installed
    names = zipfile.ZipFile(wheel).namelist()
    for package in ("depsim", "depsim/dsl", "depsim/codegen", "depsim/runtime",
                    "depsim/runtime/sweep"):
        assert f"{package}/__init__.py" in names, package
    for data in ("depsim/dsl/grammar.lark", "depsim/runtime/c/include/depsim.h",
                 "depsim/runtime/c/include/depsim_model.h", "depsim/runtime/c/run/run.c",
                 "depsim/runtime/c/base/decimal_powers.inc",
                 "depsim/runtime/c/targets/program/main.c",
                 "depsim/codegen/templates/numpy_module.py.j2"):
        assert data in names, data
    assert not any(name.startswith(("tests/", "examples/")) for name in names)


def test_requirements_are_declared(installed):
    *_, python = installed
    done = run(python, "-m", "pip", "check")
    assert done.returncode == 0, done.stdout + done.stderr


def test_installed_depsim_imports_from_the_wheel_not_the_checkout(installed):
    depsim, env, work, _, python = installed
    done = run(python, "-c", "import depsim.runtime, depsim.dsl; print(depsim.runtime.__file__,"
               " depsim.dsl.__file__)", cwd=work, env=env)
    assert done.returncode == 0, done.stderr
    assert str(ROOT) not in done.stdout and "site-packages" in done.stdout


def test_check_run_and_sweep_from_another_folder(installed):
    depsim, env, work, *_ = installed
    model = work / "pendulum.dep"
    shutil.copy(EXAMPLES / "pendulum.dep", model)
    done = run(depsim, "check", model.name, cwd=work, env=env)
    assert done.returncode == 0, done.stderr
    for target in ("numpy", "c"):
        out = work / f"{target}.csv"
        done = run(depsim, "run", model.name, "--target", target, "--t-end", "1", "-o", out,
                   cwd=work, env=env)
        assert done.returncode == 0, done.stderr
        assert out.read_text().startswith("t,theta,omega,tip_x,tip_y\n")
    assert (work / "numpy.csv").read_text().count("\n") == (work / "c.csv").read_text().count(
        "\n")
    done = run(depsim, "sweep", model.name, "--grid", "L=0.9:1.1:3", "--t-end", "0.5",
               "--workers", "2", "-o", "study.nc", cwd=work, env=env)
    assert done.returncode == 0, done.stderr
    assert (work / "study.nc").read_bytes()[:8] == b"\x89HDF\r\n\x1a\n"
    assert "Traceback" not in done.stderr
