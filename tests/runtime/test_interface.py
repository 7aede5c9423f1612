"""The model interface and the core's C structs are each defined once: depsim_model.h is
rendered from depsim.runtime.interface, Python reads the structs from the headers (cffi), and
the layout cffi computes is the C compiler's."""

from __future__ import annotations

import subprocess

from depsim.runtime import interface
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


def test_the_model_header_is_rendered_from_the_interface_table():
    text = (SOURCE_DIR / "include" / "depsim_model.h").read_text(encoding="utf-8")
    assert text == interface.render_header(), \
        "run: python -m depsim.runtime.interface > runtime/c/include/depsim_model.h"


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
