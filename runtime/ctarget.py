"""The C target's Python side: build a C target folder into a shared library (cached), and
see the compiled model through ctypes.

`build_library(folder)` compiles every `.c` of a folder written by
`depsim.codegen.compile_c` except the program's `main.c` with
`cc -O2 -std=c99 -fPIC -shared ... -lm`, into `folder/build/<key>/libdepsim_model.so`; the key
hashes the sources (which carry the model's SHA-256 and the depsim version), the compiler
and its flags, so a changed model, depsim or flag builds anew and an unchanged one is reused.

`CModule` has the interface of a generated NumPy module (docs/generated-module.md): the same
constants and functions, evaluated by the C code. `CModel` mirrors runtime/c/depsim_model.h.

ctypes (standard library) rather than cffi: no extra dependency and no compiler needed at
import; the interface is a handful of plain structs and pointers."""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import tempfile
from ctypes import POINTER, c_char_p, c_double, c_int
from pathlib import Path

import numpy as np

CFLAGS = ("-O2", "-std=c99")
SHARED_FLAGS = ("-fPIC", "-shared")
LIBRARY_NAME = "libdepsim_model.so"
PROGRAM_SOURCE = "main.c"


ABI = 1  # DEP_MODEL_ABI of runtime/c/depsim_model.h


class CBuildError(RuntimeError):
    """The C compiler is missing or failed on a C target folder (message: its output)."""


_P = POINTER(c_double)
_ARGS = {"q": _P, "qd": _P, "t": c_double, "p": _P}

# Each function of the model: (arguments, result shapes from the sizes); docs/generated-module.md.
FUNCTIONS = (
    ("mass_matrix", ("p",), (("nq", "nq"),)),
    ("initial_state", ("p",), (("nq",), ("nq",))),
    ("phi", ("q", "t", "p"), (("nc",),)),
    ("phi_q", ("q", "t", "p"), (("nnz",),)),
    ("phi_t", ("q", "t", "p"), (("nc",),)),
    ("gamma", ("q", "qd", "t", "p"), (("nc",),)),
    ("force", ("q", "qd", "t", "p"), (("nq",),)),
    ("hinge_angles", ("q", "p"), (("nh",),)),
    ("hinge_rates", ("q", "qd", "p"), (("nh",),)),
    ("hinge_jacobian", ("q", "p"), (("nh", "nq"),)),
    ("hinge_gamma", ("q", "qd", "p"), (("nh",),)),
    ("hinge_properties", ("p",), (("nh", "nhp"),)),
    ("outputs", ("q", "qd", "t", "p"), (("nout",),)),
    ("energy", ("q", "qd", "t", "p"), (("ne",),)),
    ("dissipation", ("q", "qd", "t", "p"), (("nd",),)),
)
SIZES = ("nq", "nc", "np", "nnz", "nh", "nhp", "ns", "nout", "ne", "nd")
NAME_TABLES = (  # (dep_model field, module constant, size)
    ("coordinate_names", "COORDINATES", "nq"), ("parameter_names", "PARAMETERS", "np"),
    ("parameter_units", "PARAMETER_UNITS", "np"), ("constraint_names", "CONSTRAINTS", "nc"),
    ("constraint_joints", "CONSTRAINT_JOINTS", "nc"), ("hinge_names", "HINGES", "nh"),
    ("hinge_property_names", "HINGE_PROPERTIES", "nhp"), ("slider_names", "SLIDERS", "ns"),
    ("output_names", "OUTPUTS", "nout"), ("output_units", "OUTPUT_UNITS", "nout"),
    ("energy_names", "ENERGIES", "ne"), ("dissipator_names", "DISSIPATORS", "nd"),
)


def _function_type(args, results):
    return ctypes.CFUNCTYPE(None, *[_ARGS[a] for a in args], *[_P for _ in results])


class CModel(ctypes.Structure):
    """runtime/c/depsim_model.h `dep_model`, field by field."""

    _fields_ = ([("abi", c_int)]
                + [(name, c_char_p) for name in ("name", "description", "source_file",
                                                 "source_sha256", "depsim_version")]
                + [(name, c_int) for name in SIZES]
                + [("coordinate_names", POINTER(c_char_p)),
                   ("parameter_names", POINTER(c_char_p)),
                   ("parameter_defaults", _P),
                   ("parameter_units", POINTER(c_char_p)),
                   ("constraint_names", POINTER(c_char_p)),
                   ("constraint_joints", POINTER(c_char_p)),
                   ("phi_q_rows", POINTER(c_int)), ("phi_q_cols", POINTER(c_int)),
                   ("hinge_names", POINTER(c_char_p)),
                   ("hinge_property_names", POINTER(c_char_p)),
                   ("slider_names", POINTER(c_char_p)),
                   ("output_names", POINTER(c_char_p)), ("output_units", POINTER(c_char_p)),
                   ("energy_names", POINTER(c_char_p)),
                   ("dissipator_names", POINTER(c_char_p))]
                + [(name, c_double) for name in ("t_end", "tol", "dt_out")]
                + [(name, _function_type(args, results)) for name, args, results in FUNCTIONS])


def _text(value: bytes | None) -> str:
    return (value or b"").decode("utf-8")


def _array(values) -> ctypes.Array:
    """Any float sequence as a fresh contiguous double buffer (the C side never keeps it)."""
    flat = np.ascontiguousarray(values, dtype=float).ravel()
    return flat.ctypes.data_as(_P), flat


class CModule:
    """The `depsim_model` of a loaded library with the NumPy module's interface: constants
    (NQ, COORDINATES, PARAMETER_DEFAULTS, ...) and functions returning fresh numpy arrays."""

    def __init__(self, library: ctypes.CDLL, path: str = ""):
        self.library = library
        self.__file__ = str(path)
        self.model = CModel.in_dll(library, "depsim_model")
        if self.model.abi != ABI:
            raise ImportError(f"{path}: model built for interface {self.model.abi}, "
                              f"this depsim reads interface {ABI}; rebuild it")
        m = self.model
        self.MODEL_NAME, self.DESCRIPTION = _text(m.name), _text(m.description)
        self.SOURCE_FILE, self.SOURCE_SHA256 = _text(m.source_file), _text(m.source_sha256)
        self.DEPSIM_VERSION = _text(m.depsim_version)
        self.sizes = {name: int(getattr(m, name)) for name in SIZES}
        self.NQ, self.NC, self.NP = self.sizes["nq"], self.sizes["nc"], self.sizes["np"]
        for field, constant, size in NAME_TABLES:
            table = getattr(m, field)
            setattr(self, constant, tuple(_text(table[i]) for i in range(self.sizes[size])))
        count = self.sizes["np"]
        self.PARAMETER_DEFAULTS = tuple(float(m.parameter_defaults[i]) for i in range(count))
        nnz = self.sizes["nnz"]
        self.PHI_Q_ROWS = tuple(int(m.phi_q_rows[i]) for i in range(nnz))
        self.PHI_Q_COLS = tuple(int(m.phi_q_cols[i]) for i in range(nnz))
        self.T_END, self.TOL, self.DT_OUT = float(m.t_end), float(m.tol), float(m.dt_out)
        for name, args, results in FUNCTIONS:
            setattr(self, name, self._wrap(name, args, results))

    def _wrap(self, name, args, results):
        function = getattr(self.model, name)
        shapes = [tuple(self.sizes[s] for s in shape) for shape in results]

        def call(*values):
            if len(values) != len(args):
                raise TypeError(f"{name}() takes {len(args)} arguments ({', '.join(args)})")
            keep, converted = [], []
            for arg, value in zip(args, values):
                if arg == "t":
                    converted.append(float(value))
                else:
                    pointer, buffer = _array(value)
                    keep.append(buffer)
                    converted.append(pointer)
            out = [np.full(shape, np.nan) for shape in shapes]  # C writes every entry
            function(*converted, *[o.ctypes.data_as(_P) for o in out])
            return out[0] if len(out) == 1 else tuple(out)

        call.__name__ = name
        return call

    def __repr__(self) -> str:
        return f"<C model {self.MODEL_NAME!r} from {self.__file__}>"


def load_c_module(path) -> CModule:
    """Load a shared library holding a generated `depsim_model` (its integrator may be left
    out) as a module-like `CModule`."""
    return CModule(ctypes.CDLL(str(path)), str(path))


def compiler() -> str:
    """The C compiler: $CC, else `cc`, else `gcc`; CBuildError when there is none."""
    for candidate in (os.environ.get("CC"), "cc", "gcc"):
        if candidate and shutil.which(candidate.split()[0]):
            return candidate
    raise CBuildError("no C compiler found: install one (cc or gcc) or set CC")


def _build_key(sources: list[Path], cc: str, flags: tuple[str, ...]) -> str:
    digest = hashlib.sha256()
    version = subprocess.run([*cc.split(), "--version"], capture_output=True, text=True)
    for part in (cc, version.stdout.splitlines()[:1], " ".join(flags)):
        digest.update(repr(part).encode() + b"\0")
    for path in sources:
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:20]


def build_library(folder, flags: tuple[str, ...] = CFLAGS) -> Path:
    """Compile the C target folder's library (cached; see the module docstring) and return
    its path. Raises CBuildError with the compiler's output when the build fails."""
    folder = Path(folder)
    sources = sorted(p for p in folder.glob("*.c") if p.name != PROGRAM_SOURCE)
    headers = sorted(folder.glob("*.h"))
    if not any(p.name == "model.c" for p in sources):
        raise CBuildError(f"{folder} is not a depsim C target folder (no model.c)")
    cc = compiler()
    all_flags = tuple(flags) + SHARED_FLAGS
    target = folder / "build" / _build_key(sources + headers, cc, all_flags) / LIBRARY_NAME
    if target.exists():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, partial = tempfile.mkstemp(dir=target.parent, suffix=".so.tmp")
    os.close(fd)
    command = [*cc.split(), *all_flags, "-o", partial, *map(str, sources), "-lm"]
    run = subprocess.run(command, capture_output=True, text=True, cwd=folder)
    if run.returncode != 0:
        os.unlink(partial)
        raise CBuildError(f"building {folder} failed:\n$ {' '.join(command)}\n"
                          f"{run.stdout}{run.stderr}")
    os.replace(partial, target)  # atomic: concurrent builders never load a partial file
    return target


def load_folder(folder, flags: tuple[str, ...] = CFLAGS) -> CModule:
    """Build (cached) and load a C target folder: the module-like `CModule` that
    `depsim.runtime.clib.simulate` runs."""
    return load_c_module(build_library(folder, flags))
