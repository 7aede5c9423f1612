"""depsim.dsl: the .dep language front end.

    load_model(path) -> Model          read, parse and check a .dep file
    parse_model(text, filename) -> Model
    ModelError                         raised with every diagnostic when a model has errors
    format_diagnostics(diags, text)    the compiler-style report (file:line:col: error[E0xx]: ...)
    summary(model) -> str              one screen describing a checked model
    evaluate(expr, params_values)      the value of a constant IR expression
    parse_quantity(text) -> (value, dim)   a constant such as "1.5 N*m", in SI

The checked `Model` and its parts are defined in `depsim.dsl.ir`.
"""

from __future__ import annotations

from pathlib import Path

from .errors import ModelError, Reporter, file_span, format_diagnostics
from .evaluate import EvaluationError, evaluate
from .expressions import parse_quantity
from .ir import Diagnostic, Model
from .parse import parse_source
from .resolve import resolve
from .summary import summary

__all__ = ["Diagnostic", "EvaluationError", "Model", "ModelError", "evaluate",
           "format_diagnostics", "load_model", "parse_model", "parse_quantity", "summary"]


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
    """Read a .dep file (UTF-8) and check it; raises ModelError (E002 when the file cannot
    be read, E003 when it is not UTF-8 text)."""
    filename = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as error:
        reason = error.strerror or type(error).__name__
        raise ModelError([Diagnostic("E002", f"cannot read '{filename}': {reason}",
                                     file_span(filename))]) from None
    text = _decode(data, filename)
    return parse_model(text, filename)


def _decode(data: bytes, filename: str) -> str:
    problem = ""
    if b"\x00" in data:
        problem = "it contains NUL bytes (a binary file?)"
    else:
        try:
            return data.decode("utf-8-sig")
        except UnicodeDecodeError as error:
            line = data[:error.start].count(b"\n") + 1
            problem = f"byte {error.start} (line {line}) is not valid UTF-8"
    raise ModelError([Diagnostic("E003", f"'{filename}' is not a UTF-8 text file: {problem}",
                                 file_span(filename))])
