"""docs/language.md stays true: its models check, and it lists every code and unit."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from depsim.dsl import parse_model
from depsim.dsl.errors import CODES
from depsim.dsl.units import UNITS

DOC = (Path(__file__).parents[2] / "docs" / "language.md").read_text(encoding="utf-8")
MODELS = re.findall(r"```dep\n(.*?)```", DOC, flags=re.S)


def test_docs_have_examples():
    assert len(MODELS) >= 12


@pytest.mark.parametrize("text", MODELS, ids=[f"block{i}" for i in range(len(MODELS))])
def test_every_example_in_the_docs_checks(text):
    parse_model(text, "language.md")


def test_every_code_is_documented():
    documented = set(re.findall(r"^\| ([EW]\d{3}) \|", DOC, flags=re.M))
    assert documented == set(CODES)


def test_every_unit_is_documented():
    documented = set(re.findall(r"^\| `(\w+)` \| [^|]+ \| [^|]+ \|$", DOC, flags=re.M))
    assert set(UNITS) <= documented
