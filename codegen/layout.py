"""The coordinate layout: (x, y, phi) per rigid body in body order, (x, y) per particle in
particle order, then each beam's coordinates in beam order (a spatial model: (x, y, z, R11,
..., R33) per body, (x, y, z) per particle; codegen/spatial.py); and the ordered symbols q,
q', p, t."""

from __future__ import annotations

from typing import Any

import sympy

from depsim.dsl import ir

from .errors import CodegenError
from .expr import ConstantScope, to_sympy
from .kinematics import Coordinates
from .spatial import BODY_COORDINATES as SPATIAL_BODY
from .spatial import PARTICLE_COORDINATES as SPATIAL_PARTICLE

RIGID_COORDINATES = ("x", "y", "phi")
PARTICLE_COORDINATES = ("x", "y")


def _symbol(name: str) -> sympy.Symbol:
    # No assumptions (real=True would make every derivative query them: about 2.5x slower on
    # two_link_flex). Nothing derive differentiates contains abs/sign of a coordinate.
    return sympy.Symbol(name)


def build_coordinates(model: ir.Model) -> tuple[Coordinates, tuple[Any, ...]]:
    """The model's ordered symbols and one beam element (BeamSymbolic) per beam
    (codegen/beam.py)."""
    from . import beam as module  # (the tests put a stand-in element in its place)

    p = tuple(_symbol(param.name) for param in model.params)
    t = _symbol("t")
    rigid, particle = (SPATIAL_BODY, SPATIAL_PARTICLE) if model.spatial \
        else (RIGID_COORDINATES, PARTICLE_COORDINATES)
    names = [f"{body.name}.{c}" for body in model.bodies for c in rigid]
    names += [f"{p.name}.{c}" for p in model.particles for c in particle]
    q = [_symbol(name) for name in names]
    beam_q, elements = [], []
    scope = ConstantScope(p, t)
    for beam in model.beams:
        symbols = tuple(_symbol(f"{beam.name}.q{k}") for k in range(module.coordinate_count(beam)))
        element = module.beam_element(beam, list(symbols), lambda e: to_sympy(e, scope))
        assert len(element.coordinate_names) == len(symbols), "beam coordinate count mismatch"
        names += [_prefixed(beam.name, name) for name in element.coordinate_names]
        q += symbols
        beam_q.append(symbols)
        elements.append(element)
    qd = [_symbol(symbol.name + "'") for symbol in q]
    _check_distinct(model, p, [t, *q, *qd])
    return Coordinates(tuple(names), tuple(q), tuple(qd), p, t, tuple(beam_q)), tuple(elements)


def _prefixed(beam: str, name: str) -> str:
    return name if name.startswith(beam + ".") else f"{beam}.{name}"


def _check_distinct(model: ir.Model, p: tuple[sympy.Symbol, ...],
                    others: list[sympy.Symbol]) -> None:
    """Symbols are equal when their names are: a parameter must not share a name with time,
    a coordinate or another parameter."""
    seen = {symbol.name for symbol in others}
    for param, symbol in zip(model.params, p):
        if symbol.name in seen:
            raise CodegenError("E902", f"parameter name '{param.name}' is used twice or is "
                               "reserved", param.span, "rename the parameter")
        seen.add(symbol.name)
