"""The C99 printer: sympy expressions to C in which every input symbol is an array slot.

`CPrinter` combines `SlotPrinter` (slots, temporaries, exact doubles) with sympy's C99 printer
and overrides what would make C and NumPy disagree or break strict C99:

* powers are printed as the NumPy printer chooses them (small whole and half-whole ones of a
  symbol as products, `SlotPrinter._product`; `sqrt`, `1.0/sqrt`, else `pow`), so both backends
  do the same arithmetic and call the same libm functions (`cbrt` would round differently
  from `x**(1/3)`);
* `pi` and `E` are exact double literals (`M_PI` is not in strict C99's math.h);
* integers too large for a C `long` are printed as doubles, as Python converts them;
* `sign`, `Heaviside` and `Piecewise` print as one-line conditional expressions with the
  NumPy printer's values (sign(0) = 0, Heaviside(0) = 1/2).

The literals a template needs (doubles, strings, comments) are made safe here too, so no
model text can leave a string literal or a comment (`c_string`, `c_comment`)."""

from __future__ import annotations

import math
import re
from collections.abc import Collection, Mapping

import sympy
from sympy.printing.c import C99CodePrinter
from sympy.printing.precedence import precedence

from depsim.runtime.core import CORE_FOLDER

from .printing import SlotPrinter

LARGEST_INTEGER_LITERAL = 2 ** 31 - 1  # an `int` on every C99 platform


class CPrinter(SlotPrinter, C99CodePrinter):
    """C99 source over `const double` arrays: `q[3]`, `p[7]`, `t`, temporaries `x0`..."""

    def __init__(self, slots: Mapping[sympy.Symbol, str],
                 temporaries: Collection[sympy.Symbol] = ()):
        super().__init__(slots, temporaries, {"strict": True})
        self.math_macros = {}  # no M_PI_2, M_SQRT2, ...: not in strict C99

    def _print_Pow(self, expr: sympy.Pow) -> str:
        base, exp = expr.base, expr.exp
        product = self._product(expr)
        if product is not None:
            return product
        if exp == sympy.S.Half:
            return f"sqrt({self._print(base)})"
        if exp == -sympy.S.Half:
            return f"1.0/sqrt({self._print(base)})"
        if exp == -1:
            return f"1.0/{self.parenthesize(base, precedence(expr))}"
        return f"pow({self._print(base)}, {self._print(exp)})"

    def _print_Integer(self, value: sympy.Integer) -> str:
        if abs(int(value)) > LARGEST_INTEGER_LITERAL:
            return c_double(float(value))
        return str(int(value))

    def _print_Rational(self, value: sympy.Rational) -> str:
        p, q = int(value.p), int(value.q)
        if max(abs(p), q) <= LARGEST_INTEGER_LITERAL:
            return f"{p}.0/{q}.0"
        return f"{c_double(p)}/{c_double(q)}"

    def _print_Pi(self, _expr) -> str:
        return c_double(math.pi)

    def _print_Exp1(self, _expr) -> str:
        return c_double(math.e)

    def _print_NaN(self, _expr) -> str:
        return "NAN"

    def _print_Infinity(self, _expr) -> str:
        return "INFINITY"

    def _print_NegativeInfinity(self, _expr) -> str:
        return "-INFINITY"

    def _print_sign(self, expr: sympy.sign) -> str:
        arg = self._print(expr.args[0])
        return f"(({arg}) == 0 ? 0.0 : copysign(1.0, {arg}))"

    def _print_Heaviside(self, expr: sympy.Heaviside) -> str:
        arg = self._print(expr.args[0])
        return f"(({arg}) < 0 ? 0.0 : ({arg}) == 0 ? 0.5 : 1.0)"

    def _print_Piecewise(self, expr: sympy.Piecewise) -> str:
        if expr.args[-1].cond != sympy.true:
            raise ValueError("a Piecewise needs a final (value, True) branch to print as C")
        text = f"({self._print(expr.args[-1].expr)})"
        for value, condition in reversed(expr.args[:-1]):
            text = f"(({self._print(condition)}) ? ({self._print(value)}) : {text})"
        return text


def c_double(value: float) -> str:
    """A C double literal that reads back exactly (`repr` round-trips), NAN, INFINITY."""
    value = float(value)
    if math.isnan(value):
        return "NAN"
    if math.isinf(value):
        return "INFINITY" if value > 0 else "-INFINITY"
    text = repr(value)
    return text if any(c in text for c in ".eE") else text + ".0"


_PRINTABLE = {chr(code) for code in range(0x20, 0x7F)}


def c_string(text: str) -> str:
    """A C string literal of `text` (UTF-8 bytes): printable ASCII stays, `"` `\\` and `?`
    (trigraphs) are escaped, every other byte is a three-digit octal escape, so nothing the
    text contains can end the literal or start a new line of code."""
    out = []
    for byte in str(text).encode("utf-8"):
        char = chr(byte)
        if char in '"\\?':
            out.append("\\" + char)
        elif char in _PRINTABLE:
            out.append(char)
        else:
            out.append(f"\\{byte:03o}")
    return '"' + "".join(out) + '"'


def c_comment(text: str) -> str:
    """`text` on one line, safe inside a C block comment: control characters become spaces,
    non-ASCII characters `\\uXXXX`, and `*/`, `/*`, `//` and `??` (trigraphs) are split."""
    chars = []
    for char in str(text):
        if char in _PRINTABLE:
            chars.append(char)
        elif ord(char) < 0x80 or char.isspace():
            chars.append(" ")
        else:
            chars.append(f"\\u{ord(char):04x}" if ord(char) <= 0xFFFF else f"\\U{ord(char):08x}")
    line = " ".join("".join(chars).split())
    for pair in ("*/", "/*", "//", "??"):
        while pair in line:
            line = line.replace(pair, pair[0] + " " + pair[1])
    return line


_IDENTIFIER = re.compile(r"[^A-Za-z0-9_]")


# Names a program of the C folder must not take, compared without case (a case-insensitive
# file system): make's files, the Makefile's targets (templates/c/Makefile.j2: `make clean`
# must not be the program's rule) and earlier reserved words. tests/c check that this covers
# every target and file of a generated folder.
# the C folder's files and make targets (its core/ folder among them)
RESERVED_STEMS = frozenset({"makefile", "gnumakefile", "all", "clean", "model", "depsim",
                            CORE_FOLDER})


def c_file_stem(name: str) -> str:
    """A model name as a program and library name: letters, digits and `_` only (anything
    else becomes `_`), not starting with a digit, never empty, never a file or a make target
    of the folder."""
    stem = _IDENTIFIER.sub("_", str(name))[:64]
    if not stem or stem[0].isdigit() or stem.lower() in RESERVED_STEMS:
        stem = "model_" + stem
    return stem
