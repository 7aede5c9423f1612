"""Easy mistakes and hostile input: each gets a diagnostic with its position (or a clear
error naming the limit), never a traceback, a hang or unbounded memory.

Bad-model fixtures for the same findings are in tests/dsl/errors/ (name_too_long,
latch_plain_degrees, keyword_glued_*, fullwidth_digit, tol_not_below_one,
output_division_by_zero, elements_too_many*, expression_too_deep)."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest

from depsim.dsl import (MAX_MODEL_BYTES, ModelError, check_parameters, load_model, parse_model,
                        parse_quantity, with_elements)
from depsim.dsl.members import MAX_ELEMENTS, MAX_TOTAL_ELEMENTS
from depsim.dsl.parse import MAX_EXPRESSION_DEPTH, MAX_NAME_LENGTH

ROOT = Path(__file__).resolve().parents[2]
ROD = "bar rod { length = 1 m; mass = 1 kg; inertia = 0.1 kg*m^2 }\n"
PIVOT = "hinge pivot joins ground.origin to rod.a"


def errors(text: str) -> list:
    with pytest.raises(ModelError) as raised:
        parse_model(text, "m.dep")
    return raised.value.errors


def one_error(text: str):
    found = errors(text)
    assert len(found) == 1, found
    return found[0]


def where(diagnostic) -> tuple[str, int, int]:
    return diagnostic.code, diagnostic.span.line, diagnostic.span.col


def hinge_model(block: str, initial: str = "") -> str:
    return f"model m\n{ROD}{PIVOT} {{\n{block}\n}}\n{initial}"


# --- part 3: a plain number where an angle is expected ------------------------------------


def test_latch_without_unit_warns_that_it_is_radians_and_suggests_degrees():
    model = parse_model(hinge_model("    latch = 90"), "m.dep")
    (warning,) = model.warnings
    assert where(warning) == ("W005", 4, 13)
    assert "90 rad (5157 deg)" in warning.message
    assert warning.hint.startswith("did you mean 90 deg?")


@pytest.mark.parametrize("text, position", [
    (hinge_model("    stop_max = -120"), (4, 16)),  # beyond a full turn, signed
    (hinge_model("    angle = rod - ground + 180"), (4, 28)),  # the offset of a hinge angle
    (hinge_model("    latch = 3"), (4, 13)),  # a whole number: more likely degrees
    (hinge_model("", "initial { pivot = 30 }\n"), (6, 19)),  # an initial angle
    (f"model m\n{ROD}{PIVOT}\noutput o = pivot - 90\n", (4, 20)),  # added to an angle
])
def test_plain_numbers_that_look_like_degrees_warn(text, position):
    model = parse_model(text, "m.dep")
    assert [where(w) for w in model.warnings] == [("W005", *position)]


@pytest.mark.parametrize("block", ["    latch = 90 deg", "    latch = 1.5708", "    latch = pi/2",
                                   "    latch = 2 rad", "    stop_min = 0",
                                   "    angle = rod - ground + 0.5"])
def test_angles_with_units_or_in_radians_do_not_warn(block):
    assert parse_model(hinge_model(block), "m.dep").warnings == ()


# --- ASCII only -----------------------------------------------------------------------------


@pytest.mark.parametrize("value, hint", [("\uff12", "write 2"), ("\u0663", "write 3"),
                                         ("1\u0660", "write 0")])
def test_non_ascii_digits_are_not_numbers(value, hint):
    text = f"model m\nbar rod {{ mass = {value} kg; length = 1 m; inertia = 1 kg*m^2 }}\n"
    error = one_error(text)
    assert error.code == "E001" and "non-ASCII character" in error.message
    assert "ASCII digits 0-9" in error.message and error.hint == hint
    assert (error.span.line, error.span.col) == (2, 18 + len(value) - 1)


def test_non_ascii_letters_and_lookalike_operators_are_reported_each():
    text = "model m\nparam m\u00e4ss = 1 kg\nparam k = 3 \u2212 2\n"
    found = errors(text)
    assert [where(e) for e in found] == [("E001", 2, 8), ("E001", 3, 13)]
    assert "ASCII letters" in found[0].message and found[1].hint == "write '-'"


def test_a_superscript_power_is_pointed_to_the_caret():
    error = one_error("model m\nparam area = 2 m\u00b2\noutput o = area\n")
    assert where(error) == ("E001", 2, 17) and error.hint == "write ^2"


def test_non_ascii_is_fine_in_comments_and_descriptions():
    model = parse_model('model m "Ausleger f\u00fcr 60\u00b0"  # \u00fcber\nparam k = 1 # \u2212\n'
                        "output o = k\n", "m.dep")
    assert model.description == "Ausleger f\u00fcr 60\u00b0"


def test_values_given_outside_the_model_are_ascii_too():
    with pytest.raises(ValueError, match="non-ASCII"):
        parse_quantity("\u0663")
    with pytest.raises(ValueError, match="non-ASCII"):
        parse_quantity("1.5 N*m^\uff12")


# --- keywords end at a word boundary --------------------------------------------------------


@pytest.mark.parametrize("text, position, fragment", [
    ("modelglued\n", (1, 1), "unknown statement 'modelglued'"),
    ("model m\nparamL = 1 m\n", (2, 1), "unknown statement 'paramL'"),
    ("model m\nbarrod { length = 1 m; mass = 1 kg; inertia = 1 kg*m^2 }\n", (2, 1),
     "unknown statement 'barrod'"),
    (f"model m\n{ROD}hingepivot joins ground.origin to rod.a\n", (3, 1),
     "unknown statement 'hingepivot'"),
    (f"model m\n{ROD}hinge pivot joinsground.origin to rod.a\n", (3, 13), "'joinsground'"),
    (f"model m\n{ROD}hinge pivot joins ground.origin torod.a\n", (3, 33), "'torod'"),
    (f"model m\n{ROD}{PIVOT}\noutputtheta = pivot\n", (4, 1), "unknown statement 'outputtheta'"),
])
def test_a_keyword_glued_to_a_name_is_an_error(text, position, fragment):
    error = one_error(text)
    assert where(error) == ("E001", *position) and fragment in error.message
    assert error.hint.startswith("a keyword ends at a space: write '")


def test_names_may_start_with_a_keyword():
    model = parse_model("model modelx\nparam paramL = 1 m\nbar barrod { length = paramL; "
                        "mass = 1 kg; inertia = 1 kg*m^2; point pointy = (0, 0) m }\n"
                        "hinge tohinge joins ground.origin to barrod.pointy\n"
                        "output outputs = tohinge\n", "m.dep")
    assert model.name == "modelx" and model.hinges[0].name == "tohinge"
    assert [p.name for p in model.bodies[0].points][-1] == "pointy"


def test_point_glued_to_its_name_is_an_attribute_not_a_point():
    error = one_error(f"model m\nbar rod {{ length = 1 m; mass = 1 kg; inertia = 1 kg*m^2; "
                      "pointp = (0, 0) m }\n")
    assert error.code == "E020" and "'pointp'" in error.message


# --- part 4: the model file -----------------------------------------------------------------


def file_error(path) -> str:
    with pytest.raises(ModelError) as raised:
        load_model(path)
    (diagnostic,) = raised.value.diagnostics
    assert diagnostic.code == "E002" and (diagnostic.span.line, diagnostic.span.col) == (1, 1)
    return diagnostic.message


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")
def test_a_device_is_refused_unread():
    assert "is a character device, not a model file" in file_error("/dev/zero")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_is_refused_unopened(tmp_path):
    """A writer stands ready with a valid model: reading the FIFO would load it."""
    fifo = tmp_path / "model.dep"
    os.mkfifo(fifo)
    writer = threading.Thread(target=fifo.write_text, args=("model m\n",), daemon=True)
    writer.start()
    try:
        assert "is a FIFO (named pipe), not a model file" in file_error(fifo)
    finally:  # let the writer finish: open the read end without blocking, drain it
        reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
        writer.join()
        os.read(reader, 100)
        os.close(reader)


def test_a_directory_is_refused(tmp_path):
    assert "is a directory" in file_error(tmp_path)


def test_a_file_over_the_size_limit_is_refused(tmp_path):
    path = tmp_path / "big.dep"
    path.write_bytes(b"model m\n#" + b" " * (MAX_MODEL_BYTES - 9) + b"\n")
    assert "larger than 1048576 bytes (1 MiB), the limit" in file_error(path)


def test_a_file_at_the_size_limit_is_read(tmp_path):
    path = tmp_path / "big.dep"
    path.write_bytes(b"model m\n#" + b" " * (MAX_MODEL_BYTES - 10) + b"\n")
    assert path.stat().st_size == MAX_MODEL_BYTES
    assert load_model(path).name == "m"


# --- part 4: expressions and names ----------------------------------------------------------


def test_expression_depth_limit():
    deepest = " + ".join(["1"] * MAX_EXPRESSION_DEPTH)
    assert parse_model(f"model m\nparam k = {deepest}\noutput o = k\n", "m.dep")
    error = one_error(f"model m\nparam k = {deepest} + 1\noutput o = k\n")
    assert where(error) == ("E006", 2, 11) and "more than 100 levels" in error.message


@pytest.mark.parametrize("expression", [
    "-" * 5000 + "1", " * ".join(["2"] * 5000), "2" + " ^ (2" * 70 + ")" * 70,
    "sqrt(" * 70 + "4" + ")" * 70, "(" * 10000 + "1" + ")" * 10000])
def test_deep_or_long_expressions_are_errors_not_recursion(expression):
    error = one_error(f"model m\nparam k = {expression}\noutput o = k\n")
    assert error.code == "E006"


def test_name_length_limit():
    fits = "n" * MAX_NAME_LENGTH
    assert parse_model(f"model {fits}\n", "m.dep").name == fits
    found = errors(f"model {fits}x\nparam k{fits} = 1\noutput o = k{fits}\n")
    assert [where(e) for e in found] == [("E008", 1, 7), ("E008", 2, 7), ("E008", 3, 12)]
    assert "is 65 characters long; names have at most 64" in found[0].message


def test_a_long_source_line_is_shown_as_a_window_around_the_error():
    text = "model m\nparam k = " + "1 + " * 5000 + "$\n"
    with pytest.raises(ModelError) as raised:
        parse_model(text, "m.dep")
    source_line, caret = raised.value.format().split("\n")[1:3]
    assert len(source_line) < 200 and source_line.startswith("...")
    assert source_line[len(caret) - 1] == "$"


# --- part 4: element counts -----------------------------------------------------------------


FLEX = (ROOT / "examples" / "two_link_flex.dep")


@pytest.fixture(scope="module")
def flex():
    return load_model(FLEX)


def test_element_counts_from_outside_are_checked(flex):
    assert [b.elements for b in with_elements(flex, {"link1": "8", "link2": 4}).beams] == [8, 4]
    for bad in ("99999999999999999999", "\u0663", "\uff18", "0", "-1", "8.0", str(MAX_ELEMENTS + 1),
                MAX_ELEMENTS + 1, 0, True, 8.0, "9" * 5000):
        with pytest.raises(ValueError, match=f"whole number from 1 to {MAX_ELEMENTS}"):
            with_elements(flex, {"link1": bad})
    with pytest.raises(ValueError, match="unknown beam 'link9'.*link1, link2"):
        with_elements(flex, {"link9": 2})


def test_element_count_total_is_limited():
    beam = "beam {} {{ length = 1 m; EI = 1 N*m^2; EA = 1e6 N; mass_per_length = 1 kg/m; " \
        "elements = 2 }}\n"
    model = parse_model("model m\n" + "".join(beam.format(f"b{i}") for i in range(3)), "m.dep")
    most = {"b0": MAX_ELEMENTS, "b1": MAX_TOTAL_ELEMENTS - MAX_ELEMENTS - 2}
    assert sum(b.elements for b in with_elements(model, most).beams) == MAX_TOTAL_ELEMENTS
    with pytest.raises(ValueError, match=f"{MAX_TOTAL_ELEMENTS + 1} elements in all; a model "
                       f"has at most {MAX_TOTAL_ELEMENTS}"):
        with_elements(model, {**most, "b2": 3})


# --- part 5: settings and constants decided by the text -------------------------------------


@pytest.mark.parametrize("tol, ok", [("2", False), ("1", False), ("0.5", True), ("1e-12", True)])
def test_tol_must_lie_between_0_and_1(tol, ok):
    text = f"model m\nsimulate {{ tol = {tol} }}\n"
    if ok:
        assert parse_model(text, "m.dep").simulation.tol == float(tol)
    else:
        error = one_error(text)
        assert where(error) == ("E026", 2, 18) and "tol must be less than 1" in error.message


@pytest.mark.parametrize("expression, reason", [
    ("1 / 0", "division by zero"), ("log(0)", "outside its domain"),
    ("pivot / 0", "division by zero"), ("pivot / (2 - 2)", "division by zero"),
    ("sqrt(-1) * pivot", "outside its domain"), ("exp(1000)", "too large"),
    ("rod.b.x / (0 m)", "division by zero")])
def test_an_output_with_a_constant_that_has_no_value_is_an_error(expression, reason):
    error = one_error(f"model m\n{ROD}{PIVOT}\noutput bad = {expression}\n")
    assert where(error) == ("E027", 4, 14) and reason in error.message


# --- run-time parameters held to the model's limits ------------------------------------------


PENDULUM = parse_model("model p\nparam L = 1 m\nbar rod { length = 2*L; mass = 1 kg; "
                       "inertia = L^2 * 1 kg }\n" + PIVOT + " {\n  friction = 0.1 N*m\n"
                       "  stop_min = -10 deg\n  stop_max = 80 deg\n}\n", "p.dep")


def vector(**changes) -> list[float]:
    values = {p.name: p.default for p in PENDULUM.params}
    values.update(changes)
    return [values[p.name] for p in PENDULUM.params]


def test_the_defaults_hold_every_limit():
    assert check_parameters(PENDULUM, vector()) == []
    kinds = {limit.what: limit.kind for limit in PENDULUM.limits}
    assert kinds == {"rod.length": "positive", "rod.mass": "positive",
                     "rod.inertia": "positive", "pivot.friction": "nonnegative",
                     "pivot.slip_rate": "positive", "pivot.stop_min": "below"}


def test_a_parameter_breaking_a_derived_attribute_is_named_with_it():
    assert check_parameters(PENDULUM, vector(L=-1.0), {"L": "--set L=-1"}) == [
        "rod.length must be positive, got -2 m (from --set L=-1)"]
    assert check_parameters(PENDULUM, vector(L=0.0)) == [
        "rod.length must be positive, got 0 m (from L = 0 m)",
        "rod.inertia must be positive, got 0 kg*m^2 (from L = 0 m)"]


def test_attribute_entries_and_ordered_pairs_are_checked():
    problems = check_parameters(PENDULUM, vector(**{"pivot.friction": -0.5,
                                                    "pivot.stop_min": 2.0}))
    assert problems == ["pivot.friction must not be negative, got -0.5 N*m",
                        "pivot.stop_min must be less than pivot.stop_max, got 2 rad and "
                        "1.39626 rad"]


def test_a_value_without_a_value_is_reported_not_raised():
    model = parse_model("model p\nparam a = 1 m\nparam b = 1\nbar rod { length = a / b; "
                        "mass = 1 kg; inertia = 1 kg*m^2 }\n", "p.dep")
    assert check_parameters(model, [1.0, 0.0] + [p.default for p in model.params[2:]]) == [
        "cannot evaluate rod.length: division by zero (from b = 0)"]


def test_the_vector_must_match_the_parameters():
    with pytest.raises(ValueError, match="parameter values for"):
        check_parameters(PENDULUM, [1.0])
