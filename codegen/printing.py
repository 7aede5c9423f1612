"""Code printers: sympy expressions to source text in which every input symbol is an array slot.

`SlotPrinter` is the language-neutral part (slots, temporaries, exact doubles, the free-symbol
check); a backend combines it with a sympy code printer. The NumPy module uses `PythonPrinter`
(scalar `math` functions), and `IeeePrinter` (numpy.float64 scalars) for the functions whose
expressions the user writes freely; the C backend combines the same mixin with sympy's C99
printer."""

from __future__ import annotations

from collections.abc import Collection, Mapping

import sympy
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.pycode import PythonCodePrinter

# x**n for whole n with 2 <= |n| <= LARGEST_PRODUCT, and x**(n + 1/2) for such n and n = 1,
# print as products of x and sqrt(x) (SlotPrinter._product)
LARGEST_PRODUCT = 4


class LoweringError(Exception):
    """An expression refers to something that is not an input of the function being lowered
    (a programmer mistake in derive, never the user's)."""


class SlotPrinter:
    """Mixin: prints input symbols as their slots (`q[3]`, `p[7]`, `t`) and CSE temporaries by
    name; any other symbol is an error. Floats print as exact round-trip doubles."""

    def __init__(self, slots: Mapping[sympy.Symbol, str],
                 temporaries: Collection[sympy.Symbol] = (), settings: dict | None = None):
        super().__init__(settings or {})
        self.slots = dict(slots)
        self.temporaries = frozenset(temporaries)

    def _print_Symbol(self, symbol: sympy.Symbol) -> str:
        if symbol in self.slots:
            return self.slots[symbol]
        if symbol in self.temporaries:
            return symbol.name
        raise LoweringError(f"symbol {symbol.name!r} is not an input of this function")

    def _print_Float(self, value: sympy.Float) -> str:
        return repr(float(value))

    def _print_Pow(self, expr: sympy.Pow) -> str:
        product = self._product(expr)
        return product if product is not None else super()._print_Pow(expr)

    def _product(self, expr: sympy.Pow) -> str | None:
        """A small whole or half-whole power of a symbol (a slot or a temporary) as a product,
        `(x*x)`, `(1.0/(x*x*sqrt(x)))`, in every backend; None for any other power. A
        multiplication is correctly rounded where libm's pow is not always, C compilers
        already turn pow(x, 2) into x*x (so the backends would differ), and a pow call costs
        tens of multiplications (a beam's force has dozens per evaluation). A compound base
        stays in pow, evaluated once. The parentheses keep the product whole where the caller
        sees only a power (after `/`, sympy prints the denominator by the power's
        precedence)."""
        base, exp = expr.base, expr.exp
        if not (base.is_Symbol and exp.is_Rational and (2 * exp).is_Integer and abs(exp) > 1):
            return None
        whole, half = divmod(int(abs(2 * exp)), 2)
        if whole > LARGEST_PRODUCT:
            return None
        factors = [self.parenthesize(base, 50)] * whole  # 50: a product's precedence
        if half:
            factors.append(self._print(sympy.Pow(base, sympy.S.Half, evaluate=False)))
        product = "*".join(factors)
        return f"({product})" if exp > 0 else f"(1.0/({product}))"


class PythonPrinter(SlotPrinter, PythonCodePrinter):
    """Python source over scalars: `math.sin`, `abs`, `min`; arrays indexed as `q[3]`."""

    def __init__(self, slots: Mapping[sympy.Symbol, str],
                 temporaries: Collection[sympy.Symbol] = ()):
        super().__init__(slots, temporaries, {"strict": True, "standard": "python3"})


class IeeePrinter(SlotPrinter, NumPyPrinter):
    """Python source over numpy.float64 scalars: `numpy.sqrt`, `numpy.log`, ... A value outside
    a function's domain or a division by zero gives nan or inf, as in C, not an exception (the
    generated function evaluates under numpy.errstate(all="ignore"))."""

    def __init__(self, slots: Mapping[sympy.Symbol, str],
                 temporaries: Collection[sympy.Symbol] = ()):
        super().__init__(slots, temporaries, {"strict": True})

    def _print_Max(self, expr: sympy.Max) -> str:
        return self._nested("numpy.fmax", expr.args)

    def _print_Min(self, expr: sympy.Min) -> str:
        return self._nested("numpy.fmin", expr.args)

    def _nested(self, function: str, args) -> str:
        """fmax(a, fmax(b, c)): C's fmax and fmin of two arguments (a nan argument is left
        out, as C's are)."""
        text = self._print(args[-1])
        for arg in reversed(args[:-1]):
            text = f"{function}({self._print(arg)}, {text})"
        return text
