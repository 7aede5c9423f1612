"""emit: render view-models through jinja2 and write the generated module.

Output is byte-for-byte reproducible: no timestamps, no absolute paths, fixed ordering."""

from __future__ import annotations

import hashlib
import importlib.metadata
import re
from pathlib import Path
from types import ModuleType

import jinja2

from depsim.dsl import ir
from depsim.runtime.binding import load_module

from .derive import SymbolicSystem, derive
from .lower import ModuleView, lower_module
from .printing import IeeePrinter, PythonPrinter

# The version every generated file names (pyproject.toml's, as installed).
DEPSIM_VERSION = importlib.metadata.version("depsim")

ENVIRONMENT = jinja2.Environment(
    loader=jinja2.PackageLoader("depsim.codegen", "templates"),
    undefined=jinja2.StrictUndefined,
    trim_blocks=True,
    lstrip_blocks=True,
    keep_trailing_newline=True,
    autoescape=False,
)
# Python literals of plain data (str, int, float and tuples of them).
ENVIRONMENT.filters["py"] = repr


def _docstring_text(text: str) -> str:
    """User text made safe inside a triple-quoted docstring."""
    return " ".join(text.replace("\\", "\\\\").replace('"""', '\\"\\"\\"').split())


ENVIRONMENT.filters["doc"] = _docstring_text


def render_numpy(view: ModuleView) -> str:
    """The NumPy module's source text for a lowered model."""
    return ENVIRONMENT.get_template("numpy_module.py.j2").render(m=view)


def numpy_source(model: ir.Model, system: SymbolicSystem | None = None,
                 tangents: bool = False) -> str:
    """A model's NumPy module source (derived here unless `system` is given); no file written.
    `tangents`: with the tangent functions too (docs/generated-module.md, Tangents)."""
    view = lower_module(model, system or derive(model), PythonPrinter, DEPSIM_VERSION,
                        ieee_printer=IeeePrinter, tangents=tangents)
    return render_numpy(view)


MAX_FILE_STEM = 64


def module_file_stem(name: str) -> str:
    """The NumPy module's file name (without `.py`) for a model name: the name itself when it
    is an identifier of at most MAX_FILE_STEM characters, else its letters, digits and `_`
    cut short, with a hash of the whole name so different names stay different files."""
    if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name) and len(name) <= MAX_FILE_STEM:
        return name
    digest = hashlib.sha256(name.encode("utf-8")).hexdigest()[:12]
    return f"{re.sub(r'[^A-Za-z0-9_]', '_', name)[:MAX_FILE_STEM - 13]}_{digest}"


def compile_numpy(model: ir.Model, out_dir: Path, system: SymbolicSystem | None = None,
                  tangents: bool = False) -> Path:
    """Write `out_dir/<model name>.py` (`module_file_stem`), the model's standalone NumPy
    module; return its path. `system`: an already derived SymbolicSystem of the model, to
    skip derivation. `tangents`: with the tangent functions (interface.TANGENTS), which
    forward sensitivities need; without them by default."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{module_file_stem(model.name)}.py"
    path.write_text(numpy_source(model, system, tangents), encoding="utf-8", newline="\n")
    return path


def load_generated(path: Path) -> ModuleType:
    """Import a generated module from its file (not added to sys.modules)."""
    return load_module(path)
