"""INTELSAT V written with for loops (tests/examples/models/intelsat5_for.dep) is
examples/intelsat5.dep: the same checked model and the same generated C code up to names,
and exactly the same results (outputs, hinge angles, latch times, energies, compared with ==,
not a tolerance: the two generated codes compute the same operations in the same order).

Names map by dropping brackets: panel[1] -> panel1, h[1] -> h1, loop[1] -> loop1,
theta[1] -> theta1, h[2].friction -> h2.friction."""

import re
from dataclasses import fields, is_dataclass
from pathlib import Path

import numpy as np
import pytest

import depsim
from depsim.dsl import ir, load_model
from depsim.runtime import simulate
from e2e import EXAMPLES

FOR_MODEL = Path(__file__).parent / "models" / "intelsat5_for.dep"
ORIGINAL = EXAMPLES / "intelsat5.dep"
T_END = 75.0  # all four latches engage by 67.9 s (test_intelsat5.py)
_WHOLE_MODEL = {"name", "description", "source_file", "source_sha256"}
_DESCRIBING = r"\s*\.(name|description|source_file|source_sha256) = "


def plain(name: str) -> str:
    return name.replace("[", "").replace("]", "")


def shape(value):
    """A part of a checked model with its spans left out and its names made plain."""
    if isinstance(value, ir.Span):
        return None
    if isinstance(value, str):
        return plain(value)
    if isinstance(value, tuple):
        return tuple(shape(part) for part in value)
    if is_dataclass(value):
        return (type(value).__name__,) + tuple(
            (f.name, shape(getattr(value, f.name))) for f in fields(value) if f.name != "span")
    return value


def test_expands_to_the_model_of_intelsat5():
    original, looped = load_model(ORIGINAL), load_model(FOR_MODEL)
    assert len(looped.params) == len(original.params) == 41
    for field in fields(ir.Model):
        if field.name not in _WHOLE_MODEL:
            assert shape(getattr(looped, field.name)) == shape(getattr(original, field.name)), \
                field.name
    assert [p.name for p in looped.params[:6]] == ["cable_k", "pulley_r", "yoke.length",
                                                   "yoke.mass", "yoke.inertia", "panel[1].length"]
    assert [h.name for h in looped.hinges] == ["h[1]", "h[2]", "h[3]", "h[4]"]
    assert [h.sign for h in looped.hinges] == [1, 1, -1, 1]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Both models compiled to C (into their own folders) and run to T_END."""
    built = {}
    for path in (ORIGINAL, FOR_MODEL):
        folder = tmp_path_factory.mktemp(path.stem)
        sim = depsim.load(path).compile(target="c", out_dir=folder)
        built[path.stem] = (folder, simulate(sim.module, t_end=T_END))
    return built


def _code(folder: Path) -> list[str]:
    """model.c without its header comment and the model's own description (name, text, file,
    hash), with the names in its strings made plain."""
    text = (folder / "model.c").read_text()
    body = text[text.index("*/") + 2:]
    return [re.sub(r'"[^"\n]*"', lambda m: plain(m.group(0)), line)
            for line in body.splitlines() if not re.match(_DESCRIBING, line)]


def test_generated_code_differs_only_in_names(runs):
    original, looped = _code(runs["intelsat5"][0]), _code(runs["intelsat5_for"][0])
    assert len(original) > 400
    assert looped == original


def test_same_results_exactly(runs):
    original, looped = runs["intelsat5"][1], runs["intelsat5_for"][1]
    assert [plain(n) for n in looped.output_names] == list(original.output_names)
    assert [plain(n) for n in looped.parameter_names] == list(original.parameter_names)
    for field in ("times", "outputs", "hinge_angles", "hinge_rates", "q", "qd", "energy",
                  "dissipated"):
        assert np.array_equal(getattr(looped, field), getattr(original, field)), field
    latches = {plain(r.hinge): r.t for r in looped.deployment.latches}
    assert latches == {r.hinge: r.t for r in original.deployment.latches}
    assert latches == pytest.approx({"h1": 50.61712, "h2": 52.95980, "h4": 55.77998,
                                     "h3": 67.91346}, abs=1e-4)  # test_intelsat5.py
    assert looped.deployment.deployed and looped.stats == original.stats
