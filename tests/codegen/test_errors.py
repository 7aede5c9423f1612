"""User-caused codegen failures raise CodegenError with a code and the element's span;
programmer mistakes in lowering raise LoweringError."""

from __future__ import annotations

from dataclasses import replace

import pytest
import sympy

import handmade
from depsim.codegen import CodegenError, derive
from depsim.codegen.lower import FunctionSpec, lower_function
from depsim.codegen.printing import LoweringError, PythonPrinter
from depsim.dsl import ir

SPAN = ir.Span("bad.dep", 7, 3, 7, 9)


def test_parameter_named_like_time():
    model = handmade.pendulum()
    model = replace(model, params=(replace(model.params[0], name="t", span=SPAN),
                                   model.params[1]))
    with pytest.raises(CodegenError) as error:
        derive(model)
    assert error.value.code == "E902" and error.value.span == SPAN


def test_joint_at_a_point_a_beam_does_not_have(monkeypatch):
    import fake_beam

    monkeypatch.setitem(__import__("sys").modules, "depsim.codegen.beam", fake_beam)
    model = handmade.beam_chain()
    hinge = model.hinges[1]
    model = replace(model, hinges=(model.hinges[0], replace(hinge, b=replace(hinge.b,
                                                                             point="middle"))))
    with pytest.raises(CodegenError) as error:
        derive(model)
    assert error.value.code == "E903" and "'middle'" in error.value.message


def test_unknown_body_point():
    model = handmade.pendulum()
    hinge = replace(model.hinges[0], b=replace(model.hinges[0].b, point="c"))
    with pytest.raises(CodegenError) as error:
        derive(replace(model, hinges=(hinge,)))
    assert error.value.code == "E904" and "no point 'c'" in error.value.message


def test_lowering_rejects_a_symbol_that_is_not_an_input():
    system = derive(handmade.pendulum())
    spec = FunctionSpec("broken", ("p",), "depends on q but takes only p",
                        (("y", sympy.ImmutableMatrix([[system.q[0] * system.p[0]]])),))
    with pytest.raises(LoweringError, match="broken: expression depends on rod.x"):
        lower_function(system, spec, PythonPrinter)


def test_printer_rejects_unknown_symbols():
    printer = PythonPrinter({sympy.Symbol("a"): "p[0]"})
    assert printer.doprint(sympy.Symbol("a") * 2) == "2*p[0]"
    with pytest.raises(LoweringError):
        printer.doprint(sympy.Symbol("b"))
