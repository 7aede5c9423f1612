"""Units, dimensions in words, and evaluating constant expressions."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from depsim.dsl import EvaluationError, evaluate, parse_quantity
from depsim.dsl.evaluate import binary, negate
from depsim.dsl.ir import Binary, Call, Dim, HingeAngle, Num, ParamRef, Unary
from depsim.dsl.syntax import FOR_WORDS, INPUT_WORDS, KEYWORDS, MODEL_WORDS
from depsim.dsl.units import UNITS, describe, dim_scale, parse_unit, si_text

GRAMMAR = Path(__file__).parents[2] / "dsl" / "grammar.lark"


def test_grammar_unit_token_names_exactly_the_unit_table():
    unit_line = next(line for line in GRAMMAR.read_text().splitlines()
                     if line.startswith("UNIT:"))
    names = set(re.search(r"\(\?:([^)]*)\)", unit_line).group(1).split("|"))
    assert names == set(UNITS)


def test_keywords_are_the_grammar_words():
    found = re.findall(r"^([A-Z]+)\.2: /([a-z]+)\(\?!\[A-Za-z0-9_\]\)/$", GRAMMAR.read_text(),
                       flags=re.M)
    assert all(name == word.upper() for name, word in found)
    assert {word for _, word in found} == KEYWORDS | {"on"} | set(FOR_WORDS) | set(MODEL_WORDS)
    kinds = re.search(r"^LOAD_KIND\.2: /\(([a-z|]+)\)", GRAMMAR.read_text(), flags=re.M)
    assert {"on", *kinds.group(1).split("|")} == set(INPUT_WORDS)


def test_g_is_not_a_unit():
    assert "g" not in UNITS


@pytest.mark.parametrize("text, factor, dim", [
    ("N*m/rad", 1.0, Dim(1, 2, -2, -1)),
    ("m/s^2", 1.0, Dim(length=1, time=-2)),
    ("N*m*s/rad", 1.0, Dim(1, 2, -1, -1)),
    ("kg*m^2", 1.0, Dim(mass=1, length=2)),
    ("deg", math.pi / 180, Dim(angle=1)),
    ("mm^2", 1e-6, Dim(length=2)),
    ("kN/mm", 1e6, Dim(mass=1, time=-2)),
    ("rpm", 2 * math.pi / 60, Dim(angle=1, time=-1)),
    ("m^-1", 1.0, Dim(length=-1)),
])
def test_parse_unit(text, factor, dim):
    got_factor, got_dim = parse_unit(text)
    assert got_factor == pytest.approx(factor) and got_dim == dim


@pytest.mark.parametrize("dim, text", [
    (Dim(), "1"), (Dim(1, 2, -2, -1), "N*m/rad"), (Dim(1, 2, -2), "N*m"),
    (Dim(length=1, time=-2), "m/s^2"), (Dim(1, 3, -2), "N*m^2"), (Dim(1, -1), "kg/m"),
    (Dim(1, 5, -2, 3), "kg*m^5*rad^3/s^2"), (Dim(time=-3), "1/s^3"),
])
def test_si_text(dim, text):
    assert si_text(dim) == text


def test_describe_in_words():
    assert describe(Dim(1, 2, -2, -1)) == "torque per angle (N*m/rad)"
    assert describe(Dim(1, 2, -2)) == "torque (N*m)"
    assert describe(Dim()) == "a plain number (no unit)"
    assert describe(Dim(mass=3)) == "a quantity (kg^3)"


def test_dim_scale():
    assert dim_scale(Dim(length=2), 0.5) == Dim(length=1)
    assert dim_scale(Dim(length=1), 0.5) is None
    assert dim_scale(Dim(mass=1, time=-1), 3) == Dim(mass=3, time=-3)


def test_evaluate_constant_trees():
    expr = Binary("+", Binary("*", ParamRef(0), Num(2.0)),
                  Call("atan2", (Num(1.0), Unary("-", ParamRef(1)))))
    assert evaluate(expr, [3.0, 1.0]) == pytest.approx(6 + math.atan2(1, -1))
    assert evaluate(Binary("^", Num(2.0), Num(10.0)), []) == 1024.0
    for func, args, result in [("sqrt", (4.0,), 2.0), ("abs", (-3.0,), 3.0),
                               ("min", (1.0, 2.0), 1.0), ("max", (1.0, 2.0), 2.0),
                               ("log", (math.e,), 1.0), ("cosh", (0.0,), 1.0)]:
        assert evaluate(Call(func, tuple(Num(a) for a in args)), []) == pytest.approx(result)


@pytest.mark.parametrize("expr, reason", [
    (Binary("/", Num(1.0), Num(0.0)), "division by zero"),
    (Call("sqrt", (Num(-1.0),)), "domain"),
    (Call("log", (Num(0.0),)), "domain"),
    (Call("exp", (Num(1000.0),)), "too large"),
    (Binary("^", Num(10.0), Num(400.0)), "too large"),
    (Binary("*", Num(1e300), Num(1e300)), "not a finite number"),
    (HingeAngle(0), "not a constant"),
])
def test_evaluate_failures_are_evaluation_errors(expr, reason):
    with pytest.raises(EvaluationError, match=reason):
        evaluate(expr, [])


def test_builders_fold_constants_and_identities():
    assert binary("*", Num(2.0), Num(3.0)) == Num(6.0)
    assert binary("*", ParamRef(0), Num(1.0)) == ParamRef(0)
    assert binary("+", Num(0.0), ParamRef(0)) == ParamRef(0)
    assert binary("/", ParamRef(0), Num(2.0)) == Binary("/", ParamRef(0), Num(2.0))
    assert binary("/", Num(1.0), Num(0.0)) == Binary("/", Num(1.0), Num(0.0))  # left to check
    assert negate(Num(2.0)) == Num(-2.0) and negate(Unary("-", ParamRef(1))) == ParamRef(1)


@pytest.mark.parametrize("text, value, dim", [
    ("1.5 N*m", 1.5, Dim(1, 2, -2)), ("90 deg", math.pi / 2, Dim(angle=1)), ("0.7", 0.7, Dim()),
    ("4500 * 0.01835^2 N*m/rad", 4500 * 0.01835**2, Dim(1, 2, -2, -1)),
    ("-2 mm", -0.002, Dim(length=1)), ("sqrt(4 m^2)", 2.0, Dim(length=1)),
])
def test_parse_quantity(text, value, dim):
    assert parse_quantity(text) == (pytest.approx(value), dim)


@pytest.mark.parametrize("text, message", [
    ("2 meters", "unknown unit 'meters'"), ("k", "unknown name 'k'"), ("1 2", "found number 2"),
    ("", "expected a value"), ("1/0", "division by zero"), ("2 m + 1 kg", "cannot add"),
    ("h1.rate", "unknown name 'h1'"),
])
def test_parse_quantity_errors_are_value_errors(text, message):
    with pytest.raises(ValueError, match=message):
        parse_quantity(text)
