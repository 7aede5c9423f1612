"""Robustness: no input makes the front end raise anything but ModelError.

Random text, and the examples mutated by deletions, insertions and swaps of characters and
of tokens the grammar knows, must either check or raise ModelError whose diagnostics format
without error; load_model must do the same for arbitrary bytes."""

from __future__ import annotations

from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from depsim.dsl import ModelError, format_diagnostics, load_model, parse_model, summary

EXAMPLES = [p.read_text(encoding="utf-8")
            for p in sorted((Path(__file__).parents[2] / "examples").glob("*.dep"))]
PIECES = ["{", "}", "(", ")", "=", "\n", ";", ",", ".", "-", "*", "/", "^", "#", '"', "bar ",
          "hinge ", "joins ", " to ", "point ", "initial ", "m", " deg", " N*m/rad", "rad",
          "ground", "1e999", "0", "-1", "2.5", "pi", "t", "x", "\t", "\r", "\x00", "é", "((("]
SETTINGS = settings(max_examples=200, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


def check(text: str) -> None:
    try:
        model = parse_model(text, "fuzz.dep")
    except ModelError as error:
        assert error.diagnostics
        assert all(d.code[0] in "EW" and d.span.line >= 1 for d in error.diagnostics)
        format_diagnostics(error.diagnostics, text)
        return
    summary(model)


@st.composite
def mutated_example(draw) -> str:
    text = draw(st.sampled_from(EXAMPLES))
    for _ in range(draw(st.integers(1, 6))):
        i = draw(st.integers(0, len(text)))
        kind = draw(st.sampled_from(["delete", "insert", "piece", "swap"]))
        if kind == "delete":
            text = text[:i] + text[i + draw(st.integers(1, 30)):]
        elif kind == "insert":
            text = text[:i] + draw(st.text(max_size=3)) + text[i:]
        elif kind == "piece":
            text = text[:i] + draw(st.sampled_from(PIECES)) + text[i:]
        elif i + 1 < len(text):
            text = text[:i] + text[i + 1] + text[i] + text[i + 2:]
    return text


@SETTINGS
@given(st.text(max_size=200))
def test_random_text_raises_only_model_error(text):
    check(text)


@SETTINGS
@given(st.lists(st.sampled_from(PIECES + ["model m\n", "param k = ", "bar b {"]),
                max_size=40).map("".join))
def test_random_token_soup_raises_only_model_error(text):
    check("model m\n" + text)


@SETTINGS
@given(mutated_example())
def test_mutated_examples_raise_only_model_error(text):
    check(text)


@settings(max_examples=50, deadline=None)
@given(st.binary(max_size=200))
def test_load_model_of_any_bytes_raises_only_model_error(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("fuzz") / "model.dep"
    path.write_bytes(data)
    try:
        load_model(path)
    except ModelError as error:
        format_diagnostics(error.diagnostics, error.source or "")
