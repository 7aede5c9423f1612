"""depsim.codegen: checked model -> symbolic system (derive) -> view-models (lower) -> code (emit).

Public API: `derive`, `compile_numpy`, `numpy_source`, `load_generated`, `CodegenError`,
`SymbolicSystem`; the C target: `compile_c`, `c_sources` (docs/c-target.md)."""

from .c_emit import c_sources, compile_c
from .derive import SymbolicSystem, derive
from .emit import compile_numpy, load_generated, numpy_source
from .errors import CodegenError

__all__ = ["CodegenError", "SymbolicSystem", "c_sources", "compile_c", "compile_numpy", "derive",
           "load_generated", "numpy_source"]
