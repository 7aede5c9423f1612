"""Input time tables (runtime/tables.py, docs/language.md, Inputs): a header is a row naming
the two columns, anything else that is not two finite numbers is an error naming its line; a
byte-order mark is dropped; reading is done in blocks, in memory near the table's own size."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from depsim.runtime import tables
from depsim.runtime.tables import read_table


def table(tmp_path, data: bytes | str, name: str = "table.csv"):
    path = tmp_path / name
    path.write_bytes(data if isinstance(data, bytes) else data.encode())
    return path


@pytest.mark.parametrize("text", [
    b"\xef\xbb\xbf0,3\n0.1,0\n",  # a byte-order mark before a headerless table
    b"\xef\xbb\xbft,u\n0,3\n0.1,0\n",
    b"0,3\r\n0.1,0\r\n",
    b"# torque of the rig\n\n  \ntime [s], T_motor [N*m]  # measured\n0, 3\n# gap\n0.1 ,0\n",
    b"_t,u\n0,3\n0.1,0",
])
def test_a_header_is_a_row_naming_the_columns_and_nothing_else_is_dropped(tmp_path, text):
    assert read_table(table(tmp_path, text)).tolist() == [[0.0, 3.0], [0.1, 0.0]]


@pytest.mark.parametrize("text, line, fragment", [
    ("0,3O\n0.1,0\n", 1, "got '0,3O' ('3O' is not a number, nor a column's name"),
    ("# rig\nt,3O\n0.1,0\n", 2, "got 't,3O' ('3O' is not a number"),
    ("t,u,v\n0,1\n", 1, "a header names the two columns 't,u'; got 't,u,v'"),
    ("0,1\nt,u\n", 2, "('t' is not a number; a header naming the columns comes only first)"),
    ("t,u\nt,u\n0,1\n", 2, "a header naming the columns comes only first"),
    ("nan,1\n", 1, "expected two finite numbers"),
    ("inf,nan\n", 1, "expected two finite numbers"),
    ("0,1\n1,\n", 2, "(an empty field)"),
    ("0,1\n1,2,3\n", 2, "(3 fields)"),
    ("0,1\n1\n", 2, "(1 field)"),
    ("0,1\n2,1\n1,1\n", 3, "time 1 s is before the line above (2 s)"),
])
def test_a_row_that_is_not_two_numbers_is_an_error_with_its_line(tmp_path, text, line,
                                                                  fragment):
    path = table(tmp_path, text)
    with pytest.raises(ValueError) as raised:
        read_table(path)
    assert str(raised.value).startswith(f"{path}:{line}: ")
    assert fragment in str(raised.value)


def test_blocks_give_the_table_and_the_lines_of_the_whole_file(tmp_path, monkeypatch):
    """Read in blocks of 7 lines: the rows are those of the file read at once (numpy), and a
    problem in a later block, or a time going back across a block's edge, names its line."""
    monkeypatch.setattr(tables, "BLOCK_LINES", 7)
    rng = np.random.default_rng(4)
    rows = np.column_stack((np.cumsum(rng.random(60)), rng.normal(size=60)))
    lines = ["t,u"] + [f"{t!r},{u!r}" for t, u in rows.tolist()]
    lines.insert(20, "   # a comment inside")
    lines.insert(30, "")
    path = table(tmp_path, "\n".join(lines) + "\n")
    assert np.array_equal(read_table(path), rows)
    back = list(lines)
    back[49] = f"{rows[40, 0].item()!r},0"  # line 50 opens block 8; line 49 ends block 7
    with pytest.raises(ValueError, match=r":50: time .* is before the line above"):
        read_table(table(tmp_path, "\n".join(back) + "\n", "back.csv"))
    broken = list(lines)
    broken[54] = "1.5;2"
    with pytest.raises(ValueError, match=r":55: expected two numbers 't,u', got '1.5;2'"):
        read_table(table(tmp_path, "\n".join(broken) + "\n", "broken.csv"))


def test_reading_a_table_takes_memory_near_its_own_size(tmp_path):
    """150,000 rows (3.4 MB of text, 2.4 MB as an array): at most twice the file and the
    array together at any moment (reading the whole text and a list of rows took 12 times)."""
    n = 150_000
    t = np.arange(n) * 1e-3
    path = tmp_path / "long.csv"
    path.write_text("t,u\n" + "".join(f"{a:.4f},{np.sin(a):.6f}\n" for a in t))
    tracemalloc.start()
    try:
        rows = read_table(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert rows.shape == (n, 2) and np.array_equal(rows[:, 0], np.round(t, 4))
    assert peak < 2 * (path.stat().st_size + rows.nbytes), peak


def test_a_file_over_the_limit_is_refused_unread(tmp_path, monkeypatch):
    monkeypatch.setattr(tables, "MAX_TABLE_BYTES", 100)
    path = table(tmp_path, "0,1\n" * 30)
    with pytest.raises(ValueError, match="larger than the limit of 100 bytes"):
        read_table(path)
