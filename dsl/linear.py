"""Linear forms of syntax expressions: hinge angles and cable angle combinations.

`linearize` splits an expression that is linear in some names (member angles in a hinge's
`angle`, hinge angles in a cable's `angles`) into terms: each name's occurrences with a
sign and the constant factors multiplying or dividing it, plus constant terms. Anything
else (a product of two such names, a function of one) is reported by the caller.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from .syntax import AstExpr, BinaryOp, CallExpr, NameRef, Quantity, UnaryOp


@dataclass(frozen=True, slots=True)
class Term:
    """sign * node, then each (op, factor) applied in order: ('*', 2) or ('/', 2)."""

    sign: int
    node: AstExpr
    factors: tuple[tuple[str, AstExpr], ...] = ()

    def negated(self) -> Term:
        return Term(-self.sign, self.node, self.factors)

    def scaled(self, op: str, factor: AstExpr) -> Term:
        return Term(self.sign, self.node, self.factors + ((op, factor),))


@dataclass(slots=True)
class LinearForm:
    terms: dict[str, list[Term]] = field(default_factory=dict)  # name -> its occurrences
    constants: list[Term] = field(default_factory=list)

    def map(self, change: Callable[[Term], Term]) -> LinearForm:
        return LinearForm({k: [change(t) for t in v] for k, v in self.terms.items()},
                          [change(t) for t in self.constants])

    def plus(self, other: LinearForm) -> LinearForm:
        terms = {k: list(v) for k, v in self.terms.items()}
        for name, more in other.terms.items():
            terms.setdefault(name, []).extend(more)
        return LinearForm(terms, self.constants + other.constants)


class NotLinear(Exception):
    """Raised inside `linearize` with the subexpression that is not linear."""

    def __init__(self, node: AstExpr) -> None:
        super().__init__()
        self.node = node


def linearize(node: AstExpr, is_variable: Callable[[str], bool]) -> LinearForm:
    """The linear form of `node` in the names for which `is_variable` is true.
    Raises NotLinear(subexpression)."""
    if isinstance(node, NameRef) and len(node.parts) == 1 and is_variable(node.parts[0].text):
        return LinearForm({node.parts[0].text: [Term(1, node)]})
    if isinstance(node, UnaryOp):
        inner = linearize(node.arg, is_variable)
        return inner.map(Term.negated) if node.op == "-" else inner
    if isinstance(node, BinaryOp) and node.op in "+-":
        right = linearize(node.right, is_variable)
        if node.op == "-":
            right = right.map(Term.negated)
        return linearize(node.left, is_variable).plus(right)
    if isinstance(node, BinaryOp) and node.op in "*/" and mentions(node, is_variable):
        if node.op == "*" and not mentions(node.left, is_variable):
            varying, factor = node.right, node.left
        elif not mentions(node.right, is_variable):
            varying, factor = node.left, node.right
        else:
            raise NotLinear(node)
        return linearize(varying, is_variable).map(lambda t: t.scaled(node.op, factor))
    if mentions(node, is_variable):
        raise NotLinear(node)
    return LinearForm({}, [Term(1, node)])


def mentions(node: AstExpr, is_variable: Callable[[str], bool]) -> bool:
    """True when a variable name occurs anywhere in `node`."""
    if isinstance(node, NameRef):
        return len(node.parts) == 1 and is_variable(node.parts[0].text)
    if isinstance(node, UnaryOp):
        return mentions(node.arg, is_variable)
    if isinstance(node, BinaryOp):
        return mentions(node.left, is_variable) or mentions(node.right, is_variable)
    if isinstance(node, CallExpr):
        return any(mentions(a, is_variable) for a in node.args)
    if isinstance(node, Quantity):
        return mentions(node.value, is_variable)
    return False
