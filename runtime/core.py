"""The integrator core: the C sources in runtime/c, built once into a shared library, and
their C interface seen from Python.

Every run of every model goes through this one library (docs/method.md): the C target hands
it a compiled model's `dep_model`, the NumPy target one whose functions call the generated
module (`depsim.runtime.binding`). It is built with the machine's C compiler on first use
and kept in the cache, keyed by its sources, the compiler and the flags:

    <cache>/core/<key>/libdepsim_core.so        <cache>: $DEPSIM_CACHE, else ~/.cache/depsim

The C structs are read by cffi from the headers themselves (depsim_model.h, depsim.h): no
second definition of any field in Python.

The sources are laid out in layers (runtime/c/README.md), named here once for every build that
takes them (this library, a C target folder, an FMU): each layer's folder holds one header that
includes only the layer below it.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import functools
import hashlib
import importlib.util
import io
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

SOURCE_DIR = Path(__file__).resolve().parent / "c"
HEADERS = ("include/depsim_model.h", "include/depsim.h")  # the public interface, include order
LAYERS = ("base", "algebra", "system", "method", "mechanics", "run")  # bottom up
LIBRARY_SOURCE = "targets/library.c"  # the public interface's entry points (depsim.h)
# The targets built beside a generated model (a C target folder, an FMU) and placed next to
# its model.h there: they include "model.h" and "core/include/depsim.h".
# The standalone program: its entry point (main.c, the options) and the files only it uses
# (program.h; the output files, the JSON summary, the --input time tables).
PROGRAM_SOURCES = ("targets/program/main.c", "targets/program/program.h",
                   "targets/program/program_output.c", "targets/program/program_summary.c",
                   "targets/program/program_tables.c")
FMU_SOURCES = ("targets/fmu/fmi2.c", "targets/fmu/fmi2_variables.c", "targets/fmu/fmi2_state.c",
               "targets/fmu/fmi2.h", "targets/fmu/fmu.h")
CORE_FOLDER = "core"  # where a C target folder or an FMU's sources/ hold the files of core_files()
# -fno-math-errno: sqrt is the instruction, not a libm call that may set errno (nothing reads
# it); 4 % faster on INTELSAT V and two_link_flex, outputs bit for bit the same.
CFLAGS = ("-O2", "-fno-math-errno", "-std=c99")
# The generated model's files add -fno-tree-slp-vectorize: gcc's SLP vectoriser (on at -O2
# since gcc 12) pairs a long function's scalar operations into vector ones, and allocating
# registers for what it made takes most of the compile (a 30-body spatial chain's
# hinge_gamma: 16.5 CPU s with it, 3.3 without). The runs are as fast (INTELSAT V, the
# slider-crank, the flexible links, a spatial chain) and the same bit for bit: it does not
# reorder arithmetic. (clang reads it as -fno-slp-vectorize.)
MODEL_EXTRA_CFLAGS = ("-fno-tree-slp-vectorize",)
MODEL_CFLAGS = CFLAGS + MODEL_EXTRA_CFLAGS
# -Wl,-Bsymbolic (ELF linkers): a call from one of the library's files to a function of another
# goes straight there, not through the PLT as a symbol another library could replace; INTELSAT
# V's runs 4 % faster in the library, the same numbers bit for bit. (macOS's linker binds so
# already and has no such option.)
SHARED_FLAGS = ("-fPIC", "-shared") + (("-Wl,-Bsymbolic",) if sys.platform.startswith("linux")
                                       else ())
CORE_LIBRARY = "libdepsim_core.so"

NO_COMPILER = ("no C compiler found: depsim builds its integrator with one (once, into its "
               "cache); install one (Debian/Ubuntu: apt install gcc; Fedora: dnf install gcc; "
               "macOS: xcode-select --install) or set CC to a compiler's path")


class CBuildError(RuntimeError):
    """The C compiler is missing or failed (message: what to install, or its output)."""


def cache_root() -> Path:
    """Where depsim keeps what it builds: $DEPSIM_CACHE, else $XDG_CACHE_HOME/depsim, else
    ~/.cache/depsim; the system's temporary folder when none of these can be created."""
    configured = os.environ.get("DEPSIM_CACHE")
    if configured:
        return Path(configured)
    home = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    root = Path(home) / "depsim"
    try:
        root.mkdir(parents=True, exist_ok=True)
        if os.access(root, os.W_OK):
            return root
    except OSError:
        pass
    user = os.getuid() if hasattr(os, "getuid") else "user"
    return Path(tempfile.gettempdir()) / f"depsim-{user}"


def compiler() -> tuple[str, ...]:
    """The C compiler command: $CC when set, else cc, gcc or clang on the PATH; CBuildError
    naming what to install when there is none."""
    chosen = os.environ.get("CC", "").strip()
    if chosen:
        if shutil.which(chosen.split()[0]) is None:
            raise CBuildError(f"CC is set to '{chosen}', which is not a program here; "
                              "set CC to an installed C compiler, or unset it to use cc")
        return tuple(chosen.split())
    for candidate in ("cc", "gcc", "clang"):
        if shutil.which(candidate):
            return (candidate,)
    raise CBuildError(NO_COMPILER)


@functools.cache
def _compiler_identity(cc: tuple[str, ...]) -> str:
    try:
        run = subprocess.run([*cc, "--version"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError) as exc:
        raise CBuildError(f"the C compiler '{' '.join(cc)}' does not run: {exc}") from None
    lines = run.stdout.splitlines()
    return f"{shutil.which(cc[0])}|{lines[0] if lines else ''}"


def build_shared_library(sources: list[Path], target_dir: Path, name: str,
                         flags: tuple[str, ...] = CFLAGS, include: tuple[Path, ...] = (),
                         objects: Path | None = None) -> Path:
    """Compile `sources` into `target_dir/<key>/<name>` unless it is there already; the key
    hashes the sources and every header beside them, the compiler and the flags. Returns the
    library's path. The sources compile to objects in parallel (one compiler per CPU), then
    link; `objects`: a folder keeping the objects by their own keys (compile_objects), where
    those compiled before are taken (else they go to a scratch folder). The file is written
    under a temporary name and renamed, so concurrent builders never load a partial library.
    Raises CBuildError."""
    cc = compiler()
    all_flags = tuple(flags) + SHARED_FLAGS
    digest = hashlib.sha256()
    for part in (_compiler_identity(cc), " ".join(all_flags)):
        digest.update(part.encode() + b"\0")
    headers = _headers(sources, include)
    for path in sorted(sources) + headers:
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    target = Path(target_dir) / digest.hexdigest()[:20] / name
    if target.exists():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as scratch:
        built = compile_objects(sources, Path(scratch) if objects is None else objects, flags,
                                include, name)
        partial = Path(scratch) / name
        run_compilers([[*cc, *all_flags, "-o", str(partial), *map(str, built), "-lm"]], name)
        os.replace(partial, target)
    return target


def _headers(sources: list[Path], include: tuple[Path, ...]) -> list[Path]:
    """The headers a build of `sources` may read: those beside them and in `include`."""
    return sorted({h for folder in {s.parent for s in sources} | set(include)
                   for pattern in ("*.h", "*.inc") for h in Path(folder).glob(pattern)})


def compile_objects(sources: list[Path], folder: Path, flags: tuple[str, ...] = CFLAGS,
                    include: tuple[Path, ...] = (), what: str = "") -> list[Path]:
    """Each source compiled (position-independent) into `folder/<key>.o` unless that is there
    already, in parallel, the longest first; the key hashes the compiler, the flags, the
    source and the headers beside it and in `include` (their contents, not where they are:
    a folder renamed keeps its objects). Returns the objects in the order of `sources`.
    Raises CBuildError (`what`: what was being built, else the sources' names)."""
    cc = compiler()
    common = hashlib.sha256()
    for part in (_compiler_identity(cc), " ".join(flags)):
        common.update(part.encode() + b"\0")
    for path in _headers(sources, include):
        common.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    objects, commands = [], []
    for source in sources:
        key = common.copy()
        key.update(source.read_bytes())
        target = folder / f"{source.stem}-{key.hexdigest()[:20]}.o"
        objects.append(target)
        if not target.exists():
            partial = target.with_name(f".{target.name}.{os.getpid()}.{threading.get_ident()}")
            commands.append(([*cc, *flags, "-fPIC", *[f"-I{f}" for f in include], "-c", "-o",
                              str(partial), str(source)], partial, target))
    commands.sort(key=lambda c: -Path(c[0][-1]).stat().st_size)  # the longest start first
    try:
        run_compilers([command for command, _, _ in commands], what or ", ".join(
            Path(c[0][-1]).name for c in commands))
        for _, partial, target in commands:
            os.replace(partial, target)
    finally:
        for _, partial, _ in commands:
            partial.unlink(missing_ok=True)
    return objects


def run_compilers(commands: list[list[str]], what: str, cwd: Path | None = None) -> None:
    """Run compiler commands, as many at once as there are CPUs; CBuildError with the
    failing command and its output (`what`: what was being built)."""

    def run(command: list[str]) -> None:
        try:
            done = subprocess.run(command, cwd=cwd, capture_output=True, text=True)
        except OSError as exc:
            raise CBuildError(f"the C compiler '{command[0]}' does not run: {exc}") from None
        if done.returncode != 0:
            raise CBuildError(f"building {what} failed:\n$ {' '.join(command)}\n"
                              f"{done.stdout}{done.stderr}".rstrip())

    workers = min(len(commands), os.cpu_count() or 1)
    with concurrent.futures.ThreadPoolExecutor(max(workers, 1)) as pool:
        list(pool.map(run, commands))


def core_files() -> list[str]:
    """Every file of the core library, as paths relative to runtime/c: the public headers, each
    layer's header and sources, the entry points (not the program's or the FMU's)."""
    files = list(HEADERS)
    for layer in LAYERS:
        files += sorted(path.relative_to(SOURCE_DIR).as_posix()
                        for path in (SOURCE_DIR / layer).iterdir()
                        if path.suffix in (".c", ".h", ".inc"))
    return files + [LIBRARY_SOURCE]


def core_sources() -> list[Path]:
    """The core library's C files."""
    return [SOURCE_DIR / name for name in core_files() if name.endswith(".c")]


_FIRST_USE = threading.RLock()


def _once(function):
    """Call `function` once per process and keep its value; the first call is made under a
    lock, so threads starting together get one FFI (cdata of two FFI instances do not mix)."""
    done: list = []

    @functools.wraps(function)
    def call():
        if not done:
            with _FIRST_USE:
                if not done:
                    done.append(function())
        return done[0]

    return call


@_once
def core_library_path() -> Path:
    """The core library, built on first use (see the module docstring)."""
    return build_shared_library(core_sources(), cache_root() / "core", CORE_LIBRARY,
                                include=(SOURCE_DIR / "include",))


def _declarations(text: str) -> str:
    """A header as cffi reads it: preprocessor lines (with their continuation lines) dropped
    except `#define NAME <integer>`."""
    text = re.sub(r"\\\n", " ", text)
    return re.sub(r"^\s*#(?!\s*define\s+\w+\s+\d+\b).*$", "", text, flags=re.MULTILINE)


@_once
def ffi():
    """The cffi view of the core's headers (structs, enums, functions) and of a compiled
    model's `depsim_model` symbol: cffi's out-of-line ABI module of the declarations, kept in
    the cache keyed by them and cffi's version, <cache>/ffi/_depsim_ffi_<key>.py. Importing
    it takes 2 ms where parsing the headers (`FFI.cdef`) took 80 ms in every process, a
    study's worker processes too."""
    import cffi

    text = "".join(_declarations((SOURCE_DIR / h).read_text(encoding="utf-8")) for h in HEADERS)
    text += "\nextern dep_model depsim_model;\n"
    key = hashlib.sha256(f"{cffi.__version__}\n{text}".encode()).hexdigest()[:20]
    name = f"_depsim_ffi_{key}"
    path = cache_root() / "ffi" / f"{name}.py"
    try:
        if not path.is_file():
            _write_ffi_module(text, name, path)
        try:
            return _import_ffi_module(name, path)
        except Exception:  # a damaged file in the cache: written again
            _write_ffi_module(text, name, path)
            return _import_ffi_module(name, path)
    except OSError:  # a cache that cannot be written: the headers parsed here
        view = cffi.FFI()
        view.cdef(text)
        return view


def _import_ffi_module(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.ffi


def _write_ffi_module(text: str, name: str, path: Path) -> None:
    """cffi's out-of-line ABI module of `text`, written under a temporary name and renamed
    (processes starting together each write a whole file)."""
    import cffi

    view = cffi.FFI()
    view.cdef(text)
    view.set_source(name, None)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    with contextlib.redirect_stdout(io.StringIO()):  # cffi says "generating <file>"
        view.emit_python_code(str(tmp))
    os.replace(tmp, path)


@_once
def core():
    """The loaded core library (built on first use)."""
    return ffi().dlopen(str(core_library_path()))


__all__ = ["CBuildError", "cache_root", "compiler", "build_shared_library", "compile_objects",
           "run_compilers",
           "core_files", "core_sources", "core_library_path", "ffi", "core", "SOURCE_DIR",
           "CFLAGS", "MODEL_CFLAGS", "MODEL_EXTRA_CFLAGS", "LAYERS", "PROGRAM_SOURCES", "FMU_SOURCES", "CORE_FOLDER"]
