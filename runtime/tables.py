"""Input time tables from CSV files (`depsim run --input NAME=FILE`, docs/language.md, Inputs).

A table is two numbers per line, `t,u` (s and the input's SI unit), times non-decreasing
(a repeated time is a jump); blank lines and `#` comments are skipped and a first line that
is not numbers is a header. The run interpolates u linearly and holds it beyond the ends.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

MAX_TABLE_BYTES = 64 * 1024 * 1024  # a larger file is refused, never read


def read_table(path: str | Path) -> np.ndarray:
    """The rows (t, u) of the table in `path`, shape (n, 2); ValueError `FILE:LINE: ...`."""
    path = Path(path)
    try:
        if not path.is_file():
            raise ValueError(f"{path}: no such file" if not path.exists()
                             else f"{path}: not a regular file")
        if path.stat().st_size > MAX_TABLE_BYTES:
            raise ValueError(f"{path}: larger than {MAX_TABLE_BYTES >> 20} MiB")
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: cannot read: {exc}") from None
    rows, previous = [], -math.inf
    for number, line in enumerate(text.splitlines(), start=1):
        content = line.split("#", 1)[0].strip()
        if not content:
            continue
        fields = [f.strip() for f in content.split(",")]
        try:
            values = [float(f) for f in fields]
        except ValueError:
            if not rows and number == _first_line(text):
                continue  # a header
            raise ValueError(f"{path}:{number}: expected two numbers 't,u', got "
                             f"'{content}'") from None
        if len(values) != 2 or not all(math.isfinite(v) for v in values):
            raise ValueError(f"{path}:{number}: expected two finite numbers 't,u', got "
                             f"'{content}'")
        if values[0] < previous:
            raise ValueError(f"{path}:{number}: time {values[0]:g} s is before the line "
                             f"above ({previous:g} s): times must not decrease")
        previous = values[0]
        rows.append(values)
    if not rows:
        raise ValueError(f"{path}: the table has no rows 't,u'")
    return np.array(rows, dtype=float)


def _first_line(text: str) -> int:
    """The number of the first line with content."""
    for number, line in enumerate(text.splitlines(), start=1):
        if line.split("#", 1)[0].strip():
            return number
    return 0
