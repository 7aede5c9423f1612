"""The models codegen tests run on: every example (through the parser), the models of
tests/codegen/models (what the examples do not use, written in the language), plus the
hand-built IR of tests/codegen/handmade.py."""

from __future__ import annotations

import sys
from pathlib import Path

from depsim.dsl import ir, load_model

import fake_beam
import handmade

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
MODELS = Path(__file__).resolve().parent / "models"


def load_example(name: str) -> ir.Model:
    """examples/<name>.dep through the parser."""
    return load_model(EXAMPLES / f"{name}.dep")


def example_names() -> list[str]:
    return sorted(path.stem for path in EXAMPLES.glob("*.dep"))


HANDMADE = {
    "slider_crank": handmade.slider_crank,
    "pendulum_variant": handmade.pendulum_variant,
    "slider_crank_moving": lambda: handmade.slider_crank(crank_rate=2.5),
    "slider_placed_crank": handmade.slider_placed_crank,
    "cable_pair": handmade.cable_pair,
}


def case_names() -> list[str]:
    """Names of every model case: `example:<name>` and `handmade:<name>`."""
    return ([f"example:{name}" for name in example_names()]
            + [f"model:{path.stem}" for path in sorted(MODELS.glob("*.dep"))]
            + [f"handmade:{name}" for name in HANDMADE] + ["fake_beam:beam_chain"])


def build(case: str, monkeypatch) -> ir.Model:
    """The IR of one case; fake-beam cases install tests/codegen/fake_beam.py as the element."""
    kind, name = case.split(":")
    if kind == "example":
        return load_example(name)
    if kind == "model":
        return load_model(MODELS / f"{name}.dep")
    if kind == "fake_beam":
        monkeypatch.setitem(sys.modules, "depsim.codegen.beam", fake_beam)
        return handmade.beam_chain()
    return HANDMADE[name]()
