"""The printed diagnostic format, file errors, and collecting all errors at once."""

from __future__ import annotations

import pytest

from depsim.dsl import Diagnostic, ModelError, format_diagnostics, load_model, parse_model
from depsim.dsl.errors import did_you_mean
from depsim.dsl.ir import Span

BAR = "bar panel3 { length = 1 m; mass = 1 kg; inertia = 0.1 kg*m^2 }\n"


def errors_of(text: str) -> list[Diagnostic]:
    with pytest.raises(ModelError) as raised:
        parse_model(text, "model.dep")
    return raised.value.diagnostics


def test_format_is_header_source_line_caret_and_hint():
    text = "model m\n" + BAR + "hinge h5 joins panel4.b to panel3.a\n"
    printed = format_diagnostics(errors_of(text), text)
    assert printed == (
        "model.dep:3:16: error[E012]: unknown member 'panel4'\n"
        "hinge h5 joins panel4.b to panel3.a\n"
        "               ^~~~~~\n"
        "hint: did you mean 'panel3'?\n")


def test_duplicate_has_a_note_with_the_first_definition():
    text = "model m\n" + BAR + "param panel3 = 2\n"
    printed = format_diagnostics(errors_of(text), text)
    assert "model.dep:3:7: error[E011]: duplicate name 'panel3': already used by bar" in printed
    assert printed.endswith("note: first defined at 2:5\n")


def test_warning_format():
    diagnostic = Diagnostic("W002", "parameter 'k' is never used", Span("m.dep", 1, 7, 1, 8))
    assert format_diagnostics([diagnostic], "param k = 1") == (
        "m.dep:1:7: warning[W002]: parameter 'k' is never used\n"
        "param k = 1\n"
        "      ^\n")


def test_caret_keeps_tabs_so_it_lines_up():
    diagnostic = Diagnostic("E010", "unknown name 'x'", Span("m.dep", 1, 3, 1, 4))
    lines = format_diagnostics([diagnostic], "\t\tx").split("\n")
    assert lines[2] == "\t\t^"


def test_caret_of_a_multi_line_span_runs_to_the_end_of_its_first_line():
    diagnostic = Diagnostic("E001", "missing '}'", Span("m.dep", 1, 5, 3, 2))
    assert format_diagnostics([diagnostic], "bar { x\n\n}").split("\n")[2] == "    ^~~"


def test_diagnostics_are_sorted_by_position():
    text = "model m\nparam b = y\nparam a = x\n"
    lines = [d.span.line for d in errors_of(text)]
    assert lines == sorted(lines) == [2, 3]


def test_all_semantic_errors_are_reported_together():
    text = ("model m\n"
            "bar yoke { length = -1 m; mass = 2; inertia = 1 kg }\n"
            "hinge h joins ground.origin to yoke.q\n"
            "output o = nothing\n")
    codes = [d.code for d in errors_of(text)]
    assert codes == ["E025", "E031", "E030", "E013", "E010"]


def test_model_error_str_lists_every_header_line():
    text = "model m\nparam a = x\nparam b = y\n"
    with pytest.raises(ModelError) as raised:
        parse_model(text, "model.dep")
    assert str(raised.value).split("\n") == [
        "model.dep:2:11: error[E010]: unknown name 'x'",
        "model.dep:3:11: error[E010]: unknown name 'y'"]
    assert raised.value.format().startswith("model.dep:2:11: error[E010]")


def test_missing_file_is_a_model_error_at_line_one(tmp_path):
    path = tmp_path / "absent.dep"
    with pytest.raises(ModelError) as raised:
        load_model(path)
    (diagnostic,) = raised.value.diagnostics
    assert diagnostic.code == "E002"
    assert (diagnostic.span.line, diagnostic.span.col) == (1, 1)
    assert "absent.dep" in diagnostic.message
    assert format_diagnostics([diagnostic], None) == f"{diagnostic_header(path)}\n"
    assert raised.value.source is None


def diagnostic_header(path) -> str:
    return f"{path}:1:1: error[E002]: cannot read '{path}': No such file or directory"


def test_nothing_to_report_formats_as_empty():
    assert format_diagnostics([], "model m") == ""


def test_directory_is_a_model_error(tmp_path):
    with pytest.raises(ModelError) as raised:
        load_model(tmp_path)
    assert raised.value.diagnostics[0].code == "E002"


@pytest.mark.parametrize("data", [b"\x89PNG\r\n\x1a\n\x00\x00", b"model m\n\xff\xfe bad\n"])
def test_binary_or_undecodable_file_is_a_model_error(tmp_path, data):
    path = tmp_path / "model.dep"
    path.write_bytes(data)
    with pytest.raises(ModelError) as raised:
        load_model(path)
    (diagnostic,) = raised.value.diagnostics
    assert diagnostic.code == "E003"
    assert (diagnostic.span.line, diagnostic.span.col) == (1, 1)


def test_utf8_with_bom_loads(tmp_path):
    path = tmp_path / "model.dep"
    path.write_bytes("\ufeffmodel m \"é\"\n".encode("utf-8"))
    assert load_model(path).description == "é"


def test_several_syntax_errors_in_one_file():
    text = "model m\nparam a 1\nparam b = 2 +\nparam c = )\nparam d = 4\n"
    errors = errors_of(text)
    assert [(d.span.line, d.code) for d in errors] == [(2, "E001"), (3, "E001"), (4, "E001")]


def test_missing_brace_is_recovered_and_later_errors_still_found():
    text = ("model m\n"
            "bar yoke {\n"
            "    length = 1 m\n"
            "bar panel { length = 1 m; mass = 1 kg; inertia = 1 kg*m^2 }\n"
            "param x 2\n")
    errors = errors_of(text)
    assert [(d.span.line, d.span.col) for d in errors] == [(2, 10), (5, 9)]
    assert "missing '}'" in errors[0].message


def test_did_you_mean():
    assert did_you_mean("panel4", ["panel3", "yoke"]) == "did you mean 'panel3'?"
    assert did_you_mean("zzz", ["panel1"]) == ""
