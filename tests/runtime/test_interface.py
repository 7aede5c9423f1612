"""The model interface and the core's C structs are each defined once: Python reads the structs
from the headers (cffi), and the layout cffi computes is the C compiler's (the header itself is
rendered from the interface: tests/codegen/test_interface_header.py)."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest
from runtime_helpers import variant

from depsim.dsl import attributes
from depsim.runtime import interface, simulate
from depsim.runtime.core import SOURCE_DIR, compiler, ffi

# (struct, fields) whose layout Python reads: every struct the binding exchanges with C.
STRUCTS = {
    "dep_model": ("abi", "name", "nq", "nd", "parameter_defaults", "phi_q_rows", "t_end",
                  "dt_out", "mass_matrix", "force", "dissipation"),
    "dep_settings": ("t_end", "dt_out", "tol", "mechanics", "progress", "progress_context"),
    "dep_error": ("code", "t", "stage", "row", "joint", "residual", "what", "hint", "message"),
    "dep_result": ("n", "n_rows", "row_names", "tol", "times", "lam", "dissipated",
                   "hinge_torque", "peak_loads", "deployment", "stats", "events", "report"),
    "dep_deployment": ("n_latch_hinges", "latches", "deployed", "time", "impact_energy"),
    "dep_event": ("name", "function", "direction", "callback", "context", "multipliers"),
    "dep_event_hit": ("t", "q", "lam", "nc", "row_names", "p", "added"),
    "dep_event_response": ("stop", "q", "add", "remove", "impact", "data_names",
                           "data_values"),
    "dep_row": ("kind", "name", "joint", "hinge", "angle", "row", "value"),
    "dep_stats": ("accepted_steps", "position", "cg_iterations", "max_v_acc", "events"),
    "dep_datum": ("key", "member", "kind", "number", "text"),
}


def test_the_interface_lists_every_function_of_the_struct_in_order():
    fields = [name for name, _ in ffi().typeof("dep_model").fields]
    functions = [name for name in fields if name in interface.FUNCTION_NAMES]
    assert functions == list(interface.FUNCTION_NAMES)


def test_cffi_reads_the_structs_as_the_compiler_lays_them_out(tmp_path):
    view = ffi()
    lines = ['#include <stddef.h>', '#include <stdio.h>', '#include "depsim.h"',
             "int main(void)", "{"]
    expected = []
    for struct, fields in STRUCTS.items():
        lines.append(f'    printf("%zu\\n", sizeof({struct}));')
        expected.append(view.sizeof(struct))
        for field in fields:
            lines.append(f'    printf("%zu\\n", offsetof({struct}, {field}));')
            expected.append(view.offsetof(struct, field))
    lines += ["    return 0;", "}"]
    source = tmp_path / "layout.c"
    source.write_text("\n".join(lines) + "\n")
    program = tmp_path / "layout"
    subprocess.run([*compiler(), "-std=c99", f"-I{SOURCE_DIR / 'include'}", "-o", str(program),
                    str(source)], check=True)
    printed = subprocess.run([str(program)], capture_output=True, text=True, check=True).stdout
    assert [int(v) for v in printed.split()] == expected


def test_a_model_with_other_hinge_property_columns_is_refused(pendulum):
    """A model whose hinge_properties columns are not the core's (made for another table) is
    refused when its run starts: read as it is, its latch would silently be 'not given'."""
    swapped = ("latch_stiffness", "latch") + attributes.HINGE_PROPERTIES[2:]
    with pytest.raises(ValueError, match="hinge property 0 is 'latch_stiffness' where the "
                       "integrator reads 'latch'"):
        simulate(variant(pendulum, HINGE_PROPERTIES=swapped), t_end=0.1)
    count = len(attributes.HINGE_PROPERTIES)
    short = variant(pendulum, HINGE_PROPERTIES=attributes.HINGE_PROPERTIES[:count - 1],
                    hinge_properties=lambda p: np.full((1, count - 1), np.nan))
    with pytest.raises(ValueError, match=f"the model has {count - 1} hinge properties, the "
                       f"integrator reads {count}"):
        simulate(short, t_end=0.1)
