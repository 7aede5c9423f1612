"""depsim_model.h, the C side of the model interface, rendered from its one definition: the
sizes, tables and functions of depsim.runtime.interface and the hinge properties the
integrator applies (depsim.dsl.attributes, the hinge's attributes with a column). The header
in runtime/c/include is exactly this text (tests/runtime/test_interface.py):

    python -m depsim.codegen.interface_header > runtime/c/include/depsim_model.h

The core reads a hinge property by its enum, so a property renamed or moved in the table
changes the enum and the core no longer compiles until it follows; a model whose columns are
not the core's is refused when a run starts (system/hinges.c), never read as "not given".
"""

from __future__ import annotations

from depsim.dsl.attributes import SPECS
from depsim.dsl.limits import LIMIT_KINDS
from depsim.runtime.interface import (ABI, FUNCTIONS, IDENTITY, SETTINGS, SIZES, TABLES,
                                      TANGENT_FLAG, TANGENTS, c_declaration)

HEAD = """\
/* depsim_model.h: what the integrator needs from a model. GENERATED from
 * depsim/runtime/interface.py, depsim/dsl/attributes.py and depsim/dsl/limits.py
 * (python -m depsim.codegen.interface_header); do not edit.
 *
 * A generated model.c defines one `const dep_model depsim_model` filled with its
 * sizes, name tables and functions; a NumPy module is seen through the same struct.
 * The functions have the names of docs/generated-module.md (prefixed `model_` in
 * model.h) and its argument order; the result arrays come last and are written
 * completely (zeros included). Arrays hold doubles in SI units: q, qd: nq; p: np;
 * t: time (s). Matrices are row-major. Empty tables are NULL.
 */
#ifndef DEPSIM_MODEL_H
#define DEPSIM_MODEL_H
"""


def hinge_property_enum() -> list[str]:
    """enum dep_hinge_property: the columns of hinge_properties, and their names."""
    columns = sorted((spec for spec in SPECS["hinge"] if spec.column is not None),
                     key=lambda spec: spec.column)
    lines = ["/* The columns of hinge_properties (HINGE_PROPERTIES): the hinge attributes the",
             "   integrator applies itself (docs/language.md, hinge), SI; nan where not given. */",
             "enum dep_hinge_property {"]
    lines += [f"    DEP_HINGE_{spec.name.upper()} = {spec.column}, /* {spec.unit} */"
              for spec in columns]
    lines += [f"    DEP_HINGE_PROPERTIES = {len(columns)} /* their count: every model's nhp */",
              "};", "/* Their names, in column order (an initializer of const char *[]). */",
              "#define DEP_HINGE_PROPERTY_NAMES \\"]
    lines += [f'    {"{" if k == 0 else " "}"{spec.name}"{"," if k < len(columns) - 1 else "}"}'
              + (" \\" if k < len(columns) - 1 else "") for k, spec in enumerate(columns)]
    return lines


def limit_kind_enum() -> list[str]:
    """enum dep_limit_kind: what a range check of the parameters (limit_kinds) asks of its
    value, in the order of depsim.dsl.limits.LIMIT_KINDS."""
    lines = ["/* What a range check of the parameters asks of its value (limit_kinds; the",
             "   model text's checks, depsim.dsl.limits). */", "enum dep_limit_kind {"]
    lines += [f"    DEP_LIMIT_{kind.upper()} = {k}," for k, kind in enumerate(LIMIT_KINDS)]
    lines[-1] = lines[-1].rstrip(",")
    return lines + ["};"]


def render_header() -> str:
    """runtime/c/include/depsim_model.h."""
    lines = HEAD.splitlines() + [
        "",
        f"#define DEP_MODEL_ABI {ABI} /* bumped whenever this struct changes */",
        "",
        *hinge_property_enum(),
        "",
        *limit_kind_enum(),
        "",
        "typedef struct dep_model {",
        "    int abi; /* DEP_MODEL_ABI of the header the model was compiled with */",
        "",
        "    /* identity */",
    ]
    lines += [f"    const char *{field};" for field, _ in IDENTITY]
    lines += ["", "    /* sizes */"]
    lines += [f"    int {s.field}; /* {s.meaning} */" for s in SIZES]
    lines += [f"    int {TANGENT_FLAG}; /* 1: the tangent functions below are generated, 0: they "
              "are NULL */"]
    lines += ["", "    /* tables (NULL when empty) */"]
    for t in TABLES:
        ctype = t.ctype.replace("const char *const", "const char *const *").replace(
            "const double", "const double *").replace("const int", "const int *")
        note = f"{t.size}" + (f", {t.note}" if t.note else "")
        lines.append(f"    {ctype}{'' if ctype.endswith('*') else ' '}{t.field}; /* {note} */")
    lines += ["", "    /* the model's simulation settings */",
              "    double " + ", ".join(f for f, _ in SETTINGS) + ";", "",
              "    /* functions (docs/generated-module.md) */"]
    for f in FUNCTIONS:
        lines.append(f"    /* {f.summary} */")
        lines.append(f"    void (*{f.name})({c_declaration(f)});")
    lines += ["", "    /* tangents (docs/generated-module.md): NULL unless the model was compiled "
              "with them */"]
    for f in TANGENTS:
        lines.append(f"    /* {f.summary} */")
        lines.append(f"    void (*{f.name})({c_declaration(f)});")
    lines += ["} dep_model;", "", "#endif /* DEPSIM_MODEL_H */", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    print(render_header(), end="")
