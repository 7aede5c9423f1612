"""Range checks of values computed from the parameters (`ir.Limit`).

The checker records one Limit for every attribute with a range (AttrSpec.limit: a bar's
length > 0, a friction >= 0, ...), every ordered pair of hinge attributes (stop_min <
stop_max, static_friction >= friction) and every slider axis (not zero), and tests them at the
default parameters (E025, E028). `check_parameters` tests the same limits for any parameter
vector, so a value changed at run time (`--set L=-1`) is held to the model text's rules.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from .evaluate import EvaluationError, evaluate, param_indices
from .ir import Limit, Model


def violation(limit: Limit, values: Sequence[float]) -> str | None:
    """The message saying how `limit` fails for the parameter values `values` (SI, in
    Model.params order), or None when it holds. Raises EvaluationError when a value cannot
    be computed (division by zero, ...)."""
    value = evaluate(limit.expr, values)
    got = f"got {_quantity(value, limit.unit)}"
    if limit.kind == "positive":
        return None if value > 0 else f"{limit.what} must be positive, {got}"
    if limit.kind == "nonnegative":
        return None if value >= 0 else f"{limit.what} must not be negative, {got}"
    if limit.kind == "nonzero":
        return None if value != 0 else f"{limit.what} must not be zero"
    assert limit.bound is not None, limit
    bound = evaluate(limit.bound, values)
    both = f"got {_quantity(value, limit.unit)} and {_quantity(bound, limit.unit)}"
    if limit.kind == "below":
        return None if value < bound else \
            f"{limit.what} must be less than {limit.bound_what}, {both}"
    assert limit.kind == "at_least", limit.kind
    return None if value >= bound else \
        f"{limit.what} must be at least {limit.bound_what}, {both}"


def check_parameters(model: Model, values: Sequence[float],
                     given: Mapping[str, str] | None = None) -> list[str]:
    """Every range check of `model` that the parameter vector `values` (SI floats, one per
    entry of `model.params`, in that order) violates, as one message each, in file order:

        "rod.length must be positive, got -1 m (from --set L=-1)"

    The message names the checked attribute and, in parentheses, the parameters its value
    comes from that differ from their defaults: as `given[name]` when the caller passes how
    the user wrote it (e.g. {"L": "--set L=-1"}), else as "L = -1 m". [] when all hold."""
    if len(values) != len(model.params):
        raise ValueError(f"{len(values)} parameter values for {len(model.params)} parameters")
    problems = []
    for limit in model.limits:
        try:
            message = violation(limit, values)
        except EvaluationError as error:
            message = f"cannot evaluate {limit.what}: {error}"
        if message is not None:
            problems.append(message + _origin(limit, model, values, given or {}))
    return problems


def _origin(limit: Limit, model: Model, values: Sequence[float],
            given: Mapping[str, str]) -> str:
    """' (from L = -1 m, ...)': the parameters the limit depends on that were changed."""
    indices = param_indices(limit.expr)
    if limit.bound is not None:
        indices |= param_indices(limit.bound)
    parts = []
    for i in sorted(indices):
        param = model.params[i]
        if param.name in given:
            parts.append(given[param.name])
        elif not _same(values[i], param.default) and param.name != limit.what:
            parts.append(f"{param.name} = {_quantity(values[i], param.unit)}")
    return f" (from {', '.join(parts)})" if parts else ""


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def _quantity(value: float, unit: str) -> str:
    return f"{value:g}" if unit in ("", "1") else f"{value:g} {unit}"


__all__ = ["check_parameters", "violation"]
