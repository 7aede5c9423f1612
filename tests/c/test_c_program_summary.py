"""The standalone program's --summary FILE.json: the JSON summary `depsim run --summary`
writes (Result.summary() through json.dumps), written by the program without Python. Compared
key by key with the binding's Result of the same run, and byte for byte (the same numbers
print the same): latches, stops and stick-slip, a loop's assembly, a driven input, a stiff
beam model. The outputs are written all or none."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from depsim.codegen.c_emit import c_program_name, compile_c
from depsim.dsl import load_model
from depsim.runtime import simulate
from depsim.runtime.binding import load_folder

ROOT = Path(__file__).resolve().parents[2]
MODELS = {"intelsat5": ROOT / "examples" / "intelsat5.dep",
          "fourbar": ROOT / "examples" / "fourbar.dep",
          "two_link_flex": ROOT / "examples" / "two_link_flex.dep",
          "stops": ROOT / "tests" / "fmu" / "models" / "stops.dep",
          "motor": ROOT / "tests" / "fmu" / "models" / "motor.dep"}
# (model, the program's options, the binding's settings)
RUNS = [("intelsat5", (), {}),
        ("intelsat5", ("--set", "h2.friction=0.9", "--t-end", "30"),
         {"set": {"h2.friction": 0.9}, "t_end": 30.0}),
        ("fourbar", ("--t-end", "1"), {"t_end": 1.0}),
        ("two_link_flex", ("--t-end", "0.01"), {"t_end": 0.01}),
        ("stops", (), {}),
        ("motor", ("--input", "T_motor=TABLE", "--t-end", "2"), {"t_end": 2.0, "table": True})]
TABLE = "t,u\n0,0\n0.5,0\n0.5,4\n1.5,-2\n"


@pytest.fixture(scope="module")
def programs(tmp_path_factory):
    """name -> (program, its C module), built by make on first use."""
    made = {}

    def get(name: str):
        if name not in made:
            model = load_model(MODELS[name])
            folder = compile_c(model, tmp_path_factory.mktemp(name))
            run = subprocess.run(["make", "-j2", "-C", str(folder)], capture_output=True,
                                 text=True)
            assert run.returncode == 0, run.stdout + run.stderr
            made[name] = folder / c_program_name(model), load_folder(folder)
        return made[name]

    return get


def same(a, b, where="") -> None:
    """a and b equal key by key, in the same order (floats bit for bit; NaN as NaN)."""
    assert type(a) is type(b), (where, a, b)
    if isinstance(a, dict):
        assert list(a) == list(b), where
        for key in a:
            same(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, list):
        assert len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{where}[{k}]")
    elif isinstance(a, float) and math.isnan(a):
        assert math.isnan(b), where
    else:
        assert a == b, (where, a, b)


@pytest.mark.parametrize("name, options, settings", RUNS,
                         ids=[f"{r[0]}-{k}" for k, r in enumerate(RUNS)])
def test_the_program_writes_the_summary_of_depsim_run(programs, tmp_path, name, options,
                                                      settings):
    program, module = programs(name)
    table = tmp_path / "table.csv"
    table.write_text(TABLE)
    args = [f"T_motor={table}" if a == "T_motor=TABLE" else a for a in options]
    ran = subprocess.run([str(program), *args, "-o", tmp_path / "out.csv", "--summary",
                          tmp_path / "program.json"], capture_output=True, text=True, env={})
    assert ran.returncode == 0, ran.stderr
    p = list(module.PARAMETER_DEFAULTS)
    for key, value in settings.get("set", {}).items():
        p[module.PARAMETERS.index(key)] = value
    inputs = {"T_motor": [tuple(map(float, line.split(","))) for line in
                          TABLE.splitlines()[1:]]} if settings.get("table") else None
    result = simulate(module, p, t_end=settings.get("t_end"), inputs=inputs)
    result.to_json(tmp_path / "binding.json")
    written = json.loads((tmp_path / "program.json").read_text())
    same(written, json.loads((tmp_path / "binding.json").read_text()))
    assert (tmp_path / "program.json").read_bytes() == (tmp_path / "binding.json").read_bytes()
    assert ran.stdout == result.report_text  # the report on stdout, as depsim run prints it
    if name == "intelsat5" and not options:
        assert written["deployment"]["deployed"] is True
        assert any(isinstance(v, dict) for e in written["events"] for v in e.values())
    if name == "fourbar":
        assert written["events"][0]["name"] == "assembly"


def test_the_summary_is_depsim_runs_file(programs, tmp_path):
    """`depsim run --target c --summary` and the program: the same file, byte for byte."""
    program, _ = programs("fourbar")
    ran = subprocess.run([str(program), "--t-end", "1", "--summary", tmp_path / "p.json"],
                         capture_output=True, text=True, env={})
    assert ran.returncode == 0, ran.stderr
    assert ran.stdout.startswith("t,crank_angle,")  # no -o: the CSV on stdout
    done = subprocess.run([sys.executable, "-m", "depsim", "run", MODELS["fourbar"], "--target",
                           "c", "--t-end", "1", "--summary", tmp_path / "d.json"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "p.json").read_bytes() == (tmp_path / "d.json").read_bytes()


def test_outputs_are_written_all_or_none(programs, tmp_path):
    """A summary that cannot be written after the run (a full device): the CSV is not
    replaced and nothing is left half written; a folder, or one file for both, is refused
    before the run."""
    program, _ = programs("stops")
    csv = tmp_path / "out.csv"
    csv.write_text("old\n")
    if Path("/dev/full").exists():
        ran = subprocess.run([str(program), "-o", csv, "--summary", "/dev/full"],
                             capture_output=True, text=True, env={})
        assert ran.returncode == 1 and ran.stdout == ""
        assert ran.stderr == "stops: error: cannot write '/dev/full'\n"
        assert csv.read_text() == "old\n"
    ran = subprocess.run([str(program), "-o", csv, "--summary", csv], capture_output=True,
                         text=True, env={})
    assert ran.returncode == 2
    assert ran.stderr == f"stops: error: --summary {csv}: that is the file of -o; give another " \
                         "file\n"
    ran = subprocess.run([str(program), "-o", csv, "--summary", tmp_path], capture_output=True,
                         text=True, env={})
    assert (ran.returncode, ran.stderr) == (1, f"stops: error: cannot write '{tmp_path}': it is "
                                               "a folder\n")
    ran = subprocess.run([str(program), "-o", csv, "--summary", tmp_path / "no" / "s.json"],
                         capture_output=True, text=True, env={})
    assert ran.returncode == 1 and "cannot write" in ran.stderr
    assert csv.read_text() == "old\n" and not list(tmp_path.glob("*.partial"))
