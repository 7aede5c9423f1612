"""A model as the integrator core sees it: one `dep_model` (runtime/c/depsim_model.h).

Both targets end here. A C target's model is compiled into a small shared library holding
its `depsim_model` (`load_folder`, `load_c_module`): a `CModule`, which also offers the
NumPy module's interface (constants, functions returning numpy arrays) evaluated in C. A
generated NumPy module is bound by `NumpyModel`: a `dep_model` whose function pointers call
the module's functions (cffi callbacks), so the same compiled core integrates it.

    binding = bind(module)        # a NumPy module or a CModule
    binding.pointer               # the `dep_model *` for dep_simulate
    binding.module                # module-like: NQ, PARAMETERS, phi(q, t, p), ...
    binding.tangents              # whether the model has the tangent functions (TANGENTS)

A model compiled with tangents has the functions of interface.TANGENTS as well: a CModule
offers them like the others, and a NumPy module's binding fills their pointers and sets
`dep_model.tangents` to 1; without them the pointers stay NULL and the flag 0.

An exception raised by a NumPy module's function cannot cross the C core: the callback fills
its results with NaN and keeps the exception (`binding.failure`), the run stops at the next
progress check and `simulate` raises it.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import importlib.util
import math
import os
import threading
from pathlib import Path
from types import ModuleType

import numpy as np

from . import interface
from .core import (MODEL_CFLAGS, CBuildError, build_shared_library, compile_objects,
                   core_library_path, ffi)

MODEL_LIBRARY = "libdepsim_model.so"
MODEL_SOURCE = "model.c"
OBJECTS = "build/objects"  # a C target folder's compiled model files, by their keys


def _text(value) -> str:
    return ffi().string(value).decode("utf-8") if value != ffi().NULL else ""


def _size(module, size: interface.Size) -> int:
    value = getattr(module, size.constant)
    return int(value) if isinstance(value, (int, np.integer)) else len(value)


# ---- a compiled C model ------------------------------------------------------------------------

class CModule:
    """The `depsim_model` of a compiled C model library, with the NumPy module's interface:
    the constants (NQ, COORDINATES, PARAMETER_DEFAULTS, ...) and the functions, evaluated by
    the C code and returning fresh numpy arrays."""

    failure = None  # C functions do not raise

    def __init__(self, library, path: str = ""):
        self.library = library
        self.__file__ = str(path)
        self.pointer = ffi().addressof(library, "depsim_model")
        m = self.pointer
        if m.abi != interface.ABI:
            raise ImportError(f"{path}: model built for interface {m.abi}, this depsim reads "
                              f"interface {interface.ABI}; compile the model again")
        for field, constant in interface.IDENTITY:
            setattr(self, constant, _text(getattr(m, field)))
        self.sizes = {s.field: int(getattr(m, s.field)) for s in interface.SIZES}
        self.NQ, self.NC, self.NP = self.sizes["nq"], self.sizes["nc"], self.sizes["np"]
        for table in interface.TABLES:
            count, values = self.sizes[table.size], getattr(m, table.field)
            read = (_text if "char" in table.ctype else
                    float if "double" in table.ctype else int)
            setattr(self, table.constant, tuple(read(values[i]) for i in range(count)))
        for field, constant in interface.SETTINGS:
            setattr(self, constant, float(getattr(m, field)))
        self.tangents = bool(getattr(m, interface.TANGENT_FLAG))
        for function in interface.FUNCTIONS + (interface.TANGENTS if self.tangents else ()):
            setattr(self, function.name, self._wrap(function))

    @property
    def module(self) -> CModule:
        return self

    def running(self):
        return contextlib.nullcontext()

    def _wrap(self, function: interface.Function):
        c_function = getattr(self.pointer, function.name)
        lengths = {"v": self.sizes["nv"], "vd": self.sizes["nv"], "q": self.NQ, "qd": self.NQ,
                   "p": self.NP, "lam": self.NC, "w": self.sizes["nw"]}
        lengths.update({interface.direction(name): n for name, n in lengths.items()})
        shapes = [tuple(self.sizes[s] for s in r.shape) for r in function.results]
        view = ffi()

        def call(*values):
            if len(values) != len(function.args):
                raise TypeError(f"{function.name}() takes {len(function.args)} arguments "
                                f"({', '.join(function.args)})")
            arguments, keep = [], []
            for name, value in zip(function.args, values):
                if name == "t":
                    arguments.append(float(value))
                    continue
                array = np.ascontiguousarray(value, dtype=float).ravel()
                if array.size != lengths[name]:
                    raise ValueError(f"{function.name}(): {name} needs {lengths[name]} values, "
                                     f"got {array.size}")
                keep.append(array)
                arguments.append(view.from_buffer("double[]", array))
            out = [np.full(shape, np.nan) for shape in shapes]  # C writes every entry
            c_function(*arguments, *[view.from_buffer("double[]", o) for o in out])
            return out[0] if len(out) == 1 else tuple(out)

        call.__name__ = function.name
        return call

    def __repr__(self) -> str:
        return f"<C model {self.MODEL_NAME!r} from {self.__file__}>"


def load_c_module(path) -> CModule:
    """Load a compiled model library (holding `depsim_model`) as a `CModule`."""
    return CModule(ffi().dlopen(str(path)), str(path))


def build_model_library(folder, flags: tuple[str, ...] | None = None) -> Path:
    """Compile the model of a C target folder (`model.c` and any `model_<function>.c`; the
    integrator is the core's) into `folder/build/<key>/libdepsim_model.so`, unless it is
    there already; `flags` default to MODEL_CFLAGS. Raises CBuildError."""
    folder = Path(folder)
    source = folder / MODEL_SOURCE
    if not source.is_file():
        from .core import CBuildError

        raise CBuildError(f"{folder} is not a depsim C target folder (no {MODEL_SOURCE})")
    sources = [source] + sorted(folder.glob("model_*.c"))
    return build_shared_library(sources, folder / "build", MODEL_LIBRARY, include=(folder,),
                                flags=MODEL_CFLAGS if flags is None else tuple(flags),
                                objects=folder / OBJECTS)


class ModelPrebuild:
    """Compiles a C target folder's generated model files (`model*.c`) in the background as
    they are written, into the objects `build_model_library` takes, while the rest of the
    model is still being generated: a large model's C compile then runs beside its lowering
    (`codegen.compile_c(..., written=prebuild)`, then `finish()`). The folder's headers must
    be written before the first file. A failure is left for the build to report."""

    def __init__(self, folder):
        self.folder = Path(folder)
        self._pool = concurrent.futures.ThreadPoolExecutor(os.cpu_count() or 1)
        self._jobs: list[concurrent.futures.Future] = []

    def __call__(self, source: Path) -> None:
        self._jobs.append(self._pool.submit(
            compile_objects, [Path(source)], self.folder / OBJECTS, MODEL_CFLAGS,
            (self.folder,)))

    def finish(self) -> None:
        """Wait for every file handed over so far."""
        self._pool.shutdown(wait=True)
        for job in self._jobs:
            if job.exception() is not None and not isinstance(job.exception(), CBuildError):
                raise job.exception()


def load_module(path) -> ModuleType:
    """Import a generated NumPy module from its file (not added to sys.modules)."""
    path = Path(path)
    spec = importlib.util.spec_from_file_location(f"depsim_generated_{path.stem}", path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot import generated module {path}")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def load_folder(folder) -> CModule:
    """Build (cached) and load the model of a C target folder; the core is built once."""
    core_library_path()
    return load_c_module(build_model_library(folder))


# ---- a NumPy module ------------------------------------------------------------------------------

class NumpyModel:
    """A generated (or hand-written) NumPy module bound to a `dep_model` whose functions call
    it. q, qd and p reach the module as lists of floats (a generated module only indexes
    them; a hand-written one may unpack or convert them); results are copied back."""

    def __init__(self, module):
        interface.check_module(module)
        self.module = module
        view = ffi()
        self._keep: list = []
        self._state = threading.local()
        self.sizes = {s.field: _size(module, s) for s in interface.SIZES}
        m = self.pointer = self._own(view.new("dep_model *"))
        m.abi = interface.ABI
        for field, constant in interface.IDENTITY:
            setattr(m, field, self._string(str(getattr(module, constant, ""))))
        for field, value in self.sizes.items():
            setattr(m, field, value)
        for table in interface.TABLES:
            values = tuple(getattr(module, table.constant))
            if len(values) != self.sizes[table.size]:
                raise TypeError(f"{module!r}: {table.constant} has {len(values)} entries, "
                                f"expected {self.sizes[table.size]}")
            setattr(m, table.field, self._table(table, values))
        for field, constant in interface.SETTINGS:
            setattr(m, field, float(getattr(module, constant)))
        # the tangents when the module has them (all: check_module), else NULL and 0
        self.tangents = interface.has_tangents(module)
        setattr(m, interface.TANGENT_FLAG, int(self.tangents))
        functions = interface.FUNCTIONS + (interface.TANGENTS if self.tangents else ())
        self.functions = {f.name: getattr(module, f.name) for f in functions}
        for function in functions:
            setattr(m, function.name, self._own(self._callback(function)))

    @property
    def failure(self) -> BaseException | None:
        """The first exception a module function raised in this thread's current run."""
        return getattr(self._state, "failure", None)

    @contextlib.contextmanager
    def running(self):
        """One run: a fresh failure and parameter list, the enclosing run's restored after it
        (a run may be started from an event callback of another)."""
        state = self._state
        outer = (getattr(state, "failure", None), getattr(state, "p_pointer", None),
                 getattr(state, "p_list", None))
        state.failure, state.p_pointer, state.p_list = None, None, None
        try:
            yield self
        finally:
            state.failure, state.p_pointer, state.p_list = outer

    def current(self) -> bool:
        """Whether the module's functions are still those this binding calls."""
        return all(getattr(self.module, name, None) is function
                   for name, function in self.functions.items())

    def _own(self, value):
        self._keep.append(value)
        return value

    def _string(self, text: str):
        return self._own(ffi().new("char[]", text.encode("utf-8")))

    def _table(self, table: interface.Table, values):
        view = ffi()
        if not values:
            return view.NULL
        if "char" in table.ctype:
            return self._own(view.new("char *[]", [self._string(str(v)) for v in values]))
        ctype = "double[]" if "double" in table.ctype else "int[]"
        return self._own(view.new(ctype, list(values)))

    def _arguments(self, function: interface.Function):
        """values -> the module's arguments: q, qd (and the other arrays, directions included)
        as lists of floats, t as is, p as the run's parameter list (converted once per run:
        the core passes one p throughout)."""
        unpack, state = ffi().unpack, self._state
        nq, nv, nc, nw = (self.sizes[k] for k in ("nq", "nv", "nc", "nw"))

        def parameters(pointer):
            if pointer != state.p_pointer:
                state.p_pointer, state.p_list = pointer, unpack(pointer, self.sizes["np"])
            return state.p_list

        lengths = {"v": nv, "vd": nv, "q": nq, "qd": nq, "p": self.sizes["np"], "lam": nc,
                   "w": nw}
        converters = {"v": lambda c: unpack(c, nv), "vd": lambda c: unpack(c, nv),
                      "q": lambda c: unpack(c, nq),
                      "qd": lambda c: unpack(c, nq), "t": None, "p": parameters,
                      "lam": lambda c: unpack(c, nc), "w": lambda c: unpack(c, nw)}
        converters.update({interface.direction(name): lambda c, n=n: unpack(c, n)
                           for name, n in lengths.items()})  # a direction: a fresh list
        steps = tuple(converters[name] for name in function.args)
        return lambda values: [c if s is None else s(c) for s, c in zip(steps, values)]

    def _callback(self, function: interface.Function):
        """A cffi callback calling the module's function; results copied back."""
        view = ffi()
        python_function = getattr(self.module, function.name)
        arguments = self._arguments(function)
        first_result = len(function.args)
        sizes = tuple(math.prod(self.sizes[s] for s in r.shape) for r in function.results)
        state, memmove, name = self._state, view.memmove, function.name

        def fail(exc: BaseException, outputs) -> None:  # kept for simulate(); the core sees NaN
            record(exc)
            for out, size in zip(outputs, sizes):
                for k in range(size):
                    out[k] = math.nan

        def record(exc: BaseException) -> None:
            if getattr(state, "failure", None) is None:
                state.failure = exc

        def deliver(out, value, size: int) -> None:
            if value.__class__ is not np.ndarray or value.dtype != np.float64 \
                    or not value.flags.c_contiguous:
                value = np.ascontiguousarray(value, dtype=np.float64)
            if value.size != size:
                raise ValueError(f"{name}() returned {value.size} values, expected {size}")
            memmove(out, value, 8 * size)

        if len(sizes) == 1:
            size = sizes[0]

            def call(*values):  # deliver() inlined: this runs for every evaluation
                try:
                    value = python_function(*arguments(values))
                    if value.__class__ is not np.ndarray or value.size != size \
                            or value.dtype != np.float64 or not value.flags.c_contiguous:
                        deliver(values[first_result], value, size)
                    else:
                        memmove(values[first_result], value, 8 * size)
                except BaseException as exc:
                    fail(exc, values[first_result:])
        else:
            def call(*values):
                try:
                    returned = python_function(*arguments(values))
                    for out, value, size in zip(values[first_result:], returned, sizes):
                        deliver(out, value, size)
                except BaseException as exc:
                    fail(exc, values[first_result:])

        # onerror: an exception raised before `call` enters its try (Ctrl-C arrives at the
        # first instruction of a callback) is recorded too, never printed and lost
        return view.callback(f"void(*)({interface.c_declaration(function)})", call,
                             onerror=lambda kind, exc, trace: record(exc))

    def __repr__(self) -> str:
        return f"<NumPy model {self.sizes and getattr(self.module, 'MODEL_NAME', '?')!r}>"


def bind(module) -> CModule | NumpyModel:
    """The binding of a module for the core: a CModule is its own; a NumPy module's is built
    once and kept on the module object (`__depsim_binding__`) while it lives (built again
    when a function of the module was replaced)."""
    if isinstance(module, (CModule, NumpyModel)):
        return module
    binding = getattr(module, "__depsim_binding__", None)
    if binding is None or binding.module is not module or not binding.current():
        binding = NumpyModel(module)
        with contextlib.suppress(AttributeError, TypeError):
            module.__depsim_binding__ = binding
    return binding


__all__ = ["CModule", "NumpyModel", "bind", "load_c_module", "load_folder",
           "build_model_library", "ModelPrebuild", "MODEL_LIBRARY"]
