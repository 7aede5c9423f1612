"""Errors raised by the facade itself (the stages define their own)."""


class UsageError(Exception):
    """The user called depsim wrongly: unknown parameter, bad option value (exit code 2)."""
