"""Every broken model in tests/dsl/errors/ reports what its header says.

Each file starts with one or more lines `# expect: LINE:COL CODE message fragment`; every one
must match a diagnostic exactly in position and code, and contain the fragment. E codes must
raise ModelError; W codes must load, with the warning in Model.warnings."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from depsim.dsl import ModelError, format_diagnostics, load_model
from depsim.dsl.errors import CODES

ERRORS = Path(__file__).parent / "errors"
FILES = sorted(ERRORS.glob("*.dep"))
EXPECT = re.compile(r"# expect: (\d+):(\d+) ([EW]\d{3}) (.+)")


def expectations(path: Path) -> list[tuple[int, int, str, str]]:
    found = []
    for line in path.read_text(encoding="utf-8").splitlines():
        match = EXPECT.fullmatch(line.strip())
        if not match:
            break
        found.append((int(match[1]), int(match[2]), match[3], match[4]))
    return found


def test_corpus_is_large_enough():
    assert len(FILES) >= 45


@pytest.mark.parametrize("path", FILES, ids=[f.stem for f in FILES])
def test_broken_model_reports_expected_diagnostic(path: Path):
    expected = expectations(path)
    assert expected, f"{path.name} has no '# expect:' header"
    if any(code.startswith("E") for _, _, code, _ in expected):
        with pytest.raises(ModelError) as raised:
            load_model(path)
        diagnostics = raised.value.diagnostics
        text = format_diagnostics(diagnostics, path.read_text(encoding="utf-8"))
    else:
        diagnostics = list(load_model(path).warnings)
        text = format_diagnostics(diagnostics, path.read_text(encoding="utf-8"))
    for line, col, code, fragment in expected:
        assert code in CODES
        hits = [d for d in diagnostics if (d.span.line, d.span.col, d.code) == (line, col, code)]
        assert hits, f"no {code} at {line}:{col} in:\n{text}"
        assert any(fragment in d.message for d in hits), f"'{fragment}' not in:\n{text}"
        assert f"{path}:{line}:{col}: " in text


def test_every_error_code_has_a_broken_model():
    used = {code for path in FILES for _, _, code, _ in expectations(path)}
    untested = set(CODES) - used - {"E002", "E003"}  # file errors: test_dsl_diagnostics.py
    assert not untested, sorted(untested)
