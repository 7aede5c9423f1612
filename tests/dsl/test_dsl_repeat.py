"""Repetition (docs/language.md, Repetition): for loops, indexed names, structural and array
parameters and list picks expand into the model written out by hand; errors inside loops
point into the loop body and name the iteration."""

from __future__ import annotations

from dataclasses import fields, is_dataclass
from pathlib import Path

import pytest

from depsim.dsl import ModelError, format_diagnostics, parse_model, summary
from depsim.dsl.ir import Num, ParamKind, ParamRef, Span
from depsim.dsl.repeat import MAX_INSTANCES

ROOT = Path(__file__).resolve().parents[2]
BAR = "length = 0.5 m; mass = 1 kg; inertia = 0.02 kg*m^2"

LOOPED = f"""model chain
param N = 3
for i in 1..N {{
    bar link[i] {{ {BAR} }}
}}
hinge h[1] joins ground.origin to link[1].a
for i in 2..N {{
    hinge h[i] joins link[i-1].b to link[i].a {{
        angle   = (-1)^i * (link[i] - link[i-1]) + 180 deg
        damping = 0.01 * i N*m*s/rad
    }}
    cable c[i] {{ stiffness = 2 N*m/rad; angles = h[i-1] - h[i] }}
    output bend[i] = h[i]
}}
initial {{ for i in 1..N {{ h[i] = 10 deg * i }} }}
output tip = link[N].b.x
"""

BY_HAND = f"""model chain
bar link[1] {{ {BAR} }}
bar link[2] {{ {BAR} }}
bar link[3] {{ {BAR} }}
hinge h[1] joins ground.origin to link[1].a
hinge h[2] joins link[1].b to link[2].a {{
    angle   = (link[2] - link[1]) + 180 deg
    damping = 0.02 N*m*s/rad
}}
cable c[2] {{ stiffness = 2 N*m/rad; angles = h[1] - h[2] }}
output bend[2] = h[2]
hinge h[3] joins link[2].b to link[3].a {{
    angle   = -(link[3] - link[2]) + 180 deg
    damping = 0.03 N*m*s/rad
}}
cable c[3] {{ stiffness = 2 N*m/rad; angles = h[2] - h[3] }}
output bend[3] = h[3]
initial {{ h[1] = 10 deg; h[2] = 20 deg; h[3] = 30 deg }}
output tip = link[3].b.x
"""


def check(text: str):
    return parse_model(text, "m.dep")


def errors(text: str) -> ModelError:
    with pytest.raises(ModelError) as raised:
        check(text)
    return raised.value


def shape(value):
    """A model part without its spans."""
    if isinstance(value, Span):
        return None
    if isinstance(value, tuple):
        return tuple(shape(v) for v in value)
    if is_dataclass(value):
        return tuple((f.name, shape(getattr(value, f.name))) for f in fields(value))
    return value


def test_a_loop_expands_to_the_model_written_out():
    looped, by_hand = check(LOOPED), check(BY_HAND)
    for field in ("params", "derived", "bodies", "hinges", "cables", "outputs", "placements",
                  "limits"):
        assert shape(getattr(looped, field)) == shape(getattr(by_hand, field)), field
    assert [b.name for b in looped.bodies] == ["link[1]", "link[2]", "link[3]"]
    assert [h.name for h in looped.hinges] == ["h[1]", "h[2]", "h[3]"]
    assert [h.sign for h in looped.hinges] == [1, 1, -1]
    assert [o.name for o in looped.outputs] == ["bend[2]", "bend[3]", "tip"]
    damping = {p.name: p.default for p in looped.params if p.name.endswith(".damping")}
    assert damping == pytest.approx({"h[2].damping": 0.02, "h[3].damping": 0.03})


def test_structural_parameter_is_fixed_and_not_in_the_vector():
    model = check(LOOPED)
    assert [(s.name, s.value) for s in model.structural] == [("N", 3)]
    assert "N" not in {p.name for p in model.params}
    assert "structural (loop bounds and indices" in summary(model)
    assert "N = 3" in summary(model)


def test_a_parameter_used_only_in_values_stays_a_run_time_parameter():
    model = check("model m\nparam N = 4\nbar b { length = 1 m; mass = 8 kg / N; "
                  "inertia = 1 kg*m^2 }\n")
    assert model.structural == ()
    assert model.params[0].name == "N" and model.params[0].kind is ParamKind.DECLARED


def test_structural_value_is_used_in_expressions():
    model = check(f"model m\nparam N = 4\nfor i in 1..N {{ bar b[i] {{ {BAR} }} }}\n"
                  "bar total { length = 1 m; mass = 0.5 kg * N; inertia = 1 kg*m^2 }\n")
    assert model.bodies[-1].mass == ParamRef(len(model.params) - 2)
    assert model.params[-2].name == "total.mass" and model.params[-2].default == 2.0


def test_nested_loops_and_bounds_from_the_outer_variable():
    model = check("model m\nfor i in 1..3 {\n for j in i..3 {\n  output o[i][j] = t * j\n"
                  " }\n}\n")
    assert [o.name for o in model.outputs] == ["o[1][1]", "o[1][2]", "o[1][3]", "o[2][2]",
                                               "o[2][3]", "o[3][3]"]


def test_empty_range_repeats_nothing():
    model = check(f"model m\nparam N = 1\nbar b[1] {{ {BAR} }}\n"
                  "for i in 2..N { hinge h[i] joins b[i-1].b to b[i].a }\n")
    assert model.hinges == ()


def test_loops_in_blocks_repeat_points_and_initial_values():
    model = check(f"""model m
body rake {{
    mass = 2 kg; inertia = 0.1 kg*m^2
    for k in 1..3 {{ point tooth[k] = (0.1 * k, 0) m }}
}}
for k in 1..3 {{
    bar tine[k] {{ {BAR} }}
    hinge t[k] joins rake.tooth[k] to tine[k].a
}}
hinge mount joins ground.origin to rake.tooth[1]
initial {{ for k in 1..3 {{ t[k] = 10 deg * k; t[k].rate = 0 rad/s }} }}
""")
    assert [p.name for p in model.bodies[0].points] == ["tooth[1]", "tooth[2]", "tooth[3]"]
    values = {p.name: p.default for p in model.params}
    assert values["rake.tooth[3].local_x"] == pytest.approx(0.3)
    assert values["t[2].initial_angle"] == pytest.approx(0.3490658503988659)


def test_array_parameter_elements_are_declared_entries():
    model = check("model m\nparam m[3] = (12.377, 9.982, 8.920) kg\n"
                  "for i in 1..3 { bar p[i] { length = 1 m; mass = m[i]; "
                  "inertia = m[i] * 1 m^2 } }\n")
    assert [(p.name, p.default, p.kind) for p in model.params[:3]] == [
        ("m[1]", 12.377, ParamKind.DECLARED), ("m[2]", 9.982, ParamKind.DECLARED),
        ("m[3]", 8.920, ParamKind.DECLARED)]
    assert model.bodies[1].mass == ParamRef(1)
    assert [d.name for d in model.derived][:2] == ["p[1].mass", "p[1].inertia"]


def test_array_size_from_a_structural_parameter_and_values_with_units():
    model = check("model m\nparam N = 2\nparam L[N] = (1 m, 200 cm)\n"
                  "for i in 1..N { bar p[i] { length = L[i]; mass = 1 kg; "
                  "inertia = 1 kg*m^2 } }\n")
    assert [(p.name, p.default) for p in model.params[:2]] == [("L[1]", 1.0), ("L[2]", 2.0)]


def test_list_pick_gives_each_copy_its_own_entry():
    model = check("model m\nfor i in 1..3 { bar p[i] { length = 1 m; "
                  "mass = (2, 3, 5)[i] kg; inertia = 1 kg*m^2 } }\n")
    assert [(p.name, p.default) for p in model.params if p.name.endswith("mass")] == [
        ("p[1].mass", 2.0), ("p[2].mass", 3.0), ("p[3].mass", 5.0)]


def test_whole_number_arithmetic_folds_exactly():
    model = check("model m\nfor i in 1..4 { output o[i] = (-1)^i * 2^(i - 1) / 4 + i }\n")
    assert [o.expr for o in model.outputs] == [Num(0.75), Num(2.5), Num(2.0), Num(6.0)]


def test_indices_may_use_structural_parameters_min_max_and_picks():
    model = check(f"model m\nparam N = 3\nfor i in 0..N {{ bar b[i] {{ {BAR} }} }}\n"
                  "output last = b[N].phi\noutput mid = b[max(1, N - 2) + (0, 1)[2]].phi\n")
    assert [o.expr.body for o in model.outputs] == [3, 2]


def test_indexed_names_in_cables_inputs_and_outputs():
    model = check(f"""model m
for i in 1..2 {{
    bar b[i] {{ {BAR} }}
    hinge h[i] joins ground.origin to b[i].a
    input T[i] torque on h[i]
    input F[i] force on b[i].b = (0, 1) N
}}
cable loop {{ stiffness = 1 N*m/rad; angles = 2*h[1] - h[2] }}
output v = b[2].b.vx
""")
    assert [i.name for i in model.inputs] == ["T[1]", "F[1]", "T[2]", "F[2]"]
    assert "F[2].y.rate" in {p.name for p in model.params}
    assert [t.hinge for t in model.cables[0].terms] == [0, 1]


# --- errors ---------------------------------------------------------------------------------


def test_error_in_a_loop_points_into_the_body_and_names_the_iteration():
    text = "model m\nfor i in 1..4 {\n    bar b[i] { length = 1 m; mass = (3 - i) kg; " \
        "inertia = 1 kg*m^2 }\n}\n"
    raised = errors(text)
    first = raised.errors[0]
    assert (first.span.line, first.span.col, first.code) == (3, 37, "E025")
    assert type(first.span) is Span
    assert first.message == "b[3].mass must be positive, got 0 kg"
    assert first.notes == ("in iteration i = 3",)
    assert raised.errors[1].notes == ("in iteration i = 4",)  # another value, another error
    printed = format_diagnostics(raised.diagnostics, text)
    assert "m.dep:3:37: error[E025]" in printed and "note: in iteration i = 3" in printed


def test_the_same_error_in_every_iteration_is_reported_once():
    raised = errors("model m\nfor i in 1..5 {\n for j in 1..2 {\n  output o[i][j] = nope\n"
                    " }\n}\n")
    assert len(raised.errors) == 1
    assert raised.errors[0].code == "E010"
    assert raised.errors[0].notes == ("in iteration i = 1, j = 1 (and 9 more iterations)",)


def test_duplicate_in_a_loop_names_both_iterations():
    raised = errors(f"model m\nfor i in 1..2 {{\n bar b {{ {BAR} }}\n}}\n")
    (error,) = raised.errors
    assert error.code == "E011"
    assert error.notes == ("in iteration i = 2", "first defined at 3:6, in iteration i = 1")


def test_ir_spans_of_repeated_elements_point_at_the_loop_body():
    model = check(LOOPED)
    assert [(b.span.line, b.span.col) for b in model.bodies] == [(4, 5)] * 3
    assert model.hinges[2].span.iteration == (("i", 3),)


@pytest.mark.parametrize("text, code, fragment", [
    ("for i in 1..2.5 { }", "E050", "a loop bound must be a whole number, got 2.5"),
    ("param k = 2 N\nfor i in 1..k { }", "E055", "'k' is a structural parameter"),
    ("output o[1.5] = t", "E051", "an index must be a whole number, got 1.5"),
    ("param m[2] = (1, 2)\noutput o = m[3]", "E052", "there is no 'm[3]'"),
    ("param m[2] = (1, 2, 3)", "E053", "has 2 elements, but 3 values are given"),
    ("for i in 1..2 { gravity = (0, 1) m/s^2 }", "E057", "cannot be repeated"),
    ("for t in 1..2 { }", "E014", "'t' is a built-in constant"),
    ("output o = (1, 2)[0]", "E052", "index 0 is out of range"),
    (f"for i in 1..{MAX_INSTANCES + 1} {{ }}", "E054", f"more than {MAX_INSTANCES}"),
])
def test_repetition_errors(text, code, fragment):
    raised = errors("model m\n" + text + "\n")
    assert any(e.code == code and fragment in e.message for e in raised.errors), \
        [(e.code, e.message) for e in raised.errors]


def test_a_thousand_bar_chain_expands_in_full():
    """1,000 repeated bars, hinges, outputs and cables expand to the model written out (how
    long checking takes is measured in bench/bench_scaling.py, not here)."""
    text = f"""model big
param N = 1000
bar link[0] {{ {BAR} }}
hinge root joins ground.origin to link[0].a
for i in 1..N {{
    bar link[i] {{ {BAR} }}
    hinge h[i] joins link[i-1].b to link[i].a {{ friction = 0.1 N*m; latch = 10 deg }}
    output bend[i] = h[i]
}}
for i in 1..N-1 {{ cable c[i] {{ stiffness = 1 N*m/rad; angles = h[i] - h[i+1] }} }}
initial {{ for i in 1..N {{ h[i] = 1 deg }} }}
"""
    model = check(text)
    assert len(model.bodies) == 1001 and len(model.cables) == 999
    assert [h.name for h in model.hinges[-2:]] == ["h[999]", "h[1000]"]
    assert model.outputs[-1].name == "bend[1000]" and len(model.outputs) == 1000


def test_a_power_of_minus_one_alternates_for_every_count_a_loop_may_reach():
    """`(-1)^i` is the number 1 or -1 for any i (a loop counts to at most 10^12), not only
    for exponents up to 64 (examples/accordion.dep with N = 65 was refused, E041)."""
    top = 10 ** 12
    model = check(f"model m\nfor i in {top - 2}..{top} {{ output o[i] = (-1)^i + 0^i + 1^i }}\n"
                  "for i in 63..66 { output s[i] = (-1)^(i + 1) * (-1)^(-i) }\n")
    assert [o.expr for o in model.outputs] == [Num(2.0), Num(0.0), Num(2.0)] + [Num(-1.0)] * 4
    text = (ROOT / "examples" / "accordion.dep").read_text()
    assert "param N = 12 " in text
    accordion = check(text.replace("param N = 12 ", "param N = 65 "))
    signs = {h.name: h.sign for h in accordion.hinges}
    assert [signs[f"h[{i}]"] for i in range(2, 66)] == [-(-1) ** i for i in range(2, 66)]
