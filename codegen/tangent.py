"""Forward-mode differentiation of a straight-line program: the tangent of a model function.

A generated function is a program: steps `s = e` in order (the system's constants and hinge
steps, the function's own groups), then results r. Its tangent along directions dx of its
inputs x is the same program with a companion step after each, ds = sum_x de/dx dx over the
free symbols x of e that are inputs with a direction or earlier steps with a companion, and
results dr = sum_x dr/dx dx likewise. Each expression is differentiated as it stands, by the
symbols it names, so the tangent grows like the program, not like the substituted expressions.
Pure mathematics: symbols and expressions, no code."""

from __future__ import annotations

import sympy

from .assembly import Group


def direction(symbol: sympy.Symbol) -> sympy.Symbol:
    """The direction symbol of an input symbol, or the companion of a step's symbol: the same
    mapping for both ('#d' keeps the names apart from the model's, which never hold '#')."""
    return sympy.Symbol(f"#d{symbol.name}")


def needed_steps(steps: tuple[Group, ...], exprs) -> tuple[Group, ...]:
    """The steps `exprs` need, directly or through later steps, in order (groups left empty
    dropped): a function evaluates nothing it does not use."""
    needed = set().union(*(e.free_symbols for e in exprs))
    kept: list[Group] = []
    for group in reversed(steps):
        group = tuple(step for step in group if step[0] in needed)
        if group:
            kept.append(group)
            needed |= set().union(*(value.free_symbols for _, value in group))
    kept.reverse()
    return tuple(kept)


def as_groups(definitions: list[tuple[sympy.Symbol, sympy.Expr]]) -> tuple[Group, ...]:
    """A flat program (each definition may use the ones before it) as groups: consecutive
    definitions together until one uses a symbol of its group."""
    groups: list[list[tuple[sympy.Symbol, sympy.Expr]]] = [[]]
    defined: set[sympy.Symbol] = set()
    for symbol, value in definitions:
        if value.free_symbols & defined:
            groups.append([])
            defined = set()
        groups[-1].append((symbol, value))
        defined.add(symbol)
    return tuple(tuple(group) for group in groups if group)


def tangent_program(steps: tuple[Group, ...], inputs, results
                    ) -> tuple[tuple[Group, ...], list[sympy.Expr]]:
    """The tangent program of `steps` and `results` along the directions of `inputs` (the
    symbols with a direction): each group followed, in the same group, by its steps'
    companions that are not identically zero (a companion refers only to earlier groups'
    symbols and companions, so the group stays a group); and the results' tangents."""
    moving = {x: direction(x) for x in inputs}
    program: list[Group] = []
    for group in needed_steps(steps, results):
        changes = [(symbol, differential(value, moving)) for symbol, value in group]
        changes = [(symbol, change) for symbol, change in changes if change != 0]
        moving.update({symbol: direction(symbol) for symbol, _ in changes})
        program.append(group + tuple((direction(symbol), change) for symbol, change in changes))
    return tuple(program), [differential(r, moving) for r in results]


def differential(expr: sympy.Expr, moving: dict[sympy.Symbol, sympy.Symbol]) -> sympy.Expr:
    """sum_x d expr / dx * moving[x] over the symbols of `expr` that move. Differentiated over
    real symbols (the model's are real: d|x|/dx is sign(x), not an expression of re and im),
    with DiracDelta (the derivative of Heaviside and sign at their jump) mapped to 0, the
    derivative almost everywhere, so no generated code ever evaluates a delta. A condition
    (x > 0) has none: 0."""
    present = sorted(expr.free_symbols & moving.keys(), key=lambda s: s.name)
    if not present or not isinstance(expr, sympy.Expr):  # a condition (a CSE'd one) stays
        return sympy.Integer(0)
    real = {s: sympy.Dummy(s.name, real=True) for s in expr.free_symbols}
    back = {r: s for s, r in real.items()}
    over_reals = expr.xreplace(real)
    total = sympy.Add(*(over_reals.diff(real[s]) * moving[s] for s in present))
    total = total.replace(sympy.DiracDelta, lambda *args: sympy.Integer(0))
    if total.has(sympy.Derivative):
        raise ValueError(f"no derivative of {expr} by {present}: an unevaluated {total}")
    return total.xreplace(back)
