"""Input time tables from CSV files (`depsim run --input NAME=FILE`, docs/language.md, Inputs).

A table is two numbers per line, `t,u` (s and the input's SI unit), times non-decreasing
(a repeated time is a jump); blank lines and `#` comments are skipped. The first line with
content may be a header, a row naming the two columns (`t,u`, `time,T_motor`): each of its
fields starts with a letter or `_` and is not a number. Any other line that is not two
finite numbers is an error naming its line. A UTF-8 byte-order mark is dropped.

The file is read in blocks of lines, each parsed by numpy at once; only a block with a
problem is read again line by line, for the message. So memory stays near the table's own
size (16 bytes a row) whatever the file holds.
"""

from __future__ import annotations

import itertools
import math
import re
import warnings
from pathlib import Path

import numpy as np

MAX_TABLE_BYTES = 64 * 1024 * 1024  # a larger file is refused, never read
BLOCK_LINES = 16384  # lines parsed at once

_NAME = re.compile(r"[A-Za-z_]")


def read_table(path: str | Path) -> np.ndarray:
    """The rows (t, u) of the table in `path`, shape (n, 2); ValueError `FILE:LINE: ...`."""
    path = Path(path)
    _check_file(path)
    blocks, reader = [], _Reader(path)
    try:
        with open(path, encoding="utf-8-sig") as handle:
            while True:
                lines = list(itertools.islice(handle, BLOCK_LINES))
                if not lines:
                    break
                blocks.append(reader.block(lines))
    except UnicodeDecodeError:
        raise ValueError(f"{path}: cannot read: not UTF-8 text (after line "
                         f"{reader.line})") from None
    except OSError as exc:
        raise ValueError(f"{path}: cannot read: {exc}") from None
    rows = np.concatenate(blocks) if blocks else np.empty((0, 2))
    if not len(rows):
        raise ValueError(f"{path}: the table has no rows 't,u'")
    return rows


def content_lines(path: str | Path) -> list[tuple[int, str]]:
    """The lines of a CSV file that have content, with their numbers (from 1): comments (`#`)
    and blank lines skipped, a byte-order mark dropped, each stripped. ValueError `FILE: ...`
    for a file that is missing, larger than MAX_TABLE_BYTES or not UTF-8 text."""
    path = Path(path)
    _check_file(path)
    try:
        with open(path, encoding="utf-8-sig") as handle:
            numbered = [(number, _content(line)) for number, line in enumerate(handle, 1)]
    except UnicodeDecodeError:
        raise ValueError(f"{path}: cannot read: not UTF-8 text") from None
    except OSError as exc:
        raise ValueError(f"{path}: cannot read: {exc}") from None
    return [(number, content) for number, content in numbered if content]


def _check_file(path: Path) -> None:
    try:
        if not path.is_file():
            raise ValueError(f"{path}: no such file" if not path.exists()
                             else f"{path}: not a regular file")
        if path.stat().st_size > MAX_TABLE_BYTES:
            raise ValueError(f"{path}: larger than the limit of {MAX_TABLE_BYTES:,} bytes "
                             "for a time table; thin it out")
    except OSError as exc:
        raise ValueError(f"{path}: cannot read: {exc}") from None


class _Reader:
    """Parses a table block by block: where the next block starts, whether the header may
    still come, the last time read."""

    def __init__(self, path: Path):
        self.path = path
        self.line = 0  # lines read so far
        self.content_seen = False  # a line with content came before: no header any more
        self.previous = -math.inf  # the last time

    def block(self, lines: list[str]) -> np.ndarray:
        """The rows of the next block of lines (ValueError naming the line of a problem)."""
        first = self.line + 1
        self.line += len(lines)
        if not self.content_seen:
            lines = self._without_header(lines, first)
        rows = _parse_fast(lines)
        if rows is None or (len(rows) and (rows[0, 0] < self.previous
                                           or np.any(np.diff(rows[:, 0]) < 0))):
            rows = self._parse_slowly(lines, first)
        if len(rows):
            self.previous = rows[-1, 0]
        return rows

    def _without_header(self, lines: list[str], first: int) -> list[str]:
        """`lines` with the header blanked out, when the first line with content is one."""
        for k, line in enumerate(lines):
            content = _content(line)
            if not content:
                continue
            self.content_seen = True
            fields = [f.strip() for f in content.split(",")]
            if not all(_is_name(f) for f in fields):
                return lines
            if len(fields) != 2:
                raise ValueError(f"{self.path}:{first + k}: a header names the two columns "
                                 f"'t,u'; got '{content}'")
            return lines[:k] + ["\n"] + lines[k + 1:]
        return lines

    def _parse_slowly(self, lines: list[str], first: int) -> np.ndarray:
        """The block line by line: the first problem raises with its line."""
        rows, previous = [], self.previous
        for number, line in enumerate(lines, start=first):
            content = _content(line)
            if not content:
                continue
            values = self._row(content, number)
            if values[0] < previous:
                raise ValueError(f"{self.path}:{number}: time {values[0]:g} s is before the "
                                 f"line above ({previous:g} s): times must not decrease")
            previous = values[0]
            rows.append(values)
        return np.array(rows, dtype=float).reshape(-1, 2)

    def _row(self, content: str, number: int) -> tuple[float, float]:
        fields = [f.strip() for f in content.split(",")]
        expected = f"{self.path}:{number}: expected two numbers 't,u', got '{content}'"
        if len(fields) != 2:
            raise ValueError(f"{expected} ({len(fields)} field{'s' * (len(fields) != 1)})")
        values = [parse_number(f) for f in fields]
        if None in values:
            raise ValueError(f"{expected} ({_not_numbers(fields)})")
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"{self.path}:{number}: expected two finite numbers 't,u', got "
                             f"'{content}'")
        return values[0], values[1]


def _parse_fast(lines: list[str]) -> np.ndarray | None:
    """The block's rows parsed by numpy at once; None when it finds anything amiss (another
    column count, a field that is not a number, a blank line with spaces, a value that is
    not finite): the block is then read line by line."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a block of comments alone: "no data"
            rows = np.loadtxt(lines, delimiter=",", comments="#", dtype=float, ndmin=2)
    except ValueError:
        return None
    if rows.size == 0:
        return np.empty((0, 2))
    if rows.shape[1] != 2 or not np.isfinite(rows).all():
        return None
    return rows


def parse_number(field: str) -> float | None:
    """float(field), or None when it is not a number (text, not an exception)."""
    try:
        return float(field)
    except ValueError:
        return None


def _not_numbers(fields: list[str]) -> str:
    """Why a row of two fields is not two numbers: the first field that is neither a number
    nor a column's name, else the first name (a header comes only first)."""
    bad = [f for f in fields if parse_number(f) is None]
    for field in bad:
        if not field:
            return "an empty field"
        if not _is_name(field):
            return f"'{field}' is not a number, nor a column's name: a name starts with a " \
                   "letter or '_'"
    return f"'{bad[0]}' is not a number; a header naming the columns comes only first"


def _content(line: str) -> str:
    return line.split("#", 1)[0].strip()


def _is_name(field: str) -> bool:
    """A column's name: starts with a letter or `_` and is not a number (`nan`, `inf`)."""
    if not _NAME.match(field):
        return False
    try:
        float(field)
    except ValueError:
        return True
    return False
