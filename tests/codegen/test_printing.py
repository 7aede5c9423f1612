"""Powers in the printers (codegen/printing.py, c_printer.py): small whole and half-whole
powers of a symbol print as products in every backend, keep their value in any context
(after `/`, under a minus, inside a product), and a compound base or another exponent stays a
power evaluated once."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy

from depsim.codegen.c_printer import CPrinter
from depsim.codegen.printing import IeeePrinter, PythonPrinter

x, y = sympy.symbols("x y")
SLOTS = {x: "q[0]", y: "q[1]"}
VALUES = [1.7, -0.3]  # q[0], q[1]
HALF = sympy.S.Half


@pytest.mark.parametrize("expr", [
    x**2, x**3, x**4, x**-2, x**-4, x**(3 * HALF), x**(-3 * HALF), x**(9 * HALF),
    y / x**2, 2 * x**-2, -x**2, y * x**3 + x**-3, 1 / (1 + x**2), x**2 / y**3,
])
def test_small_powers_print_as_products_with_the_powers_value(expr):
    c_text = CPrinter(SLOTS).doprint(expr)
    assert "pow(" not in c_text, c_text
    exact = float(expr.subs({x: VALUES[0], y: VALUES[1]}))
    for printer, namespace in ((PythonPrinter, {"math": math}), (IeeePrinter, {"numpy": np})):
        text = printer(SLOTS).doprint(expr)
        assert "]**" not in text, text  # no power of a slot
        value = eval(text, {**namespace, "q": np.array(VALUES)})  # our own printed text
        assert value == pytest.approx(exact, rel=4e-16), text


@pytest.mark.parametrize("expr, c_text", [
    ((x + y)**2, "pow(q[0] + q[1], 2)"),       # a compound base: evaluated once
    (sympy.sin(x)**-2, "pow(sin(q[0]), -2)"),
    (x**5, "pow(q[0], 5)"),                     # beyond LARGEST_PRODUCT
    (x**sympy.Rational(1, 3), "pow(q[0], 1.0/3.0)"),
    (x**y, "pow(q[0], q[1])"),
    (sympy.sqrt(x), "sqrt(q[0])"),
    (1 / x, "1.0/q[0]"),
])
def test_other_powers_stay_powers(expr, c_text):
    assert CPrinter(SLOTS).doprint(expr) == c_text
