"""Model text that checks but used to break code generation: an output with
no finite value once its terms cancel, names too long for a file, and the deepest expression
the checker lets through."""

from __future__ import annotations

from dataclasses import replace

import pytest

import handmade
from depsim.codegen import CodegenError, compile_numpy, derive, load_generated, numpy_source
from depsim.codegen.c_emit import c_sources
from depsim.codegen.emit import MAX_FILE_STEM, module_file_stem
from depsim.dsl import ir, parse_model
from depsim.dsl.parse import MAX_EXPRESSION_DEPTH

SPAN = ir.Span("bad.dep", 9, 1, 9, 30)
PENDULUM = ("model p\nbar rod { length = 1 m; mass = 1 kg; inertia = 0.1 kg*m^2 }\n"
            "hinge pivot joins ground.origin to rod.a\n")


@pytest.mark.parametrize("expression", ["1 / (pivot - pivot)", "log(rod.b.x / rod.b.x - 1)",
                                        "(pivot - pivot) ^ -1"])
def test_an_output_without_a_finite_value_is_a_codegen_error(expression):
    model = parse_model(PENDULUM + f"output bad = {expression}\n", "bad.dep")
    model = replace(model, outputs=(replace(model.outputs[0], span=SPAN),))
    with pytest.raises(CodegenError) as error:
        derive(model)
    assert error.value.code == "E905" and error.value.span == SPAN
    assert str(error.value).startswith("bad.dep:9:1: error[E905]: output 'bad' has no finite")


def test_a_constant_without_a_value_never_reaches_the_printers():
    """`output bad = 1 / 0` is refused by the checker (E027), so both printers only ever see
    finite numbers; a finite output of the same shape prints in C and Python."""
    model = parse_model(PENDULUM + "output fine = 1 / 2 + log(1) + pivot\n", "ok.dep")
    system = derive(model)
    assert "zoo" not in numpy_source(model, system)
    assert "zoo" not in c_sources(model, system)["model.c"]


def test_the_deepest_expression_allowed_goes_through_both_printers():
    count = MAX_EXPRESSION_DEPTH - 5  # each term adds a level; sin(k * pivot) three more
    deep = " - ".join(f"sin({k} * pivot)" for k in range(1, count + 1))
    model = parse_model(PENDULUM + f"output deep = {deep}\noutput nested = "
                        + "sin(" * 60 + "pivot" + ")" * 60 + "\n", "deep.dep")
    system = derive(model)
    assert "def outputs" in numpy_source(model, system)
    assert "outputs" in c_sources(model, system)["model.c"]


@pytest.mark.parametrize("name", ["a" * 300, "../../escape", "x" * MAX_FILE_STEM + "y", "9lives"])
def test_module_file_names_are_bounded_and_stay_in_the_folder(tmp_path, name):
    model = replace(handmade.pendulum(), name=name)
    path = compile_numpy(model, tmp_path / "out")
    assert path.parent == tmp_path / "out" and len(path.name) <= MAX_FILE_STEM + 3
    assert load_generated(path).MODEL_NAME == name


def test_module_file_stems_keep_plain_names_and_tell_long_ones_apart():
    assert module_file_stem("pendulum") == "pendulum"
    assert module_file_stem("a" * MAX_FILE_STEM) == "a" * MAX_FILE_STEM
    long_names = ["a" * 300, "a" * 301, "a" * 200 + "b"]
    stems = {module_file_stem(name) for name in long_names}
    assert len(stems) == 3 and all(len(s) == MAX_FILE_STEM for s in stems)
