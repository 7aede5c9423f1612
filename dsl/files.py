"""Reading a model file: a regular file of bounded size holding UTF-8 text.

Everything read from outside is bounded: a device (`/dev/zero`), a FIFO or a directory is
refused before it is opened, and no more than MAX_MODEL_BYTES + 1 bytes are ever read, so
no input can make `depsim check` grow without bound. Problems raise `ModelError` with E002
(cannot read) or E003 (not UTF-8 text), at line 1, column 1 of the file.
"""

from __future__ import annotations

import os
import stat
from typing import NoReturn

from .errors import ModelError, file_span
from .ir import Diagnostic

MAX_MODEL_BYTES = 1 << 20  # 1 MiB: about 400 times the largest example, checked in seconds

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


def read_model_text(path: str | os.PathLike) -> str:
    """The text of the model file at `path`, decoded from UTF-8 (a byte-order mark is
    dropped). Raises ModelError: E002 when it is missing, unreadable, not a regular file or
    larger than MAX_MODEL_BYTES; E003 when it is not UTF-8 text."""
    filename = str(path)
    try:
        _check_kind(os.stat(path), filename)
        data = _read_bounded(path, filename)
    except OSError as error:
        reason = error.strerror or type(error).__name__
        _fail("E002", f"cannot read '{filename}': {reason}", filename)
    return _decode(data, filename)


def _check_kind(info: os.stat_result, filename: str) -> None:
    """Refuse anything but a regular file (reading a device or a FIFO may never end)."""
    if stat.S_ISREG(info.st_mode):
        if info.st_size > MAX_MODEL_BYTES:
            _too_large(filename)
        return
    kind = next((word for test, word in _KINDS if test(info.st_mode)), "not a regular file")
    _fail("E002", f"cannot read '{filename}': it is {kind}, not a model file", filename)


def _read_bounded(path: str | os.PathLike, filename: str) -> bytes:
    # O_NONBLOCK: should the path have become a FIFO since the stat, opening it returns at once
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    descriptor = os.open(path, flags)
    with os.fdopen(descriptor, "rb") as file:
        _check_kind(os.fstat(file.fileno()), filename)
        data = file.read(MAX_MODEL_BYTES + 1)
    if len(data) > MAX_MODEL_BYTES:  # a file that grew, or one whose size stat does not know
        _too_large(filename)
    return data


def _too_large(filename: str) -> NoReturn:
    _fail("E002", f"cannot read '{filename}': it is larger than {MAX_MODEL_BYTES} bytes "
          f"({MAX_MODEL_BYTES >> 20} MiB), the limit for a model file", filename)


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
    _fail("E003", f"'{filename}' is not a UTF-8 text file: {problem}", filename)


def _fail(code: str, message: str, filename: str) -> NoReturn:
    raise ModelError([Diagnostic(code, message, file_span(filename))]) from None


__all__ = ["MAX_MODEL_BYTES", "read_model_text"]
