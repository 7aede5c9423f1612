"""depsim.dsl: the .dep language front end.

    load_model(path) -> Model          read, parse and check a .dep file
    parse_model(text, filename) -> Model
    ModelError                         raised with every diagnostic when a model has errors
    format_diagnostics(diags, text)    the compiler-style report (file:line:col: error[E0xx]: ...)
    summary(model) -> str              one screen describing a checked model
    evaluate(expr, params_values)      the value of a constant IR expression
    parse_quantity(text) -> (value, dim)   a constant such as "1.5 N*m", in SI
    read_model_text(path) -> str       a model file's text (regular file, at most 1 MiB, UTF-8)
    with_elements(model, counts) -> Model   other beam element counts (checked; ValueError)
    check_parameters(model, values, given) -> [str]   range checks of a parameter vector

The checked `Model` and its parts are defined in `depsim.dsl.ir`.
"""

from __future__ import annotations

from pathlib import Path

from .errors import ModelError, Reporter, file_span, format_diagnostics
from .evaluate import EvaluationError, evaluate
from .expressions import parse_quantity
from .files import MAX_MODEL_BYTES, read_model_text
from .ir import Diagnostic, Model
from .limits import check_parameters
from .members import with_elements
from .parse import parse_source
from .resolve import resolve
from .summary import summary

__all__ = ["MAX_MODEL_BYTES", "Diagnostic", "EvaluationError", "Model", "ModelError",
           "check_parameters", "evaluate", "format_diagnostics", "load_model", "parse_model",
           "parse_quantity", "read_model_text", "summary", "with_elements"]


def parse_model(text: str, filename: str) -> Model:
    """Parse and check model text; `filename` is used in diagnostics.

    Returns the checked Model (its `warnings` hold any warnings). Raises ModelError holding
    every error (and warning) found."""
    report = Reporter()
    try:
        source = parse_source(text, filename, report)
        model = resolve(source, text, report) if source is not None else None
    except RecursionError:
        report.error("E006", "the model is nested too deeply to check", file_span(filename))
        model = None
    if model is None or report.has_errors:
        raise ModelError(report.diagnostics, text)
    return model


def load_model(path: str | Path) -> Model:
    """Read a .dep file (UTF-8, a regular file of at most MAX_MODEL_BYTES) and check it;
    raises ModelError (E002 when the file cannot be read, E003 when it is not UTF-8 text)."""
    return parse_model(read_model_text(path), str(path))
