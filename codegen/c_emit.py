"""C target: the model's functions as C99 (templates/c/), beside the C integrator (runtime/c/).

`compile_c(model, out_dir)` writes a self-contained folder that `make -C out_dir` builds with a
C compiler and libm only (docs/c-target.md):

    model.c, model.h       the generated functions and the `depsim_model` description
    model_<name>.c         a long function of a large model, in a file of its own
    main.c, program*       the standalone program (runtime/c/targets/program)
    core/                  the integrator core as runtime/c lays it out (copied unchanged;
                           never generated per model)
    Makefile               builds the program `<name>` and the library `lib<name>.so`

Same SymbolicSystem, same CSE lowering (`lower.lower_module`) as the NumPy module, printed by
`CPrinter`; the C view-model here only adds what C needs (parameter declarations, unused
arguments, zero fills, literal tables). Emission is byte-for-byte reproducible."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from depsim.dsl import ir

from depsim.runtime import interface
from depsim.runtime.core import (CFLAGS, CORE_FOLDER, MODEL_EXTRA_CFLAGS, PROGRAM_SOURCES,
                                 SOURCE_DIR, core_files)

from .c_printer import CPrinter, c_comment, c_double, c_file_stem, c_string
from .derive import SymbolicSystem, derive
from .emit import DEPSIM_VERSION, ENVIRONMENT
from .lower import Call, FunctionView, KernelView, ModuleView, lower_module

# One Environment (emit.ENVIRONMENT's settings and loader), with the C literal filters.
C_ENVIRONMENT = ENVIRONMENT.overlay()
C_ENVIRONMENT.filters.update(c_string=c_string, c_comment=c_comment, c_double=c_double)

# A function whose expressions are longer than this many characters goes into a file of its own,
# model_<name>.c: a C compiler's optimisation passes take time growing faster than a function's
# length, and separate files compile in parallel (`make -j`, and depsim's own builds). Small
# models keep everything in model.c.
OWN_FILE_CHARS = 50_000
# A value a function stores into this many entries of one result or more is stored by a loop
# over a table of those entries: a C compiler's dead-store and alias passes take time growing
# about as the square of a function's stores into one array (a 100-body spatial chain's
# coordinate scales, 1,200 stores of two values: 1.9 CPU s of gcc -O2 as single stores).
REPEATED_STORES = 8
_INTERFACE = {f.name: f for f in interface.FUNCTIONS + interface.TANGENTS}
PROGRAM = "main.c"  # the program's entry point in the folder, left out of the library
# The program's files in the folder (main.c and those only it uses), left out of the library.
PROGRAM_FILES = tuple(Path(name).name for name in PROGRAM_SOURCES)



@dataclass(frozen=True)
class CStatement:
    """`const double name = value;` (a temporary, `result` empty) or `result[flat] = value;`,
    or a kernel's call as its lines (`lines`, the others empty)."""

    result: str
    name: str
    value: str
    note: str
    lines: tuple[str, ...] = ()


@dataclass(frozen=True)
class CKernel:
    """`static void name(declaration)`: a kind of blocks' kernel (lower.KernelView)."""

    name: str
    declaration: str
    statements: tuple[CStatement, ...]


@dataclass(frozen=True)
class CResult:
    name: str
    size: int
    fill: str  # "" or the value every entry gets first ("0.0": some are structurally zero,
    # and results are written completely, as NumPy's start from zeros; "NAN": most are not
    # given, as in hinge_properties), the entries holding it then left out


@dataclass(frozen=True)
class CFunction:
    name: str
    declaration: str  # "const double *q, double t, const double *p, double *phi"
    summary: str
    unused: tuple[str, ...]  # parameters the body never reads: `(void)name;`
    results: tuple[CResult, ...]
    statements: tuple[CStatement, ...]
    kernels: tuple[CKernel, ...] = ()

    @property
    def length(self) -> int:
        """Characters of its body's names and expressions (and its kernels')."""
        return sum(len(s.name) + len(s.value) + sum(map(len, s.lines))
                   for s in self.statements + tuple(s for k in self.kernels
                                                    for s in k.statements))


@dataclass(frozen=True)
class CFile:
    """One generated .c file: its name and functions; `main`: it holds the tables and the
    `depsim_model` struct (model.c)."""

    name: str
    functions: tuple[CFunction, ...]
    main: bool


@dataclass(frozen=True)
class CPrototype:
    """A model function's declaration in model.h."""

    name: str
    summary: str
    declaration: str


@dataclass(frozen=True)
class CHeader:
    """What model.h holds, known before any function is lowered: the sizes (dep_model field,
    value; the tangents flag last) and the functions' prototypes."""

    sizes: tuple[tuple[str, int], ...]
    prototypes: tuple[CPrototype, ...]


@dataclass(frozen=True)
class CTable:
    """A constant table of the model: `static const <ctype> <name>[] = {values}` or NULL."""

    field: str  # member of dep_model
    name: str
    ctype: str
    values: tuple[str, ...]  # C literals

    @property
    def reference(self) -> str:
        return self.name if self.values else "NULL"


@dataclass(frozen=True)
class CModuleView:
    m: ModuleView
    stem: str  # program and library name
    sizes: tuple[tuple[str, int], ...]  # (dep_model field, value), the tangents flag last
    tables: tuple[CTable, ...]
    functions: tuple[CFunction, ...]
    files: tuple[CFile, ...]  # model.c, then model_<name>.c for each long function
    library_sources: tuple[str, ...]  # .c files of the library (model*.c and the integrator)
    model_objects: tuple[str, ...]  # the objects of the generated model*.c (MODEL_CFLAGS)
    program_sources: tuple[str, ...]  # the program's own .c files but main.c
    headers: tuple[str, ...]  # every header the sources include (make's dependencies)


def core_folder_files() -> dict[str, Path]:
    """The integrator's files a C target folder holds: their names in the folder (`main.c`,
    `program_*.c`, `core/...`) and their sources in runtime/c (installed as package data of
    depsim.runtime)."""
    files = {f"{CORE_FOLDER}/{name}": SOURCE_DIR / name for name in core_files()}
    files.update({Path(name).name: SOURCE_DIR / name for name in PROGRAM_SOURCES})
    return files


def _uses(texts: list[str], arg: str) -> bool:
    pattern = re.compile(rf"\b{arg}\b" if arg == "t" else rf"\b{arg}\[")
    return any(pattern.search(text) for text in texts)


def _call_lines(call: Call, results) -> tuple[str, ...]:
    """A kernel's call: the groups not passed as pointers gathered into arrays of their
    group's name, the outputs written in place or through `out`, in a block of their own."""
    lines = [f"const double {group}[{len(values)}] = {{{', '.join(values)}}};"
             for (group, values), pointer in zip(call.args, call.pointers) if pointer is None]
    args = [pointer or group for (group, _), pointer in zip(call.args, call.pointers)]
    if call.out is None:
        lines.append(f"double out[{len(call.outputs)}];")
    lines.append(f"{call.kernel}({', '.join(args + [call.out or 'out'])});")
    if call.out is None:
        operator = "+=" if call.accumulate else "="
        lines += [f"{results[r].name}[{flat}] {operator} out[{k}];"
                  for k, (r, flat) in enumerate(call.outputs)]
    if len(lines) == 1:
        return tuple(lines)
    return ("{",) + tuple(f"    {line}" for line in lines) + ("}",)


def _kernel(k: KernelView) -> CKernel:
    groups = [f"const double *restrict {group}" for group, _ in k.groups]
    statements = tuple(
        CStatement("", s.assignment.name, s.assignment.value, "") if s.result < 0
        else CStatement("out", str(s.entry.flat), s.entry.value, "") for s in k.statements)
    return CKernel(k.name, ", ".join(groups + ["double *restrict out"]), statements)


def c_function(f: FunctionView) -> CFunction:
    """The C view of one lowered function."""
    texts = [a.value for a in f.temporaries] + [e.value for r in f.results for e in r.entries]
    texts += [", ".join(values) + "," + (pointer or "") for s in f.statements if s.call
              for (_, values), pointer in zip(s.call.args, s.call.pointers)]
    texts += [f"{arg}[" for *_, args in f.computed for arg in args]
    unused = [a for a in f.args if not _uses(texts, a)]
    results = []
    for r in f.results:
        size = 1
        for extent in r.shape:
            size *= extent
        undefined = sum(e.value == "NAN" for e in r.entries)
        fill = "0.0" if len(r.entries) + r.kernel_entries < size \
            else "NAN" if 2 * undefined > size else ""
        results.append(CResult(r.name, size, fill))
        if size == 0:  # an empty result (no dissipators, no outputs): nothing to write
            unused.append(r.name)
    computed = tuple(CStatement("", "", "", "", (
        f"double {array}[{size}];", f"model_{function}({', '.join(args + (array,))});"))
        for array, size, function, args in f.computed)
    statements = computed + tuple(
        CStatement("", "", "", "", _call_lines(s.call, f.results)) if s.call is not None else
        CStatement("", s.assignment.name, s.assignment.value, "") if s.result < 0 else
        CStatement(f.results[s.result].name, str(s.entry.flat), s.entry.value,
                   "" if len(s.entry.index) == 1
                   else f"  /* [{s.entry.index[0]}][{s.entry.index[1]}] */")
        for s in f.statements
        if s.result < 0 or not (results[s.result].fill == "NAN" and s.entry.value == "NAN"))
    statements = _gather_repeated(statements, f)
    declaration = interface.c_declaration(_INTERFACE[f.name], restrict=True)
    return CFunction(f.name, declaration, f.summary, tuple(unused), tuple(results), statements,
                     tuple(map(_kernel, f.kernels)))


def _gather_repeated(statements: tuple[CStatement, ...], f: FunctionView
                     ) -> tuple[CStatement, ...]:
    """The stores of one value into REPEATED_STORES or more entries of one result replaced by
    one loop over a table of the entries, where the first of them was (its value is defined
    there; no statement reads a result, and a kernel's call writes none of these entries)."""
    called = {(f.results[r].name, flat) for s in f.statements if s.call is not None
              for r, flat in s.call.outputs}
    groups: dict[tuple[str, str], list[int]] = {}
    for k, s in enumerate(statements):
        if s.result and not s.lines and (s.result, int(s.name)) not in called:
            groups.setdefault((s.result, s.value), []).append(k)
    loops = {}
    for (result, value), places in groups.items():
        if len(places) >= REPEATED_STORES:
            loops[places[0]] = _store_loop(result, value, [statements[k].name for k in places])
            loops.update((k, None) for k in places[1:])
    return tuple(loops[k] if k in loops else s for k, s in enumerate(statements)
                 if loops.get(k, s) is not None)


def _store_loop(result: str, value: str, entries: list[str]) -> CStatement:
    rows = [", ".join(entries[k:k + 16]) for k in range(0, len(entries), 16)]
    lines = ([f"static const int at[{len(entries)}] = {{"] + [f"    {row}," for row in rows]
             + ["};", f"for (int k = 0; k < {len(entries)}; ++k) {{",
                f"    {result}[at[k]] = {value};", "}"])
    return CStatement("", "", "", "", ("{",) + tuple(f"    {line}" for line in lines) + ("}",))


_LITERALS = {"const char *const": c_string, "const double": c_double, "const int": str}


def _tables(m: ModuleView) -> tuple[CTable, ...]:
    return tuple(CTable(t.field, t.constant, t.ctype, tuple(map(_LITERALS[t.ctype], t.values)))
                 for t in m.tables)


def c_header(view: ModuleView) -> CHeader:
    """model.h's content from the module's header (its functions need not be lowered)."""
    sizes = tuple((field, value) for field, _, value in view.sizes) + (
        (interface.TANGENT_FLAG, int(view.tangents)),)
    functions = interface.FUNCTIONS + (interface.TANGENTS if view.tangents else ())
    return CHeader(sizes, tuple(CPrototype(f.name, f.summary,
                                           interface.c_declaration(f, restrict=True))
                                for f in functions))


class _Files:
    """The model's functions packed into files as they are lowered, each file handed to
    `put(name, text)` as soon as it is complete (model.h before them): a function longer
    than OWN_FILE_CHARS in a file of its own, model_<name>.c; shorter ones gathered in
    order until they are longer together, then written as model_<first>.c. Those left at
    the end go into model.c with the tables and the `depsim_model` struct (all of a small
    model's)."""

    def __init__(self, put):
        self.put = put
        self.functions: list[CFunction] = []
        self.files: list[CFile] = []  # the complete ones, in order
        self.group: list[CFunction] = []

    def add(self, header: ModuleView, f: FunctionView) -> None:
        if not self.functions:
            self.put("model.h", C_ENVIRONMENT.get_template("c/model.h.j2").render(
                c=c_header(header), m=header))
        function = c_function(f)
        self.functions.append(function)
        if function.length > OWN_FILE_CHARS:
            self._close(header, (function,))
            return
        self.group.append(function)
        if sum(g.length for g in self.group) > OWN_FILE_CHARS:
            self._close(header, tuple(self.group))
            self.group = []

    def _close(self, header: ModuleView, functions: tuple[CFunction, ...]) -> None:
        file = CFile(f"model_{functions[0].name}.c", functions, False)
        self.files.append(file)
        self.put(file.name, C_ENVIRONMENT.get_template("c/model.c.j2").render(
            m=header, file=file))


def c_view(view: ModuleView, runtime_files: tuple[str, ...], functions: tuple[CFunction, ...],
           split: tuple[CFile, ...]) -> CModuleView:
    """The C target's view-model of a lowered module; `runtime_files`: the integrator's file
    names in the folder (core_folder_files); `functions`: its functions' C views, `split`:
    the files those not in model.c went into (_Files)."""
    m = view
    apart = {f.name for file in split for f in file.functions}
    files = (CFile("model.c", tuple(f for f in functions if f.name not in apart), True),) \
        + split
    sources = tuple(f.name for f in files) + tuple(sorted(
        f for f in runtime_files if f.endswith(".c") and f not in PROGRAM_FILES))
    program = tuple(sorted(f for f in runtime_files if f in PROGRAM_FILES and f != PROGRAM
                           and f.endswith(".c")))
    headers = ("model.h",) + tuple(sorted(f for f in runtime_files
                                          if f.endswith((".h", ".inc"))))
    return CModuleView(m, c_file_stem(m.model_name), c_header(m).sizes, _tables(m), functions,
                       files, sources, tuple(f.name[:-2] + ".o" for f in files), program,
                       headers)


def c_sources(model: ir.Model, system: SymbolicSystem | None = None,
              tangents: bool = False) -> dict[str, str]:
    """The generated files of the C target (model.c, any model_<name>.c, model.h, Makefile)
    as text; no file written. The integrator's sources (runtime/c) are not included.
    `tangents`: with the tangent functions (interface.TANGENTS; else their fields are NULL)."""
    return c_target(model, system, tangents)[1]


def c_target(model: ir.Model, system: SymbolicSystem | None = None, tangents: bool = False,
             put=None) -> tuple[ModuleView, dict[str, str]]:
    """The lowered module (its sizes, tables and identity, for targets that wrap the C model:
    codegen.fmu, which never asks for tangents) and the generated files of `c_sources`, from
    one lowering. `put(name, text)`, when given, is handed each file as soon as it is
    complete: model.h first, then each model_<name>.c while the next functions are lowered,
    then model.c and the Makefile."""
    files: dict[str, str] = {}

    def keep(name: str, text: str) -> None:
        files[name] = text
        if put is not None:
            put(name, text)

    packed = _Files(keep)
    view = lower_module(model, system or derive(model), CPrinter, DEPSIM_VERSION,
                        tangents=tangents, kernels=True, lowered=packed.add)
    c = c_view(view, tuple(core_folder_files()), tuple(packed.functions), tuple(packed.files))
    keep("model.c", C_ENVIRONMENT.get_template("c/model.c.j2").render(c=c, m=view,
                                                                      file=c.files[0]))
    keep("Makefile", C_ENVIRONMENT.get_template("c/Makefile.j2").render(
        c=c, m=view, cflags=" ".join(CFLAGS), model_cflags=" ".join(MODEL_EXTRA_CFLAGS)))
    return view, files


def compile_c(model: ir.Model, out_dir: Path, system: SymbolicSystem | None = None,
              tangents: bool = False, written=None) -> Path:
    """Write the C target's folder for `model` into `out_dir` (created if needed): generated
    model.c/model.h, the integrator's sources, a Makefile. Returns `out_dir`.
    `system`: an already derived SymbolicSystem of the model, to skip derivation.
    `tangents`: with the tangent functions (interface.TANGENTS; about twice the C to
    compile), which forward sensitivities need; the standalone program never uses them.
    `written(path)`: told of each generated model*.c as soon as it is in the folder (with
    the headers it includes), e.g. to compile it while the rest is generated
    (depsim.runtime.binding.ModelPrebuild).
    Build with `make -C out_dir` (program `<name>`, library `lib<name>.so`) or
    `depsim.runtime.binding.build_model_library(out_dir)` (the library alone)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, source in core_folder_files().items():
        (out_dir / name).parent.mkdir(parents=True, exist_ok=True)
        _write_if_changed(out_dir / name, source.read_text(encoding="utf-8"))

    def put(name: str, text: str) -> None:
        _write_if_changed(out_dir / name, text)
        if written is not None and name.endswith(".c"):
            written(out_dir / name)

    c_target(model, system, tangents, put)
    return out_dir


def c_program_name(model: ir.Model) -> str:
    """The name of the program (and of `lib<name>.so`) `compile_c` builds for `model`."""
    return c_file_stem(model.name)


def _write_if_changed(path: Path, text: str) -> None:
    """Write `text` unless the file holds it already (keeps make's timestamps meaningful)."""
    if path.exists() and path.read_text(encoding="utf-8") == text:
        return
    path.write_text(text, encoding="utf-8", newline="\n")


__all__ = ["compile_c", "c_sources", "c_target", "c_program_name", "core_folder_files",
           "PROGRAM_FILES"]
