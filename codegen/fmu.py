"""FMU target: a model as an FMI 2.0 Co-Simulation unit (docs/fmu.md).

`compile_fmu(model, path)` writes one `.fmu` archive:

    modelDescription.xml               generated (templates/fmu/modelDescription.xml.j2)
    binaries/linux64/<identifier>.so   built here with the system C compiler
    sources/                           model*.c, model.h (the C target's), fmu_variables.c
                                       (generated: the GUID and the variables' tables), the
                                       FMI wrapper fmi2.c, fmi2.h, fmu.h
                                       (runtime/c/targets/fmu) and the integrator core
                                       under core/ (runtime/c)

The variables of the FMU are one list (`fmu_view`) from which both the XML and the wrapper's
value-reference tables (fmu_variables.c) are rendered; the wrapper itself is one source for
every model. It keeps one `dep_run` of the core open per instance and advances it in
`fmi2DoStep`. No Python is inside the FMU."""

from __future__ import annotations

import hashlib
import re
import tempfile
import uuid
import zipfile
from dataclasses import dataclass
from pathlib import Path

from depsim.dsl import ir

from depsim.runtime.core import FMU_SOURCES, MODEL_EXTRA_CFLAGS, SOURCE_DIR

from .c_emit import C_ENVIRONMENT, PROGRAM_FILES, c_target, core_folder_files
from .c_printer import c_file_stem
from .derive import SymbolicSystem
from .errors import CodegenError
from .lower import ModuleView

PLATFORM = "linux64"
CFLAGS = ("-std=c99", "-O2", "-fPIC", "-shared", "-Wall", "-Wextra", "-Werror",
          "-fvisibility=hidden")
SANITIZE_FLAGS = ("-fsanitize=address,undefined", "-fno-omit-frame-pointer")
VARIABLES_FILE = "fmu_variables.c"  # generated (templates/fmu/fmu_variables.c.j2)
INDEPENDENT = "time"

# Per hinge, the Real observables (suffix, C kind, unit, description; force_z in a spatial
# model only) and, for a hinge with a latch, the Boolean `<hinge>.latched`.
HINGE_OBSERVABLES = (
    ("angle", "FMU_ANGLE", "rad", "angle of hinge {h}"),
    ("rate", "FMU_RATE", "rad/s", "angle rate of hinge {h}"),
    ("force_x", "FMU_FORCE_X", "N",
     "force on member b from member a at hinge {h}, x (ground frame)"),
    ("force_y", "FMU_FORCE_Y", "N",
     "force on member b from member a at hinge {h}, y (ground frame)"),
    ("force_z", "FMU_FORCE_Z", "N",
     "force on member b from member a at hinge {h}, z (ground frame)"),
    ("torque", "FMU_TORQUE", "N*m",
     "lock torque of hinge {h} on member b (latched or at a stop; 0 when free)"),
)
# A slider in the hinge tables (docs/language.md, slider): its displacement, rate and lock
# force along the axis, in the hinge observables' places.
SLIDER_OBSERVABLES = (
    ("position", "FMU_ANGLE", "m", "displacement of slider {h} along its axis"),
    ("rate", "FMU_RATE", "m/s", "displacement rate of slider {h}"),
    ("force", "FMU_TORQUE", "N",
     "lock force of slider {h} on member b along its axis (latched or at a stop; 0 when "
     "free)"),
)


def _xml_text(text: str) -> str:
    """`text` with XML's special characters escaped and characters XML 1.0 cannot hold
    (control characters) replaced by spaces; line breaks kept as character references."""
    out = []
    for char in str(text):
        code = ord(char)
        if char in "&<>\"'":
            out.append({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;",
                        "'": "&apos;"}[char])
        elif char in "\t\n\r":
            out.append(f"&#{code};")
        elif code < 0x20 or 0xD800 <= code <= 0xDFFF or code in (0xFFFE, 0xFFFF):
            out.append(" ")
        else:
            out.append(char)
    return "".join(out)


def _xml_comment(text: str) -> str:
    """One line safe inside an XML comment: no `--`, no control characters."""
    line = " ".join(_xml_text(text).replace("&#9;", " ").replace("&#10;", " ")
                    .replace("&#13;", " ").split())
    while "--" in line:
        line = line.replace("--", "- -")
    return line.rstrip("-")


FMU_ENVIRONMENT = C_ENVIRONMENT.overlay()
FMU_ENVIRONMENT.filters.update(xml_attr=lambda text: f'"{_xml_text(text)}"',
                               xml_comment=_xml_comment)


@dataclass(frozen=True)
class FmuVariable:
    """One ScalarVariable, and what it names in the wrapper (`kind`, `index`)."""

    name: str
    vr: int
    type: str  # "Real" or "Boolean"
    causality: str
    variability: str
    initial: str  # "" for none
    unit: str  # "" for none (dimensionless)
    start: str | None
    description: str
    kind: str  # enum fmu_kind of runtime/c/targets/fmu/fmu.h
    index: int


@dataclass(frozen=True)
class FmuUnit:
    name: str  # the SI unit text, e.g. "N*m/rad"
    exponents: tuple[tuple[str, int], ...]  # BaseUnit attributes, e.g. (("kg", 1), ...)


@dataclass(frozen=True)
class FmuView:
    guid: str
    identifier: str  # modelIdentifier: the binary's name
    variables: tuple[FmuVariable, ...]  # in ModelVariables order
    reals: tuple[FmuVariable, ...]  # by value reference
    booleans: tuple[FmuVariable, ...]
    input_slots: tuple[int, ...]  # each input's value slot in p (its rate: the next one)
    outputs: tuple[int, ...]  # 1-based indices into ModelVariables of every output
    units: tuple[FmuUnit, ...]
    source_files: tuple[str, ...]  # the .c files under sources/
    stop_time: str
    tolerance: str
    step_size: str


def model_identifier(model: ir.Model) -> str:
    """The FMU's modelIdentifier (and binary name): the model name as the C target reduces it
    (docs/c-target.md, section 3)."""
    return c_file_stem(model.name)


def fmu_guid(model: ir.Model, depsim_version: str) -> str:
    """A GUID from the model's source SHA-256, its beam element counts and depsim's version:
    the same model and depsim give the same GUID."""
    elements = ",".join(f"{b.name}={b.elements}" for b in model.beams)
    digest = hashlib.sha256(f"{model.source_sha256}|{elements}|{depsim_version}|fmi2-cs"
                            .encode()).digest()
    return "{" + str(uuid.UUID(bytes=digest[:16], version=5)) + "}"


_FACTOR = re.compile(r"([A-Za-z]+)(?:\^(-?\d+))?")


def unit_exponents(text: str) -> tuple[tuple[str, int], ...] | None:
    """The SI base-unit exponents (kg, m, s, rad) of SI unit text such as "N*m/rad"; empty
    for a plain number ("1", ""); None for text that is not SI units."""
    from depsim.dsl.units import UNITS

    exponents = {"kg": 0, "m": 0, "s": 0, "rad": 0}
    pieces = re.split(r"([*/])", text.strip()) if text.strip() else []
    for op, piece in zip(["*"] + pieces[1::2], pieces[0::2]):
        if piece == "1":
            continue
        match = _FACTOR.fullmatch(piece)
        unit = UNITS.get(match.group(1)) if match else None
        if unit is None or unit.factor != 1.0:
            return None
        power = int(match.group(2) or 1) * (-1 if op == "/" else 1)
        for base, exponent in zip(exponents, (unit.dim.mass, unit.dim.length, unit.dim.time,
                                              unit.dim.angle)):
            exponents[base] += exponent * power
    return tuple((base, e) for base, e in exponents.items() if e != 0)


def _number(value: float) -> str:
    return repr(float(value))


def _parameter_description(param: ir.Param | None) -> str:
    if param is None:
        return ""
    where = f"{_file_name(param.span.file)}:{param.span.line}"
    if param.kind == ir.ParamKind.ATTRIBUTE and "." in param.name:
        element, attribute = param.name.rsplit(".", 1)
        return f"{attribute} of {element} ({where})"
    return f"param {param.name} ({where})"


def _input_description(model: ir.Model, component: str) -> str:
    """What an input component is, from the model's `input` statement."""
    for item in getattr(model, "inputs", ()):
        if component not in item.components:
            continue
        where = f"{_file_name(item.span.file)}:{item.span.line}"
        if item.hinge is not None:
            return f"torque on hinge {model.hinges[item.hinge].name} ({where})"
        member = item.point.member
        owner = {ir.MemberKind.BODY: model.bodies, ir.MemberKind.BEAM: model.beams}.get(
            member.kind)
        name = owner[member.index].name if owner is not None else "ground"
        axis = component.rsplit(".", 1)[-1]
        return f"force on {name}.{item.point.point}, {axis} (ground frame; {where})"
    return f"input {component}"


def _file_name(path: str) -> str:
    return path.replace("\\", "/").rsplit("/", 1)[-1]


class _Variables:
    """Collects the FMU's variables in ModelVariables order, numbering value references per
    type."""

    def __init__(self):
        self.items: list[FmuVariable] = []
        self.count = {"Real": 0, "Boolean": 0}

    def add(self, name, type_, causality, variability, kind, index, unit="", start=None,
            initial="", description=""):
        vr = self.count[type_]
        self.count[type_] += 1
        self.items.append(FmuVariable(name, vr, type_, causality, variability, initial, unit,
                                      start, description, kind, index))


def fmu_view(model: ir.Model, m: ModuleView, source_files: tuple[str, ...] = ()) -> FmuView:
    """The FMU's variables and settings for a lowered model `m` of `model`."""
    tables = {t.constant: tuple(t.values) for t in m.tables}
    names, defaults = tables["PARAMETERS"], tables["PARAMETER_DEFAULTS"]
    units = tables["PARAMETER_UNITS"]
    input_slots = tuple(int(s) for s in tables.get("INPUT_SLOTS", ()))
    slots = {s for slot in input_slots for s in (slot, slot + 1)}
    params = {p.name: p for p in model.params}
    v = _Variables()
    v.add(INDEPENDENT, "Real", "independent", "continuous", "FMU_TIME", 0, unit="s",
          description="time (s): depsim time + startTime")
    for k, name in enumerate(names):
        if k not in slots:
            v.add(name, "Real", "parameter", "fixed", "FMU_PARAMETER", k, unit=units[k],
                  start=_number(defaults[k]), initial="exact",
                  description=_parameter_description(params.get(name)))
    for k, (name, unit) in enumerate(zip(tables.get("INPUTS", ()),
                                         tables.get("INPUT_UNITS", ()))):
        v.add(name, "Real", "input", "continuous", "FMU_INPUT", k, unit=unit,
              start=_number(defaults[input_slots[k]]),
              description=_input_description(model, name))
    for j, (name, unit) in enumerate(zip(tables["OUTPUTS"], tables["OUTPUT_UNITS"])):
        v.add(name, "Real", "output", "continuous", "FMU_OUTPUT", j, unit=unit,
              initial="calculated", description=f"output {name}")
    latches = {joint.name for joint in model.hinges + model.sliders if joint.latch is not None}
    sliders = set(tables["SLIDERS"])
    for h, hinge in enumerate(tables["HINGES"]):
        what_joint = "slider" if hinge in sliders else "hinge"
        for suffix, kind, unit, what in \
                SLIDER_OBSERVABLES if hinge in sliders else HINGE_OBSERVABLES:
            if suffix == "force_z" and not model.spatial:
                continue
            v.add(f"{hinge}.{suffix}", "Real", "output", "continuous", kind, h, unit=unit,
                  initial="calculated", description=what.format(h=hinge))
        if hinge in latches:
            v.add(f"{hinge}.latched", "Boolean", "output", "discrete", "FMU_LATCHED", h,
                  initial="calculated", description=f"true once the latch of {what_joint} "
                                                    f"{hinge} engaged")
    _check_unique(model, v.items)
    variables = tuple(_with_unit(var) for var in v.items)
    return FmuView(
        guid=fmu_guid(model, m.depsim_version), identifier=model_identifier(model),
        variables=variables,
        reals=tuple(var for var in variables if var.type == "Real"),
        booleans=tuple(var for var in variables if var.type == "Boolean"),
        input_slots=input_slots,
        outputs=tuple(i for i, var in enumerate(variables, 1) if var.causality == "output"),
        units=_units(variables), source_files=source_files,
        stop_time=_number(m.t_end), tolerance=_number(m.tol), step_size=_number(m.dt_out))


def _with_unit(var: FmuVariable) -> FmuVariable:
    """The variable with its unit text dropped when it is a plain number (or not SI)."""
    if var.unit and unit_exponents(var.unit):
        return var
    return FmuVariable(**{**var.__dict__, "unit": ""})


def _units(variables: tuple[FmuVariable, ...]) -> tuple[FmuUnit, ...]:
    names = sorted({var.unit for var in variables if var.unit})
    return tuple(FmuUnit(name, unit_exponents(name)) for name in names)


def _check_unique(model: ir.Model, variables: list[FmuVariable]) -> None:
    seen: set[str] = set()
    for var in variables:
        if var.name in seen:
            output = next((o for o in model.outputs if o.name == var.name), None)
            raise CodegenError(
                "E906", f"'{var.name}' names two variables of the FMU (the FMU adds "
                f"'{INDEPENDENT}' and per hinge '<hinge>.angle', '.rate', '.force_x', "
                "'.force_y', '.torque', '.latched')",
                output.span if output else None, hint=f"rename the model's '{var.name}'")
        seen.add(var.name)


def fmu_sources(model: ir.Model, system: SymbolicSystem | None = None
                ) -> tuple[FmuView, dict[str, str]]:
    """The FMU's view and every text file it holds: "modelDescription.xml" and the C
    sources (`sources/` names, each compiled into the binary but the headers)."""
    m, generated = c_target(model, system)
    core = {name: path.read_text(encoding="utf-8")
            for name, path in core_folder_files().items() if name not in PROGRAM_FILES}
    sources = {name: text for name, text in generated.items() if name.startswith("model")}
    sources.update(core)
    sources.update({Path(name).name: (SOURCE_DIR / name).read_text(encoding="utf-8")
                    for name in FMU_SOURCES})
    c_files = tuple(sorted([name for name in sources if name.endswith(".c")]
                           + [VARIABLES_FILE]))
    view = fmu_view(model, m, c_files)
    sources[VARIABLES_FILE] = FMU_ENVIRONMENT.get_template(f"fmu/{VARIABLES_FILE}.j2").render(
        m=m, v=view)
    xml = FMU_ENVIRONMENT.get_template("fmu/modelDescription.xml.j2").render(m=m, v=view)
    return view, {"modelDescription.xml": xml,
                  **{name: sources[name] for name in sorted(sources)}}


def compile_fmu(model: ir.Model, path: str | Path, system: SymbolicSystem | None = None, *,
                cflags: tuple[str, ...] = (), sanitize: bool = False) -> Path:
    """Write `model` as an FMI 2.0 Co-Simulation FMU to `path` (a `.fmu` zip archive) and
    return the path. The binary is built with $CC (else cc, gcc or clang); `cflags` are
    added to its flags and `sanitize` builds it with AddressSanitizer and UBSan (tests).
    The archive is written beside `path` and renamed into place, so nothing half-written
    is ever left (depsim.runtime.output.atomic_path). Raises CodegenError for a model the
    FMU cannot represent, depsim.runtime.core.CBuildError when the build fails and
    depsim.runtime.output.OutputError when `path` cannot be written."""
    from depsim.runtime.output import atomic_path

    view, files = fmu_sources(model, system)
    flags = CFLAGS + (SANITIZE_FLAGS if sanitize else ()) + tuple(cflags)
    with tempfile.TemporaryDirectory(prefix="depsim-fmu-") as folder:
        binary = _build(view, files, Path(folder), flags)
        with atomic_path(path) as partial:
            _write_archive(partial, view, files, binary)
    return Path(path)


def _build(view: FmuView, files: dict[str, str], folder: Path, flags: tuple[str, ...]) -> bytes:
    """Compile the sources into the FMU's shared object (one compiler per source, in
    parallel, the generated model*.c adding MODEL_EXTRA_CFLAGS, then one link); its
    bytes."""
    from depsim.runtime.core import compiler, run_compilers

    for name, text in files.items():
        if name != "modelDescription.xml":
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            (folder / name).write_text(text, encoding="utf-8", newline="\n")
    cc = compiler()
    objects = [f"{k}_{Path(source).stem}.o" for k, source in enumerate(view.source_files)]
    run_compilers([[*cc, *flags, *(MODEL_EXTRA_CFLAGS if source.startswith("model") else ()),
                    "-c", "-o", obj, source]
                   for source, obj in zip(view.source_files, objects)], "the FMU's binary", folder)
    target = f"{view.identifier}.so"
    run_compilers([[*cc, *flags, "-o", target, *objects, "-lm"]], "the FMU's binary", folder)
    return (folder / target).read_bytes()


def _write_archive(path: str, view: FmuView, files: dict[str, str], binary: bytes) -> None:
    """The zip archive, byte-for-byte reproducible (fixed entry times, sorted entries)."""
    entries = [("modelDescription.xml", files["modelDescription.xml"].encode(), 0o644),
               (f"binaries/{PLATFORM}/{view.identifier}.so", binary, 0o755)]
    entries += [(f"sources/{name}", text.encode(), 0o644) for name, text in files.items()
                if name != "modelDescription.xml"]
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, data, mode in entries:
            info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o100000 | mode) << 16
            archive.writestr(info, data)


__all__ = ["compile_fmu", "fmu_sources", "fmu_view", "model_identifier", "fmu_guid",
           "unit_exponents"]
