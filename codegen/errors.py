"""The error codegen raises for failures the model's author caused."""

from __future__ import annotations

from depsim.dsl.ir import Span


class CodegenError(Exception):
    """A user-caused failure during derivation or emission.

    Carries the same parts as the language's other errors: a code (`E9xx` for codegen), a
    message, the span of the model element at fault (or None) and an optional hint.
    """

    def __init__(self, code: str, message: str, span: Span | None = None, hint: str | None = None):
        super().__init__(message)
        self.code = code
        self.message = message
        self.span = span
        self.hint = hint

    def __str__(self) -> str:
        where = f"{self.span.file}:{self.span.line}:{self.span.col}: " if self.span else ""
        text = f"{where}error[{self.code}]: {self.message}"
        if self.hint:
            text += f"\nhint: {self.hint}"
        return text
