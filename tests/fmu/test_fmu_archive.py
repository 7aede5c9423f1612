"""The FMU archive: fmpy's validation of every example, its content, the variables and units of
modelDescription.xml, the binary's exported symbols, and reproducible output."""

from __future__ import annotations

import shutil
import subprocess
import zipfile
import xml.etree.ElementTree as ET

import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from depsim.codegen.fmu import fmu_sources, unit_exponents
from depsim.dsl import load_model

from fmu_helpers import EXAMPLES, model_path

FMI2_FUNCTIONS = {
    "fmi2GetTypesPlatform", "fmi2GetVersion", "fmi2SetDebugLogging", "fmi2Instantiate",
    "fmi2FreeInstance", "fmi2SetupExperiment", "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode", "fmi2Terminate", "fmi2Reset", "fmi2GetReal",
    "fmi2GetInteger", "fmi2GetBoolean", "fmi2GetString", "fmi2SetReal", "fmi2SetInteger",
    "fmi2SetBoolean", "fmi2SetString", "fmi2GetFMUstate", "fmi2SetFMUstate",
    "fmi2FreeFMUstate", "fmi2SerializedFMUstateSize", "fmi2SerializeFMUstate",
    "fmi2DeSerializeFMUstate", "fmi2GetDirectionalDerivative", "fmi2SetRealInputDerivatives",
    "fmi2GetRealOutputDerivatives", "fmi2DoStep", "fmi2CancelStep", "fmi2GetStatus",
    "fmi2GetRealStatus", "fmi2GetIntegerStatus", "fmi2GetBooleanStatus",
    "fmi2GetStringStatus",
}


@pytest.mark.parametrize("name", EXAMPLES + ["motor"])
def test_validates(name, fmu_path):
    """fmpy's validation (schema, names, ModelStructure, start values, units) finds nothing."""
    assert validate_fmu(str(fmu_path(name))) == []


@pytest.mark.parametrize("name", ["intelsat5", "motor"])
def test_variables(name, fmu_path):
    """Parameters (without the inputs' slots), inputs, outputs and hinge observables, with
    the model's defaults as start values and their SI units."""
    model = load_model(model_path(name))
    description = read_model_description(str(fmu_path(name)))
    variables = {v.name: v for v in description.modelVariables}
    slots = {s for item in model.inputs for slot in item.slots for s in (slot, slot + 1)}
    for k, param in enumerate(model.params):
        if k in slots:
            assert variables.get(param.name) is None or variables[param.name].causality == \
                "input"
            continue
        v = variables[param.name]
        assert (v.causality, v.variability, v.initial) == ("parameter", "fixed", "exact")
        assert float(v.start) == param.default
        assert v.unit == (param.unit if unit_exponents(param.unit) else None)
    for item in model.inputs:
        for component, slot in zip(item.components, item.slots):
            v = variables[component]
            assert (v.causality, v.variability) == ("input", "continuous")
            assert float(v.start) == model.params[slot].default
    for output in model.outputs:
        assert variables[output.name].causality == "output"
    for hinge in model.hinges:
        for suffix, unit in [("angle", "rad"), ("rate", "rad/s"), ("force_x", "N"),
                             ("force_y", "N"), ("torque", "N*m")]:
            v = variables[f"{hinge.name}.{suffix}"]
            assert (v.type, v.causality, v.unit) == ("Real", "output", unit)
        latched = variables.get(f"{hinge.name}.latched")
        assert (latched is not None) == (hinge.latch is not None)
        if latched is not None:
            assert (latched.type, latched.causality, latched.variability) == \
                ("Boolean", "output", "discrete")
    assert variables["time"].causality == "independent"
    experiment = description.defaultExperiment
    assert float(experiment.stopTime) == model.simulation.t_end
    assert float(experiment.tolerance) == model.simulation.tol


def test_units_from_si_text(fmu_path):
    """UnitDefinitions: each SI unit text with its base-unit exponents."""
    root = ET.fromstring(zipfile.ZipFile(fmu_path("intelsat5")).read("modelDescription.xml"))
    units = {u.get("name"): {k: int(v) for k, v in u.find("BaseUnit").attrib.items()}
             for u in root.iter("Unit")}
    assert units["N*m/rad"] == {"kg": 1, "m": 2, "s": -2, "rad": -1}
    assert units["N*m"] == {"kg": 1, "m": 2, "s": -2}
    assert units["rad/s"] == {"s": -1, "rad": 1}
    assert unit_exponents("N*m*s/rad") == (("kg", 1), ("m", 2), ("s", -1), ("rad", -1))
    assert unit_exponents("1/s") == (("s", -1),)
    assert unit_exponents("1") == ()
    assert unit_exponents("deg") is None  # not SI: no unit is declared


def test_archive_content(fmu_path):
    """modelDescription.xml, the linux64 binary named by modelIdentifier, and every source
    listed in SourceFiles (so another platform can rebuild it)."""
    path = fmu_path("intelsat5")
    names = set(zipfile.ZipFile(path).namelist())
    description = read_model_description(str(path))
    identifier = description.coSimulation.modelIdentifier
    assert identifier == "intelsat5"
    assert {"modelDescription.xml", f"binaries/linux64/{identifier}.so",
            "sources/fmi2.c", "sources/fmi2.h", "sources/fmu.h", "sources/fmu_variables.c",
            "sources/model.c", "sources/model.h",
            "sources/core/include/depsim.h", "sources/core/run/run.c"} <= names
    assert "sources/main.c" not in names and not any("program" in n for n in names)
    (build,) = description.buildConfigurations  # fmpy reads FMI 2.0's SourceFiles so
    sources = build.sourceFileSets[0].sourceFiles
    assert "fmi2.c" in sources and "model.c" in sources
    for source in sources:
        assert f"sources/{source}" in names
    assert description.coSimulation.canGetAndSetFMUstate is True
    assert description.coSimulation.canSerializeFMUstate is True
    assert description.coSimulation.canInterpolateInputs is True


def test_exports_only_fmi2_functions(fmu_path, tmp_path):
    """The binary's dynamic symbol table defines the FMI functions and nothing of the core."""
    nm = shutil.which("nm")
    assert nm is not None, "binutils' nm is needed (it comes with the C compiler)"
    binary = tmp_path / "intelsat5.so"
    binary.write_bytes(zipfile.ZipFile(fmu_path("intelsat5"))
                       .read("binaries/linux64/intelsat5.so"))
    listing = subprocess.run([nm, "-D", "--defined-only", str(binary)], capture_output=True,
                             text=True, check=True).stdout
    functions = {line.split()[-1] for line in listing.splitlines()
                 if line.split()[-2:-1] in (["T"], ["t"])}
    assert functions == FMI2_FUNCTIONS


def test_reproducible_and_guid():
    """The same model gives the same text; the GUID follows the model's hash."""
    model = load_model(model_path("pendulum"))
    first, files = fmu_sources(model)
    again, files_again = fmu_sources(model)
    assert files == files_again
    assert first.guid in files["modelDescription.xml"]
    assert first.guid in files["fmu_variables.c"]
    other, _ = fmu_sources(load_model(model_path("motor")))
    assert other.guid != first.guid


def test_the_wrapper_is_one_source_for_every_model():
    """Only the variables' tables and modelDescription.xml are rendered per model: the FMI
    wrapper is runtime/c/targets/fmu's source, the same text in every FMU."""
    from depsim.runtime.core import FMU_SOURCES, SOURCE_DIR

    for name in ("pendulum", "intelsat5"):
        _, files = fmu_sources(load_model(model_path(name)))
        for source in FMU_SOURCES:
            assert files[source.rsplit("/", 1)[-1]] == (SOURCE_DIR / source).read_text()
