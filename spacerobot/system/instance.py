"""One FMI 2.0 co-simulation FMU, extracted and instantiated through fmpy, addressed by name.

Used by the cross-check writer, the benchmarks and the tests; the SSP runner keeps its own
instance type because it also carries the SSD component and maps FMI errors to messages.
"""
from __future__ import annotations

import shutil
from pathlib import Path
from typing import Callable, List, Optional, Sequence


def logger_callbacks(sink: Callable[[str, int, str, str], None]):
    """fmpy ``fmi2CallbackFunctions`` whose logger calls ``sink(instance, status, category,
    message)`` with decoded strings.

    The logger is called directly by the FMU, not through fmpy's ``addLoggerProxy``: that proxy
    keeps ONE process-global Python target, so registering through it would redirect every other
    FMU's messages in the process (and leave a dangling pointer once the target is gone). The
    message then arrives as the printf format string, which for our pythonfmu FMUs is the whole
    message with ``%`` escaped as ``%%`` (undone here). Keep the returned structure alive as long
    as an instance uses it (it holds the ctypes callables).
    """
    from fmpy import calloc, free
    from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                           fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)

    def text(b) -> str:
        return b.decode("utf-8", "replace") if b else ""

    def logger(component, instance_name, status, category, message):
        try:
            sink(text(instance_name) or "?", int(status), text(category),
                 text(message).replace("%%", "%"))
        except Exception:  # never let an exception cross the C boundary
            pass

    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(logger)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    return cb


class FMUInstance:
    """An instantiated FMU with name-based access (fmpy's low-level ``FMU2Slave``).

    Parameters
    ----------
    path : the .fmu file
    name : instance name
    callbacks : fmpy ``fmi2CallbackFunctions`` to instantiate with (default: fmpy's)
    logging_on : passed to ``fmi2Instantiate``
    extracted : ``(model description, unzip folder)`` already at hand for this FMU (the folder
        is then shared and not removed by :meth:`close`)
    """

    def __init__(self, path: str | Path, name: str, callbacks=None, logging_on: bool = False,
                 extracted: Optional[tuple] = None):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        if extracted is None:
            self.md, self.dir, self._owns_dir = (read_model_description(str(path)),
                                                 extract(str(path)), True)
        else:
            (self.md, self.dir), self._owns_dir = extracted, False
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier,
                             instanceName=name)
        self._callbacks = callbacks              # kept alive as long as the instance
        self.fmu.instantiate(callbacks=callbacks, loggingOn=logging_on)

    def names(self, causality: str) -> List[str]:
        """Variable names of one causality, in model-description order."""
        return [n for n, v in self.vars.items() if v.causality == causality]

    def vrs(self, names: Sequence[str]) -> List[int]:
        return [self.vars[n].valueReference for n in names]

    def set(self, name: str, value) -> None:
        v = self.vars[name]
        if v.type == "Integer":
            self.fmu.setInteger([v.valueReference], [int(value)])
        else:
            self.fmu.setReal([v.valueReference], [float(value)])

    def get(self, name: str):
        v = self.vars[name]
        if v.type == "Integer":
            return self.fmu.getInteger([v.valueReference])[0]
        return self.fmu.getReal([v.valueReference])[0]

    def free(self) -> None:
        """fmi2Terminate and fmi2FreeInstance."""
        self.fmu.terminate()
        self.fmu.freeInstance()

    def close(self) -> None:
        """:meth:`free`, and remove the unzip folder if this instance extracted it."""
        self.free()
        if self._owns_dir:
            shutil.rmtree(self.dir, ignore_errors=True)
