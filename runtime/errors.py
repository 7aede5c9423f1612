"""The runtime's one error type: a solver failure the user can act on (CLI exit code 3)."""

from __future__ import annotations


class SolverError(RuntimeError):
    """The integration could not continue without returning wrong results.

    The message names the time (s), the pass ("position", "velocity", "acceleration",
    "initial state", "step size"), the constraint row and its joint (e.g. "hinge h3, row h3.x"),
    the residual reached, and a hint on what to try. The same facts are attributes, so callers
    and tests need not parse the text.
    """

    def __init__(self, what: str, *, t: float | None = None, stage: str | None = None,
                 row: str | None = None, joint: str | None = None,
                 residual: float | None = None, hint: str | None = None):
        self.what = what
        self.t = t
        self.stage = stage
        self.row = row
        self.joint = joint
        self.residual = residual
        self.hint = hint
        super().__init__(self._format())

    def _format(self) -> str:
        where = []
        if self.t is not None:
            where.append(f"t = {self.t:.9g} s")
        if self.stage is not None:
            where.append(f"{self.stage} pass" if self.stage in _PASSES else self.stage)
        if self.joint is not None:
            where.append(self.joint + (f" (row {self.row})" if self.row else ""))
        head = ", ".join(where)
        text = f"{head}: {self.what}" if head else self.what
        if self.hint:
            text += f"\n  hint: {self.hint}"
        return text


_PASSES = ("position", "velocity", "acceleration")
