"""Helpers of the FMU tests: where the models are, and a small FMI 2.0 master on fmpy's
low-level classes that records what the FMU logs."""

from __future__ import annotations

import ctypes
from dataclasses import dataclass, field
from pathlib import Path

from fmpy import extract, read_model_description
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted(path.stem for path in (ROOT / "examples").glob("*.dep"))
MODELS = Path(__file__).resolve().parent / "models"


def model_path(name: str) -> Path:
    """An example (examples/<name>.dep) or a test model (tests/fmu/models/<name>.dep)."""
    path = ROOT / "examples" / f"{name}.dep"
    return path if path.exists() else MODELS / f"{name}.dep"


@dataclass
class Log:
    """The messages an FMU sent its logger: (status, category, message)."""

    entries: list[tuple[int, str, str]] = field(default_factory=list)

    def errors(self) -> list[str]:
        return [message for status, category, message in self.entries
                if status == 3 and category == "logError"]


class Slave:
    """One instance of an FMU driven call by call; `log` collects what it reports."""

    def __init__(self, path: Path, loggingOn: bool = False):
        self.description = read_model_description(str(path))
        self.log = Log()
        self.vr = {v.name: v.valueReference for v in self.description.modelVariables}
        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(self._logger)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(_calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(_free)
        from fmpy.logging import addLoggerProxy
        addLoggerProxy(ctypes.byref(self._callbacks))
        self.fmu = FMU2Slave(guid=self.description.guid, unzipDirectory=extract(str(path)),
                             modelIdentifier=self.description.coSimulation.modelIdentifier,
                             instanceName="test")
        self.fmu.instantiate(callbacks=self._callbacks, loggingOn=loggingOn)

    def _logger(self, environment, instance, status, category, message):
        self.log.entries.append((status, (category or b"").decode(), message.decode()))

    def start(self, start_values: dict[str, float] | None = None, stop_time=None) -> None:
        """Set up, set `start_values`, and initialize (fmpy's calls; they raise on errors)."""
        self.fmu.setupExperiment(startTime=0.0, stopTime=stop_time)
        self.fmu.enterInitializationMode()
        for name, value in (start_values or {}).items():
            self.fmu.setReal([self.vr[name]], [value])
        self.fmu.exitInitializationMode()

    def real(self, name: str) -> float:
        return self.fmu.getReal([self.vr[name]])[0]

    def free(self) -> None:
        self.fmu.freeInstance()


_libc = ctypes.CDLL(None)
_libc.calloc.restype = ctypes.c_void_p
_libc.calloc.argtypes = [ctypes.c_size_t, ctypes.c_size_t]
_libc.free.argtypes = [ctypes.c_void_p]


def _calloc(count, size):
    return _libc.calloc(count, size)


def _free(pointer):
    _libc.free(pointer)


