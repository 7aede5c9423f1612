"""Text -> syntax tree: one test per construct, with spans."""

from __future__ import annotations

import pytest

from depsim.dsl.errors import Reporter
from depsim.dsl.ir import Span
from depsim.dsl.parse import parse_source
from depsim.dsl.syntax_messages import EXAMPLES
from depsim.dsl.syntax import (AttributeItem, BinaryOp, CableStmt, CallExpr, GravityStmt,
                               GroundStmt, InitialStmt, JointStmt, MemberStmt, ModelStmt,
                               NameRef, NumberLit, OutputStmt, ParamStmt, PointItem, Quantity,
                               SimulateStmt, UnaryOp, VectorLit)


def parse(text: str):
    report = Reporter()
    source = parse_source(text, "t.dep", report)
    assert not report.diagnostics, report.diagnostics
    return source.statements


def expr(text: str):
    (statement,) = parse(f"param x = {text}\n")
    return statement.value


def test_model_statement_with_and_without_description():
    model, = parse('model intelsat5 "INTELSAT V"')
    assert model == ModelStmt(model.name, "INTELSAT V", Span("t.dep", 1, 1, 1, 29))
    assert model.name.text == "intelsat5" and model.name.span == Span("t.dep", 1, 7, 1, 16)
    assert parse("model m")[0].description == ""


def test_comments_blank_lines_and_semicolons_separate_statements():
    statements = parse("# head\n\nmodel m   # trailing\n\n; param a = 1; param b = 2\n# end")
    assert [type(s) for s in statements] == [ModelStmt, ParamStmt, ParamStmt]
    assert statements[2].span.line == 5


def test_param_statement():
    (param,) = parse("param cable_k = 4500 N/m")
    assert param.name.text == "cable_k"
    assert param.value == Quantity(NumberLit(4500.0, "4500", param.value.value.span), "N/m",
                                   Span("t.dep", 1, 22, 1, 25), Span("t.dep", 1, 17, 1, 25))


def test_numbers():
    assert [expr(t).value for t in ("1", "1.5", "2e11", ".5", "1e-3", "3.")] == \
        [1.0, 1.5, 2e11, 0.5, 1e-3, 3.0]


def test_operator_precedence_and_associativity():
    tree = expr("1 + 2 * 3 - 4 / 2")
    assert tree.op == "-" and tree.left.op == "+" and tree.left.right.op == "*"
    assert tree.right.op == "/"
    minus_power = expr("-2^2")
    assert isinstance(minus_power, UnaryOp) and minus_power.arg.op == "^"
    assert expr("(1 + 2) * 3").left.op == "+"


def test_unit_binds_to_the_whole_power():
    tree = expr("0.01835^2 N*m/rad")
    assert isinstance(tree, Quantity) and tree.unit == "N*m/rad"
    assert isinstance(tree.value, BinaryOp) and tree.value.op == "^"


def test_compound_units_are_one_token():
    assert expr("9.81 m/s^2").unit == "m/s^2"
    assert expr("0.01 N*m*s/rad").unit == "N*m*s/rad"
    assert expr("2e11 N/m^2").unit == "N/m^2"


def test_unit_after_parenthesised_expression():
    tree = expr("(L/2) m")
    assert isinstance(tree, Quantity) and tree.value.op == "/"


def test_unit_followed_by_operator_and_name():
    tree = expr("0.5 kg * r^2 / 12")
    assert tree.op == "/" and tree.left.op == "*"
    assert tree.left.left == Quantity(tree.left.left.value, "kg", tree.left.left.unit_span,
                                      tree.left.left.span)


def test_unit_names_alone_are_names():
    tree = expr("cable_k * pulley_r^2 / rad")
    assert isinstance(tree.right, NameRef) and tree.right.dotted == "rad"


def test_a_parameter_may_reuse_a_unit_name():
    statements = parse("param m = 2 kg\nparam J = m * (1 m)^2")
    right = statements[1].value
    assert right.left == NameRef(right.left.parts, right.left.span)
    assert right.right.left.unit == "m"


def test_calls_and_dotted_names():
    tree = expr("atan2(rod.b.y, rod.b.x) + min(1, 2) + h1.rate")
    call = tree.left.left
    assert isinstance(call, CallExpr) and call.func.text == "atan2" and len(call.args) == 2
    assert call.args[0].dotted == "rod.b.y"
    assert tree.right.dotted == "h1.rate"


def test_unary_plus():
    assert expr("+3").op == "+"


def test_gravity_vector_with_shared_unit():
    (gravity,) = parse("gravity = (0, -9.81) m/s^2")
    assert isinstance(gravity, GravityStmt)
    assert gravity.value.unit == "m/s^2" and isinstance(gravity.value.y, UnaryOp)


def test_gravity_vector_with_component_units():
    (gravity,) = parse("gravity = (0 m/s^2, -9.81 m/s^2)")
    assert gravity.value.unit is None and gravity.value.x.unit == "m/s^2"


def test_ground_block_with_points():
    (ground,) = parse("ground {\n    point base = (0.5, 0) m\n}")
    assert isinstance(ground, GroundStmt)
    (point,) = ground.block.items
    assert isinstance(point, PointItem) and point.name.text == "base"
    assert isinstance(point.value, VectorLit)


@pytest.mark.parametrize("kind", ["bar", "body", "beam"])
def test_member_blocks(kind):
    (member,) = parse(f"{kind} yoke {{\n  length = 1.090 m\n  mass = 2.222 kg\n}}")
    assert isinstance(member, MemberStmt) and member.kind == kind
    assert [i.name.text for i in member.block.items] == ["length", "mass"]
    assert member.span == Span("t.dep", 1, 1, 4, 2)


def test_one_line_block():
    (member,) = parse("bar b { length = 1 m; mass = 2 kg; inertia = 0.1 kg*m^2 }")
    assert len(member.block.items) == 3


def test_empty_block():
    assert parse("simulate { }")[0].block.items == ()


def test_hinge_with_and_without_block():
    hinge, bare = parse("hinge h1 joins ground.origin to yoke.a {\n angle = yoke - ground\n}\n"
                        "hinge h2 joins yoke.b to panel1.a")
    assert isinstance(hinge, JointStmt) and hinge.kind == "hinge"
    assert (hinge.a.member.text, hinge.a.point.text) == ("ground", "origin")
    assert (hinge.b.member.text, hinge.b.point.text) == ("yoke", "a")
    assert bare.block is None


def test_keywords_are_contextual():
    # 'to' and 'point' are keywords only where the grammar expects them
    hinge, = parse("hinge to joins a.point to b.to")
    assert hinge.name.text == "to" and hinge.a.point.text == "point"


def test_slider_axis_vector():
    (slider,) = parse("slider guide joins ground.origin to piston.pin { axis = (1, 0) }")
    assert slider.kind == "slider"
    assert isinstance(slider.block.items[0].value, VectorLit)


def test_cable_block():
    (cable,) = parse("cable loop1 {\n stiffness = k / rad\n angles = 2*h1 - h2\n}")
    assert isinstance(cable, CableStmt)
    assert cable.block.items[1].value.op == "-"


def test_initial_block_with_rates():
    (initial,) = parse("initial { h1 = 30 deg; h1.rate = 0 rad/s }")
    assert isinstance(initial, InitialStmt)
    rate = initial.block.items[1]
    assert isinstance(rate, AttributeItem) and rate.name.text == "h1" and rate.sub.text == "rate"


def test_simulate_block():
    (simulate,) = parse("simulate {\n t_end = 40 s\n tol = 1e-8\n dt_out = 0.05 s\n}")
    assert isinstance(simulate, SimulateStmt) and len(simulate.block.items) == 3


def test_output_statement():
    (output,) = parse("output chord2 = link2.chord + 90 deg")
    assert isinstance(output, OutputStmt) and output.name.text == "chord2"


def test_windows_line_endings():
    assert len(parse("model m\r\nparam a = 1\r\n")) == 2


def test_syntax_errors_return_none_and_report():
    report = Reporter()
    assert parse_source("model m\nparam = 1\n", "t.dep", report) is None
    assert report.diagnostics[0].code == "E001"


@pytest.mark.parametrize("label, snippet", [
    (label, snippet) for label, snippets in EXAMPLES.items() for snippet in snippets])
def test_each_example_snippet_gets_its_own_message(label, snippet):
    report = Reporter()
    assert parse_source("model m\n" + snippet, "t.dep", report) is None
    assert report.diagnostics[0].message.startswith(label + ", found ")
