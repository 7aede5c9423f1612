"""The model interface's C header and the hinge property table are each defined once
(depsim.runtime.interface, depsim.dsl.attributes.SPECS): depsim_model.h is rendered from them,
the core reads hinge properties by the header's enum, and every copy of the table (the IR, the
generated module's columns, the language reference) is compared with it here."""

from __future__ import annotations

import dataclasses
import re
import subprocess
from pathlib import Path

from depsim.codegen import interface_header
from depsim.dsl import attributes, ir
from depsim.runtime.core import SOURCE_DIR, compiler, ffi

DOCS = Path(__file__).resolve().parents[2] / "docs"


def hinge_specs():
    return attributes.SPECS["hinge"]


def test_the_header_is_rendered_from_the_tables():
    text = (SOURCE_DIR / "include" / "depsim_model.h").read_text(encoding="utf-8")
    assert text == interface_header.render_header(), \
        "run: python -m depsim.codegen.interface_header > runtime/c/include/depsim_model.h"


def test_the_enum_is_the_columns_of_hinge_properties():
    """The core's enum (read from the header by cffi) numbers each property with its column
    in the table, and the generated modules' columns are those."""
    enum = ffi().typeof("enum dep_hinge_property").relements
    for spec in hinge_specs():
        if spec.column is not None:
            assert enum[f"DEP_HINGE_{spec.name.upper()}"] == spec.column
    assert enum["DEP_HINGE_PROPERTIES"] == len(attributes.HINGE_PROPERTIES)
    columns = {spec.column: spec.name for spec in hinge_specs() if spec.column is not None}
    assert attributes.HINGE_PROPERTIES == tuple(columns[k] for k in sorted(columns))


def test_the_ir_carries_every_hinge_attribute():
    """ir.Hinge has a field per attribute (the angle becomes sign and offset)."""
    fields = {field.name for field in dataclasses.fields(ir.Hinge)}
    for spec in hinge_specs():
        assert spec.name == "angle" or spec.name in fields, spec.name
    assert {"sign", "offset"} <= fields


def test_the_language_reference_shows_the_table():
    text = (DOCS / "language.md").read_text(encoding="utf-8")
    marker = "<!-- the hinge attributes: made from depsim.dsl.attributes (SPECS) -->\n"
    assert marker in text
    shown = text.split(marker, 1)[1].split("\n\n", 1)[0] + "\n"
    assert shown == attributes.hinge_attribute_table(), \
        "docs/language.md: paste depsim.dsl.attributes.hinge_attribute_table()"
    generated = (DOCS / "generated-module.md").read_text(encoding="utf-8")
    listed = re.search(r"\| `HINGE_PROPERTIES` \| tuple\[str\] \| columns of `hinge_properties`: "
                       r"(.*) \|\n", generated).group(1)
    assert re.findall(r'`"(\w+)"`', listed) == list(attributes.HINGE_PROPERTIES)


def test_a_renamed_property_does_not_build(tmp_path, monkeypatch):
    """Renaming a property in the table (and rendering the header) leaves the core's sources
    naming an enum that no longer exists: the build fails, the physics never reads NaN."""
    renamed = tuple(dataclasses.replace(spec, name="lock") if spec.name == "latch" else spec
                    for spec in hinge_specs())
    monkeypatch.setitem(attributes.SPECS, "hinge", renamed)
    include = tmp_path / "include"
    include.mkdir()
    (include / "depsim_model.h").write_text(interface_header.render_header())
    (include / "depsim.h").write_text((SOURCE_DIR / "include" / "depsim.h").read_text())
    core = tmp_path / "core"
    for layer in ("base", "algebra", "system"):
        (core / layer).mkdir(parents=True)
        for path in (SOURCE_DIR / layer).iterdir():
            text = path.read_text(encoding="utf-8").replace('"../include/', '"../../include/')
            (core / layer / path.name).write_text(text)
    build = subprocess.run([*compiler(), "-std=c99", "-c", "-o", str(tmp_path / "hinges.o"),
                            str(core / "system" / "hinges.c")], capture_output=True, text=True)
    assert build.returncode != 0
    assert "DEP_HINGE_LATCH" in build.stderr


def test_the_ir_carries_every_slider_attribute():
    """ir.Slider has a field per attribute; its property columns are the hinge's."""
    fields = {field.name for field in dataclasses.fields(ir.Slider)}
    for spec in attributes.SPECS["slider"]:
        assert spec.name in fields, spec.name
        if spec.column is not None:
            assert attributes.HINGE_PROPERTIES[spec.column] == spec.name


def test_the_language_reference_shows_the_slider_table():
    text = (DOCS / "language.md").read_text(encoding="utf-8")
    marker = "<!-- the slider attributes: made from depsim.dsl.attributes (SPECS) -->\n"
    assert marker in text
    shown = text.split(marker, 1)[1].split("\n\n", 1)[0] + "\n"
    assert shown == attributes.hinge_attribute_table("slider"), \
        "docs/language.md: paste depsim.dsl.attributes.hinge_attribute_table('slider')"
