"""Errors raised by the facade itself (the stages define their own)."""


class UsageError(Exception):
    """The user called depsim wrongly: unknown parameter, bad option value (exit code 2)."""


class DataError(Exception):
    """A measured-data file is wrong (depsim fit): the file, the line (from 1) and what is
    wrong; printed `FILE:LINE: error: message` (exit code 1)."""

    def __init__(self, path, line: int, message: str):
        self.path, self.line, self.message = str(path), line, message
        super().__init__(f"{path}:{line}: error: {message}")
