"""FMI 3.0 co-simulation FMUs in the project's runner: an FMI 2.0-shaped view of fmpy's
``FMU3Slave``.

The runner (:mod:`.instance`, :mod:`.master`, :mod:`.recorder`, :mod:`.bindings`) talks to an
FMU through FMI 2.0's calls (``setupExperiment``, ``getReal``, ``setInteger``, ``doStep``, ...)
and FMI 2.0's type names (``Real``, ``Integer``). :class:`FMU3Adapter` offers those calls over
an FMI 3.0 instance (``Float64`` for ``Real``, ``Int32`` for ``Integer``; the start and stop
times of ``setupExperiment`` go to ``fmi3EnterInitializationMode``), and
:data:`TYPE_NAMES` maps FMI 3.0's variable types to FMI 2.0's names. Scalars only: the
project's FMI 3.0 FMUs declare the FMI 2.0 variables one to one (docs/fmus.md).

:meth:`FMU3Adapter.array_io` and :meth:`FMU3Adapter.doStep` call the shared library directly
through preallocated ctypes arrays, as :class:`.instance.ArrayIO` does for FMI 2.0: a status
worse than Warning raises fmpy's ``FMICallException``.
"""
from __future__ import annotations

import ctypes
from typing import Callable, Sequence, Tuple

import numpy as np

#: FMI 3.0 variable type -> the FMI 2.0 name the runner uses
TYPE_NAMES = {"Float64": "Real", "Float32": "Real", "Int32": "Integer", "Int8": "Integer",
              "UInt8": "Integer", "Int16": "Integer", "UInt16": "Integer",
              "UInt32": "Integer", "Int64": "Integer", "UInt64": "Integer"}
#: the FMI 2.0 type the runner asks for -> the FMI 3.0 functions' type
_CALL_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}


def _raise(function: str, status: int) -> None:
    from fmpy.fmi1 import FMICallException
    raise FMICallException(function=function, status=status)


def log_message_callback(callbacks, instance_name: str):
    """An fmi3 ``logMessage`` function calling the sink of :func:`.instance.logger_callbacks`'
    ``callbacks`` (its ``sink`` attribute) with this instance's name; None if there is none."""
    sink = getattr(callbacks, "sink", None) if callbacks is not None else None
    if sink is None:
        return None

    def log_message(env, status, category, message):
        try:
            sink(instance_name, int(status), (category or b"").decode("utf-8", "replace"),
                 (message or b"").decode("utf-8", "replace"))
        except Exception:  # never let an exception cross the C boundary
            pass
    return log_message


class FMU3Adapter:
    """fmpy's ``FMU3Slave`` with FMI 2.0's calls (see the module's doc).

    Parameters
    ----------
    md : fmpy model description of an FMI 3.0 co-simulation FMU
    unzip_dir : the extracted FMU
    instance_name : the instance's name
    """

    def __init__(self, md, unzip_dir: str, instance_name: str):
        from fmpy.fmi3 import FMU3Slave

        self.slave = FMU3Slave(guid=md.guid, unzipDirectory=unzip_dir,
                               modelIdentifier=md.coSimulation.modelIdentifier,
                               instanceName=instance_name)
        self.instance_name = instance_name
        self._start, self._stop = 0.0, None

    # -- lifecycle ------------------------------------------------------------------------------
    @property
    def component(self):
        return self.slave.component

    @property
    def dll(self):
        return self.slave.dll

    def instantiate(self, callbacks=None, loggingOn: bool = False) -> None:
        """fmi3InstantiateCoSimulation (no event mode, no early return), logging to the sink of
        ``callbacks`` (:func:`.instance.logger_callbacks`) or, without one, fmpy's printer."""
        self.slave.instantiate(loggingOn=loggingOn,
                               logMessage=log_message_callback(callbacks, self.instance_name))

    def setupExperiment(self, tolerance=None, startTime: float = 0.0, stopTime=None) -> None:
        """Only remembered: FMI 3.0 passes them to fmi3EnterInitializationMode."""
        self._start, self._stop = float(startTime), stopTime

    def enterInitializationMode(self) -> None:
        self.slave.enterInitializationMode(startTime=self._start, stopTime=self._stop)

    def exitInitializationMode(self) -> None:
        self.slave.exitInitializationMode()

    def terminate(self) -> None:
        self.slave.terminate()

    def freeInstance(self) -> None:
        self.slave.freeInstance()

    def reset(self) -> None:
        self.slave.reset()

    # -- variables ------------------------------------------------------------------------------
    def getReal(self, vr):
        return self.slave.getFloat64(list(vr))

    def setReal(self, vr, values):
        self.slave.setFloat64(list(vr), [float(x) for x in values])

    def getInteger(self, vr):
        return self.slave.getInt32(list(vr))

    def setInteger(self, vr, values):
        self.slave.setInt32(list(vr), [int(x) for x in values])

    def getBoolean(self, vr):
        return self.slave.getBoolean(list(vr))

    def setBoolean(self, vr, values):
        self.slave.setBoolean(list(vr), [bool(x) for x in values])

    def getString(self, vr):
        return self.slave.getString(list(vr))

    def setString(self, vr, values):
        self.slave.setString(list(vr), list(values))

    def array_io(self, typ: str, vrs: Sequence[int], values: np.ndarray
                 ) -> Tuple[Callable[[], None], Callable[[], None]]:
        """``(get, set)`` of the variables ``vrs`` of runner type ``typ`` (``Real``,
        ``Integer``) through ``values`` (float64 or int32, shape (len(vrs),)), each one direct
        call of fmi3Get/Set<type>."""
        from fmpy.fmi3 import fmi3Float64, fmi3Int32, fmi3ValueReference

        t3 = _CALL_TYPES.get(typ)
        if t3 not in ("Float64", "Int32"):
            raise ValueError(f"FMI 3.0 array access for {typ} variables is not supported")
        ctype = fmi3Float64 if t3 == "Float64" else fmi3Int32
        n = len(vrs)
        vr = (fmi3ValueReference * n)(*vrs)
        ptr = values.ctypes.data_as(ctypes.POINTER(ctype))
        get_c = getattr(self.slave.dll, f"fmi3Get{t3}")          # argtypes set by fmpy
        set_c = getattr(self.slave.dll, f"fmi3Set{t3}")

        def get() -> None:
            status = get_c(self.slave.component, vr, n, ptr, n)
            if status > 1:
                _raise(f"fmi3Get{t3}", status)

        def set_() -> None:
            status = set_c(self.slave.component, vr, n, ptr, n)
            if status > 1:
                _raise(f"fmi3Set{t3}", status)
        return get, set_

    # -- stepping -------------------------------------------------------------------------------
    def doStep(self, currentCommunicationPoint: float, communicationStepSize: float,
               noSetFMUStatePriorToCurrentPoint: bool = True) -> None:
        """fmi3DoStep; a status worse than Warning raises ``FMICallException``, as fmpy's
        FMI 2.0 doStep does (the step's extra outputs are read and dropped: the project's FMUs
        have no events, never ask to terminate and never return early)."""
        from fmpy.fmi3 import fmi3Boolean, fmi3Float64

        if not hasattr(self, "_step_out"):
            self._step_out = (fmi3Boolean(), fmi3Boolean(), fmi3Boolean(), fmi3Float64())
            self._step_ptrs = tuple(ctypes.byref(x) for x in self._step_out)
            self._do_step = self.slave.dll.fmi3DoStep
        status = self._do_step(self.slave.component, currentCommunicationPoint,
                               communicationStepSize, bool(noSetFMUStatePriorToCurrentPoint),
                               *self._step_ptrs)
        if status > 1:
            _raise("fmi3DoStep", status)
        if self._step_out[1].value:
            _raise("fmi3DoStep (terminateSimulation)", 3)


def fmi2_view(model_variables) -> None:
    """Rename the types of fmpy's FMI 3.0 model variables to the runner's FMI 2.0 names
    (:data:`TYPE_NAMES`), in place."""
    for v in model_variables:
        v.type = TYPE_NAMES.get(v.type, v.type)


def is_fmi3(md) -> bool:
    return str(getattr(md, "fmiVersion", "")).startswith("3.")


__all__ = ["FMU3Adapter", "TYPE_NAMES", "fmi2_view", "is_fmi3", "log_message_callback"]
