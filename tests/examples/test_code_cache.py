"""The generated code is cached (README, docs/api.md): a second compile of an unchanged model
loads it without deriving anything (sympy is never imported); the model text, its file name,
element counts or depsim's version make a new entry; parameters never do."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from e2e import EXAMPLES

PROBE = """
import sys, depsim
model = depsim.load(sys.argv[1])
if len(sys.argv) > 3:
    model = model.with_elements({"link1": int(sys.argv[3])})
sim = model.compile(target=sys.argv[2])
print(sim.cached is not None, "sympy" in sys.modules, sim.run(t_end=0.01).times[-1])
"""


def compile_in_process(cache: Path, model: Path, target: str, *extra) -> tuple[bool, bool]:
    done = subprocess.run([sys.executable, "-c", PROBE, str(model), target, *map(str, extra)],
                          env={**os.environ, "DEPSIM_CACHE": str(cache)}, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    cached, sympy, t_end = done.stdout.split()
    assert float(t_end) == 0.01
    return cached == "True", sympy == "True"


@pytest.mark.parametrize("target", ["numpy", "c"])
def test_a_second_compile_derives_nothing(tmp_path: Path, target):
    model = tmp_path / "pendulum.dep"
    model.write_text((EXAMPLES / "pendulum.dep").read_text())
    assert compile_in_process(tmp_path / "cache", model, target) == (False, True)
    assert compile_in_process(tmp_path / "cache", model, target) == (True, False)
    model.write_text(model.read_text() + "\n# a comment changes the text\n")
    assert compile_in_process(tmp_path / "cache", model, target) == (False, True)


def test_element_counts_and_a_half_written_entry_derive_again(tmp_path: Path):
    cache, model = tmp_path / "cache", EXAMPLES / "two_link_flex.dep"
    assert compile_in_process(cache, model, "numpy", 1) == (False, True)
    assert compile_in_process(cache, model, "numpy", 1) == (True, False)
    assert compile_in_process(cache, model, "numpy", 2) == (False, True)
    for stamp in (cache / "models").glob("*/depsim-generated"):
        stamp.unlink()  # as if a compile had been killed before it finished
    assert compile_in_process(cache, model, "numpy", 1) == (False, True)


def test_run_says_when_it_reused_the_code(cli, tmp_path: Path, monkeypatch):
    monkeypatch.setenv("DEPSIM_CACHE", str(tmp_path / "cache"))
    first = cli("run", EXAMPLES / "pendulum.dep", "--t-end", "0.1")
    second = cli("run", EXAMPLES / "pendulum.dep", "--t-end", "0.1", "--set", "m=3")
    assert first.returncode == second.returncode == 0, first.stderr + second.stderr
    assert "code: derived and generated" in first.stdout
    assert "code: reused from the cache" in second.stdout


def test_the_key_covers_the_core_sources_a_c_folder_carries(monkeypatch):
    """A C folder carries the integrator core's sources (main.c, the solver): a change to any
    of them makes a new cache entry, so `depsim compile` never copies a stale core."""
    import depsim.api as api

    api._generator_digest.cache_clear()
    before = api._generator_digest()
    original = Path.read_bytes

    def edited(path: Path) -> bytes:
        data = original(path)
        return data + b"/* edited */\n" if path.name == "step.c" else data

    monkeypatch.setattr(Path, "read_bytes", edited)
    api._generator_digest.cache_clear()
    try:
        assert api._generator_digest() != before
    finally:
        api._generator_digest.cache_clear()
