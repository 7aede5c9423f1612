"""Diagnostics: the error codes, the collector, `ModelError` and the printed format.

A diagnostic is printed as

    model.dep:12:5: error[E012]: unknown member 'panel4'
        hinge h5 joins panel4.b to panel3.a
                       ^~~~~~
    hint: did you mean 'panel3'?

Codes are stable: tests and docs/language.md refer to them. Errors start with E, warnings
with W. Nothing here raises for user input except `ModelError`, which carries every
diagnostic found.
"""

from __future__ import annotations

import dataclasses
import difflib
from collections.abc import Iterable

from .ir import Diagnostic, Span

# Every code the front end can emit, with a one-line title (docs/language.md lists them all).
CODES: dict[str, str] = {
    # files and syntax
    "E001": "syntax error",
    "E002": "cannot read the model file",
    "E003": "the model file is not UTF-8 text",
    "E004": "missing or misplaced model statement",
    "E005": "statement given twice",
    "E006": "nesting too deep",
    "E007": "number out of range",
    "E008": "name too long",
    # names
    "E010": "unknown name",
    "E011": "duplicate name",
    "E012": "unknown member",
    "E013": "unknown point",
    "E014": "reserved name",
    "E015": "parameter used before its declaration",
    "E016": "unknown function",
    "E017": "wrong number of arguments",
    "E018": "name not allowed here",
    "E019": "unknown property",
    # attributes and values
    "E020": "unknown attribute",
    "E021": "missing required attribute",
    "E022": "attribute given twice",
    "E023": "wrong kind of value",
    "E024": "element count is not a positive whole number",
    "E025": "value out of range",
    "E026": "bad simulate setting",
    "E027": "cannot evaluate",
    "E028": "inconsistent attributes",
    "E029": "unknown word for an attribute that takes one of a few words",
    # units and dimensions
    "E030": "wrong dimension",
    "E031": "missing unit",
    "E032": "incompatible dimensions",
    "E033": "bad exponent",
    "E034": "bad function argument",
    "E035": "unknown unit",
    # joints, cables, initial values, outputs
    "E040": "joint joins a member to itself",
    "E041": "hinge angle is not of the form ±(B - A) + offset",
    "E042": "angle of a member the hinge does not join",
    "E043": "cable angles name something that is not a hinge",
    "E044": "cable angles are not a linear combination of hinge angles",
    "E045": "initial value for something that is not a joint",
    "E046": "initial value of a slider that closes a kinematic loop",
    "E047": "input on something it cannot act on, or a default that is not a number",
    "E048": "an angle, torque or axis asked of a particle, which has none",
    "E049": "a free joint between members that other joints already join",
    # repetition (for loops, indexed names, array and structural parameters)
    "E050": "bad loop range",
    "E051": "bad index",
    "E052": "no element with this index",
    "E053": "wrong number of values for an array parameter",
    "E054": "repetition too large",
    "E055": "bad structural parameter",
    "E056": "loop variable reuses a name",
    "E057": "statement that cannot be repeated",
    "E060": "a construct of the other kind of model (planar or spatial)",
    "E061": "bad orientation",
    # warnings
    "W001": "member has no joint path to the ground",
    "W002": "parameter never used",
    "W003": "output interval longer than the simulation",
    "W004": "model has no bodies or beams",
    "W005": "a plain number taken as radians looks like degrees",
}

MAX_DIAGNOSTICS = 50  # after this many errors, stop collecting: the rest are usually noise


@dataclasses.dataclass(frozen=True, slots=True)
class LoopSpan(Span):
    """A span of text inside a `for` loop, in one iteration: `iteration` holds the loop
    variables' values, outermost first ((("i", 3),) for i = 3). Two iterations of the same
    text are different places (a name declared in a loop is declared once per iteration)."""

    iteration: tuple[tuple[str, int], ...] = ()

    def plain(self) -> Span:
        return Span(self.file, self.line, self.col, self.end_line, self.end_col)

    def describe(self) -> str:
        """"in iteration i = 3, j = 2"."""
        return "in iteration " + ", ".join(f"{name} = {value}"
                                           for name, value in self.iteration)


class Reporter:
    """Collects diagnostics while a stage runs; never raises for user input.

    A diagnostic at text inside a `for` loop (a LoopSpan) gets a note naming the iteration;
    the same diagnostic at the same text in later iterations is counted, not repeated."""

    def __init__(self) -> None:
        self.diagnostics: list[Diagnostic] = []
        self._repeats: dict[tuple, tuple[int, int]] = {}  # key -> (list index, more)

    def error(self, code: str, message: str, span: Span, hint: str = "",
              notes: Iterable[str] = ()) -> None:
        assert code.startswith("E") and code in CODES, code
        self._add(Diagnostic(code, message, span, hint, tuple(notes)))

    def warning(self, code: str, message: str, span: Span, hint: str = "",
                notes: Iterable[str] = ()) -> None:
        assert code.startswith("W") and code in CODES, code
        self._add(Diagnostic(code, message, span, hint, tuple(notes)))

    def _add(self, diagnostic: Diagnostic) -> None:
        span = diagnostic.span
        if isinstance(span, LoopSpan):
            key = (diagnostic.code, span.plain(), _shape(diagnostic.message))
            if key in self._repeats:
                self._repeated(key)
                return
            diagnostic = dataclasses.replace(diagnostic, span=span.plain(),
                                             notes=(span.describe(), *diagnostic.notes))
            if len(self.diagnostics) < MAX_DIAGNOSTICS:
                self._repeats[key] = (len(self.diagnostics), 0)
        if len(self.diagnostics) < MAX_DIAGNOSTICS and diagnostic not in self.diagnostics:
            self.diagnostics.append(diagnostic)

    def _repeated(self, key: tuple) -> None:
        index, more = self._repeats[key]
        more += 1
        self._repeats[key] = (index, more)
        first = self.diagnostics[index]
        note = f"{first.notes[0].split(' (')[0]} (and {more} more iteration{'s' * (more > 1)})"
        self.diagnostics[index] = dataclasses.replace(first, notes=(note, *first.notes[1:]))

    @property
    def has_errors(self) -> bool:
        return any(is_error(d) for d in self.diagnostics)

    def errors(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if is_error(d)]

    def warnings(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if not is_error(d)]


def is_error(diagnostic: Diagnostic) -> bool:
    return diagnostic.code.startswith("E")


def sort_key(diagnostic: Diagnostic) -> tuple[int, int]:
    return diagnostic.span.line, diagnostic.span.col


class ModelError(Exception):
    """The model has errors. `diagnostics` holds all of them, with any warnings, in source
    order; `source` is the model text when it could be read (for `format_diagnostics`)."""

    def __init__(self, diagnostics: Iterable[Diagnostic], source: str | None = None) -> None:
        self.diagnostics: list[Diagnostic] = sorted(diagnostics, key=sort_key)
        self.source = source
        assert any(is_error(d) for d in self.diagnostics), "ModelError without an error"
        super().__init__("\n".join(header(d) for d in self.diagnostics))

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if is_error(d)]

    def format(self) -> str:
        """All diagnostics with source lines and carets (see `format_diagnostics`)."""
        return format_diagnostics(self.diagnostics, self.source)


def header(diagnostic: Diagnostic) -> str:
    """The first line: `FILE:LINE:COL: error[E012]: message`."""
    span = diagnostic.span
    severity = "error" if is_error(diagnostic) else "warning"
    return f"{span.file}:{span.line}:{span.col}: {severity}[{diagnostic.code}]: " \
           f"{diagnostic.message}"


def format_diagnostics(diagnostics: Iterable[Diagnostic], source_text: str | None) -> str:
    """Format diagnostics in source order: header line, the source line, a caret line
    (^~~~ under the span on that line), then `hint:` and `note:` lines. Every line ends with
    a newline; "" when there is nothing to report. `source_text` may be None (a file that
    could not be read): then only the header, hint and note lines are printed."""
    lines = (source_text or "").split("\n")
    return "".join(_format_one(d, lines) + "\n" for d in sorted(diagnostics, key=sort_key))


SHOWN_LINE = 160  # a longer source line is shown as a window around the caret


def _format_one(diagnostic: Diagnostic, lines: list[str]) -> str:
    out = [header(diagnostic)]
    span = diagnostic.span
    if 1 <= span.line <= len(lines) and lines[span.line - 1].strip():
        text, span = _window(lines[span.line - 1].rstrip("\r\n"), span)
        out.append(text)
        out.append(_caret(text, span))
    if diagnostic.hint:
        out.append(f"hint: {diagnostic.hint}")
    out.extend(f"note: {note}" for note in diagnostic.notes)
    return "\n".join(out)


def _window(text: str, span: Span) -> tuple[str, Span]:
    """At most about SHOWN_LINE characters of a long line around the span's start, with
    '...' where text is left out; the span moved to match."""
    if len(text) <= SHOWN_LINE:
        return text, span
    start = max(0, min(span.col - 1 - SHOWN_LINE // 4, len(text) - SHOWN_LINE))
    end = start + SHOWN_LINE
    prefix = "..." if start > 0 else ""
    shown = prefix + text[start:end] + ("..." if end < len(text) else "")
    shift = len(prefix) - start
    end_col = span.end_col + shift if span.end_line == span.line else len(shown) + 1
    return shown, Span(span.file, span.line, span.col + shift, span.line,
                       min(end_col, len(prefix) + SHOWN_LINE + 1))


def _caret(text: str, span: Span) -> str:
    """^~~~ under columns [col, end_col) of the span's first line; tabs kept so it aligns."""
    start = min(max(span.col, 1), len(text) + 1)
    end = span.end_col if span.end_line == span.line else len(text) + 1
    width = max(1, min(end, len(text) + 1) - start)
    prefix = "".join("\t" if ch == "\t" else " " for ch in text[:start - 1])
    return prefix + "^" + "~" * (width - 1)


def did_you_mean(name: str, candidates: Iterable[str]) -> str:
    """A hint naming the closest candidate, or "" when none is close."""
    close = difflib.get_close_matches(name, sorted(set(candidates)), n=1, cutoff=0.6)
    return f"did you mean '{close[0]}'?" if close else ""


def join_names(names: Iterable[str]) -> str:
    """'a, b, c' (or 'none')."""
    listed = list(names)
    return ", ".join(listed) if listed else "none"


def file_span(filename: str) -> Span:
    """The span used for problems with a whole file: line 1, column 1."""
    return Span(filename, 1, 1, 1, 2)


def at(span: Span) -> str:
    """`LINE:COL` for notes such as 'first defined at 12:5' ('12:5, in iteration i = 1'
    inside a loop)."""
    where = f"{span.line}:{span.col}"
    return f"{where}, {span.describe()}" if isinstance(span, LoopSpan) else where


def _shape(message: str) -> str:
    """A message with its indices left out: 'panel[3].mass must be positive' and
    'panel[4].mass must be positive' are the same error in two iterations."""
    out, depth = [], 0
    for char in message:
        depth += char == "["
        if not depth:
            out.append(char)
        depth -= char == "]" and depth > 0
    return "".join(out)
