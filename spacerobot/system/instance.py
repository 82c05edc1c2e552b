"""One FMI 2.0 or 3.0 co-simulation FMU, extracted and instantiated through fmpy, addressed by
name (FMI 3.0 through :class:`.fmi3.FMU3Adapter`, which offers FMI 2.0's calls and type names).

The one instance wrapper of the project: the co-simulation master (:mod:`.master`), the SSP
runner, the cross-check writer, the benchmarks and the tests all use :class:`FMUInstance`.
:class:`FMULog` collects the messages of every instance of a run through
:func:`logger_callbacks`. :class:`ArrayIO` reads or writes a fixed set of variables of one
type through one preallocated array (what the master and the recorder do at every step).
"""
from __future__ import annotations

import collections
import difflib
import shutil
from pathlib import Path
from typing import Callable, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

#: FMI 2.0 status codes -> names
STATUS_NAMES = ["OK", "Warning", "Discard", "Error", "Fatal", "Pending"]


def logger_callbacks(sink: Callable[[str, int, str, str], None]):
    """fmpy ``fmi2CallbackFunctions`` whose logger calls ``sink(instance, status, category,
    message)`` with decoded strings.

    The logger is called directly by the FMU, not through fmpy's ``addLoggerProxy``: that proxy
    keeps ONE process-global Python target, so registering through it would redirect every other
    FMU's messages in the process (and leave a dangling pointer once the target is gone). The
    message then arrives as the printf format string, which for the project's FMUs is the whole
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
    cb.sink = sink                      # for FMI 3.0 instances (.fmi3.log_message_callback)
    cb.logger = fmi2CallbackLoggerTYPE(logger)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    return cb


class FMULog:
    """Collects the log messages of the instances that use :attr:`callbacks`: the last
    ``maxlen`` per instance (:meth:`recent`) and every message of status Warning or worse
    (:attr:`all`, at most 10000)."""

    def __init__(self, maxlen: int = 200):
        self.messages: Dict[str, collections.deque] = collections.defaultdict(
            lambda: collections.deque(maxlen=maxlen))
        self.all: List[Tuple[str, str, str, str]] = []

        def sink(inst: str, status: int, category: str, text: str) -> None:
            label = STATUS_NAMES[status] if 0 <= status < len(STATUS_NAMES) else str(status)
            rec = (inst, label, category, text)
            self.messages[inst].append(rec)
            if status >= 1 and len(self.all) < 10000:   # warnings and worse
                self.all.append(rec)

        self.callbacks = logger_callbacks(sink)

    def recent(self, instance: str, n: int = 10) -> str:
        """The last ``n`` messages of ``instance``, one indented line each."""
        msgs = list(self.messages.get(instance, []))[-n:]
        if not msgs:
            return "  (the FMU logged no messages)"
        return "\n".join(f"  [{s}] {c}: {m}" for _, s, c, m in msgs)


class ArrayIO:
    """``fmi2Get<type>`` / ``fmi2Set<type>`` of fixed value references through one preallocated
    NumPy array :attr:`values` (float64 for Real, int32 for Integer and Boolean).

    fmpy's ``getReal(vrs)`` builds a ctypes array of the value references and one of the values,
    and a list of the result, at every call; here both arrays are built once, so a call at every
    communication step costs the FMI call alone. A status worse than Warning raises fmpy's
    ``FMICallException``, as fmpy's own call does (:func:`.errors.fmi_errors` translates it).
    An ``fmu`` that is not fmpy's ``FMU2Slave`` (e.g. a test double) is called through its
    ``get<type>`` / ``set<type>`` methods.

    Parameters
    ----------
    fmu : fmpy ``FMU2Slave`` (instantiated before :meth:`get` / :meth:`set` are called)
    typ : ``'Real'``, ``'Integer'`` or ``'Boolean'``
    vrs : value references (k,)
    values : (k,) array to use as :attr:`values` (e.g. another ArrayIO's, so that a set sends
        what a get read), default a new zero array
    """

    _TYPES = {"Real": np.float64, "Integer": np.int32, "Boolean": np.int32}

    def __init__(self, fmu, typ: str, vrs: Sequence[int], values: Optional[np.ndarray] = None):
        import ctypes
        from fmpy.fmi2 import FMU2Slave, fmi2Integer, fmi2Real, fmi2ValueReference

        dtype = self._TYPES[typ]
        self.fmu, self.typ, self.n = fmu, typ, len(vrs)
        self.values = np.zeros(self.n, dtype) if values is None else values
        if self.values.dtype != dtype or self.values.shape != (self.n,):
            raise ValueError(f"ArrayIO {typ}: values must be ({self.n},) {np.dtype(dtype)}")
        self._raw = isinstance(fmu, FMU2Slave)
        self._direct = None
        if not self._raw and hasattr(fmu, "array_io"):        # FMI 3.0 (.fmi3.FMU3Adapter)
            self._direct = fmu.array_io(typ, vrs, self.values)
        elif self._raw:
            ctype = fmi2Real if typ == "Real" else fmi2Integer       # fmi2Boolean is an int
            self._vr = (fmi2ValueReference * self.n)(*vrs)
            self._ptr = self.values.ctypes.data_as(ctypes.POINTER(ctype))
            self._get_c = getattr(fmu.dll, f"fmi2Get{typ}")          # argtypes set by fmpy
            self._set_c = getattr(fmu.dll, f"fmi2Set{typ}")
        else:
            self._vrs = list(vrs)

    def get(self) -> np.ndarray:
        """Read the variables into :attr:`values` (returned)."""
        if self._raw:
            self._check(self._get_c(self.fmu.component, self._vr, self.n, self._ptr), "Get")
        elif self._direct:
            self._direct[0]()
        else:
            self.values[:] = getattr(self.fmu, f"get{self.typ}")(self._vrs)
        return self.values

    def set(self) -> None:
        """Write :attr:`values` to the variables."""
        if self._raw:
            self._check(self._set_c(self.fmu.component, self._vr, self.n, self._ptr), "Set")
        elif self._direct:
            self._direct[1]()
        else:
            getattr(self.fmu, f"set{self.typ}")(self._vrs, self.values.tolist())

    def _check(self, status: int, what: str) -> None:
        if status > 1:                                   # worse than fmi2Warning, as fmpy
            from fmpy.fmi1 import FMICallException
            raise FMICallException(function=f"fmi2{what}{self.typ}", status=status)


def stepper(fmu) -> Callable[[float, float], None]:
    """``step(t, dt)``: fmi2DoStep of ``fmu`` from ``t`` by ``dt``. For fmpy's ``FMU2Slave``
    the function of its shared library is called directly (as :class:`ArrayIO` does for get and
    set: the master calls it at every communication step), a status worse than Warning raising
    fmpy's ``FMICallException`` as fmpy's ``doStep`` does; any other ``fmu`` (a test double)
    through its ``doStep``."""
    from fmpy.fmi2 import FMU2Slave, fmi2True

    if not isinstance(fmu, FMU2Slave):
        return lambda t, dt: fmu.doStep(currentCommunicationPoint=t, communicationStepSize=dt)
    do_step = fmu.dll.fmi2DoStep                                 # argtypes set by fmpy

    def step(t: float, dt: float) -> None:
        status = do_step(fmu.component, t, dt, fmi2True)
        if status > 1:                                   # worse than fmi2Warning, as fmpy
            from fmpy.fmi1 import FMICallException
            raise FMICallException(function="fmi2DoStep", status=status)
    return step


class FMUInstance:
    """An FMU instance with name-based access (over fmpy's low-level ``FMU2Slave``).

    Parameters
    ----------
    path : the .fmu file
    name : instance name
    callbacks : fmpy ``fmi2CallbackFunctions`` to instantiate with (default: fmpy's), e.g.
        :attr:`FMULog.callbacks` or :func:`logger_callbacks`; kept alive with the instance
    logging_on : passed to ``fmi2Instantiate``
    extracted : ``(model description, unzip folder)`` already at hand for this FMU (the folder
        is then shared and not removed by :meth:`close`)
    unzipdir : where to extract the FMU (default: a new temporary folder)
    instantiate : call ``fmi2Instantiate`` now (False: call :meth:`instantiate` later)

    Raises
    ------
    ValueError
        The file is not an FMI 2.0 or 3.0 co-simulation FMU (``zipfile.BadZipFile``, a subclass of
        Exception, for a file that is not a zip archive at all).
    """

    def __init__(self, path: str | Path, name: str, callbacks=None, logging_on: bool = False,
                 extracted: Optional[tuple] = None, unzipdir: Optional[str | Path] = None,
                 instantiate: bool = True):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        self.name = name
        self.path = Path(path)
        if extracted is None:
            md = read_model_description(str(path))
        else:
            md = extracted[0]
        if md.fmiVersion not in ("2.0", "3.0") or md.coSimulation is None:
            raise ValueError(f"{path}: only FMI 2.0 and 3.0 co-simulation FMUs are supported")
        if extracted is None:
            self.md, self.dir, self._owns_dir = md, extract(
                str(path), unzipdir=None if unzipdir is None else str(unzipdir)), True
        else:
            (self.md, self.dir), self._owns_dir = extracted, False
        self.fmi_version = self.md.fmiVersion
        if self.fmi_version == "3.0":
            from .fmi3 import FMU3Adapter, fmi2_view
            fmi2_view(self.md.modelVariables)    # Float64 -> Real, Int32 -> Integer
            self.fmu = FMU3Adapter(self.md, self.dir, name)
        else:
            self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                                 modelIdentifier=self.md.coSimulation.modelIdentifier,
                                 instanceName=name)
        self.vars = {v.name: v for v in self.md.modelVariables}
        self._callbacks = callbacks              # kept alive as long as the instance
        self._logging_on = logging_on
        self.instantiated = self.initialized = False
        self.fatal = False                       #: set after fmi2Fatal: only free, never terminate
        if instantiate:
            self.instantiate()

    # -- lifecycle ------------------------------------------------------------------------------
    def instantiate(self) -> None:
        """fmi2Instantiate (with the callbacks and logging flag given to the constructor)."""
        self.fmu.instantiate(callbacks=self._callbacks, loggingOn=self._logging_on)
        self.instantiated = True

    def init(self, params: Optional[Mapping[str, object]] = None, start: float = 0.0,
             stop: Optional[float] = None) -> "FMUInstance":
        """fmi2SetupExperiment, fmi2EnterInitializationMode, set ``params``,
        fmi2ExitInitializationMode; returns ``self``."""
        self.fmu.setupExperiment(startTime=start, stopTime=stop)
        self.fmu.enterInitializationMode()
        for k, v in (params or {}).items():
            self.set(k, v)
        self.fmu.exitInitializationMode()
        self.initialized = True
        return self

    def free(self) -> None:
        """fmi2Terminate (if initialised and not fatal) and fmi2FreeInstance. Never raises:
        this is the clean-up that runs after any error, and it runs once."""
        if not self.instantiated:
            return
        try:
            if self.initialized and not self.fatal:
                self.fmu.terminate()
        except Exception:
            pass
        finally:
            try:
                self.fmu.freeInstance()
            except Exception:
                pass
            self.instantiated = self.initialized = False

    def close(self) -> None:
        """:meth:`free`, and remove the unzip folder if this instance extracted it."""
        self.free()
        if self._owns_dir:
            shutil.rmtree(self.dir, ignore_errors=True)

    # -- variables ------------------------------------------------------------------------------
    def var(self, name: str):
        """The model variable ``name``; KeyError naming close matches if there is none."""
        try:
            return self.vars[name]
        except KeyError:
            close = difflib.get_close_matches(name, list(self.vars), n=3)
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise KeyError(f"component {self.name!r} has no variable {name!r}{hint}") from None

    def names(self, causality: str) -> List[str]:
        """Variable names of one causality, in model-description order."""
        return [n for n, v in self.vars.items() if v.causality == causality]

    def vrs(self, names: Sequence[str]) -> List[int]:
        return [self.var(n).valueReference for n in names]

    def set(self, name: str, value) -> None:
        """Set one variable from a number or its text (as in an .ssv), by its FMI type."""
        v = self.var(name)
        vr = [v.valueReference]
        if v.type == "Real":
            self.fmu.setReal(vr, [float(value)])
        elif v.type in ("Integer", "Enumeration"):
            fv = float(value)
            if fv != int(fv):
                raise ValueError(f"{self.name}.{name} is an {v.type}; got non-integer {value!r}")
            self.fmu.setInteger(vr, [int(fv)])
        elif v.type == "Boolean":
            b = value if isinstance(value, bool) else str(value).lower() in ("1", "true", "1.0")
            self.fmu.setBoolean(vr, [b])
        else:
            self.fmu.setString(vr, [str(value)])

    def set_many(self, names: Sequence[str], values: Sequence[float]) -> None:
        """fmi2SetReal of several Real variables at once."""
        self.fmu.setReal(self.vrs(names), [float(x) for x in values])

    def get(self, name: str):
        """The value of one Real, Integer/Enumeration or Boolean variable."""
        v = self.var(name)
        if v.type in ("Integer", "Enumeration"):
            return self.fmu.getInteger([v.valueReference])[0]
        if v.type == "Boolean":
            return self.fmu.getBoolean([v.valueReference])[0]
        return self.fmu.getReal([v.valueReference])[0]

    def values(self, names: Optional[Sequence[str]] = None) -> Dict[str, float]:
        """Current values of ``names`` (default: every Real and Integer variable)."""
        names = ([n for n, v in self.vars.items() if v.type in ("Real", "Integer")]
                 if names is None else list(names))
        return dict(zip(names, self.reader(names)().tolist()))

    def outputs(self) -> Dict[str, float]:
        return self.values(self.names("output"))

    def reader(self, names: Sequence[str]) -> Callable[[], np.ndarray]:
        """A function that reads ``names`` (Real, Integer/Enumeration, Boolean) into a float
        array with one fmi2Get call per type."""
        groups: Dict[str, Tuple[List[int], List[int]]] = {}
        for i, n in enumerate(names):
            v = self.var(n)
            typ = {"Enumeration": "Integer"}.get(v.type, v.type)
            if typ not in ("Real", "Integer", "Boolean"):
                raise ValueError(f"{self.name}.{n}: {v.type} variables cannot be read as numbers")
            idx, vrs = groups.setdefault(typ, ([], []))
            idx.append(i)
            vrs.append(v.valueReference)
        getters = [(idx, vrs, getattr(self.fmu, f"get{typ}")) for typ, (idx, vrs) in groups.items()]
        size = len(names)

        def read() -> np.ndarray:
            out = np.empty(size)
            for idx, vrs, get in getters:
                out[idx] = get(vrs)
            return out
        return read
