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


# The kinds of range check, in the order of `enum dep_limit_kind` (depsim_model.h), and the
# rule each states. A kind with a bound ("below", "at_least") compares two values.
LIMIT_KINDS = ("positive", "nonnegative", "nonzero", "below", "at_least")
_RULES = {"positive": "must be positive", "nonnegative": "must not be negative",
          "nonzero": "must not be zero", "below": "must be less than",
          "at_least": "must be at least"}


def message_format(limit: Limit) -> str:
    """The message of `limit` broken, as a printf format of its value and bound (`%g`, in
    that order): the one wording of a range check, which `violation` fills here and the
    integrator core fills in C (the generated model's LIMIT_MESSAGES), e.g.

        "rod.length must be positive, got %g m"
        "h1.stop_min must be less than h1.stop_max, got %g rad and %g rad"
    """
    unit = "" if limit.unit in ("", "1") else " " + limit.unit.replace("%", "%%")
    what = limit.what.replace("%", "%%")
    if limit.kind == "nonzero":
        return f"{what} {_RULES[limit.kind]}"
    if limit.bound is None:
        return f"{what} {_RULES[limit.kind]}, got %g{unit}"
    bound = limit.bound_what.replace("%", "%%")
    return f"{what} {_RULES[limit.kind]} {bound}, got %g{unit} and %g{unit}"


def holds(kind: str, value: float, bound: float = 0.0) -> bool:
    """Whether a value (and its bound) passes a check of `kind` (LIMIT_KINDS)."""
    return {"positive": value > 0, "nonnegative": value >= 0, "nonzero": value != 0,
            "below": value < bound, "at_least": value >= bound}[kind]


def violation(limit: Limit, values: Sequence[float]) -> str | None:
    """The message saying how `limit` fails for the parameter values `values` (SI, in
    Model.params order), or None when it holds. Raises EvaluationError when a value cannot
    be computed (division by zero, ...)."""
    assert limit.kind in LIMIT_KINDS and (limit.bound is None) == (limit.kind in (
        "positive", "nonnegative", "nonzero")), limit
    value = evaluate(limit.expr, values)
    bound = evaluate(limit.bound, values) if limit.bound is not None else 0.0
    if holds(limit.kind, value, bound):
        return None
    form = message_format(limit)
    return form % (value, bound)[:form.replace("%%", "").count("%g")]


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


__all__ = ["LIMIT_KINDS", "check_parameters", "holds", "message_format", "violation"]
