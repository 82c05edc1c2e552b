"""Error translation of the co-simulation: which FMI call is in progress (:class:`Calls`), and
an FMI failure turned into one :class:`SimulationError` that names the component, the FMI
function, the time and the FMU's own last log messages (:func:`fmi_errors`)."""
from __future__ import annotations

import contextlib
import math
from typing import Mapping


class SimulationError(RuntimeError):
    """An FMU returned Discard, Error or Fatal, or the system cannot be run. The first line of
    the message says what failed; the following lines are the FMU's own log messages."""


class Calls:
    """The FMI call in progress: ``calls(component, function)`` before each call, ``phase``
    (instantiation, initialisation, stepping) and the communication point ``t``."""

    def __init__(self):
        self.component, self.function = "", ""
        self.phase = "instantiation"
        self.t = math.nan

    def __call__(self, component: str, function: str) -> None:
        self.component, self.function = component, function

    def where(self) -> str:
        return f"at t = {self.t:.6g} s" if self.phase == "stepping" else f"during {self.phase}"


@contextlib.contextmanager
def fmi_errors(calls: Calls, log, instances: Mapping[str, object]):
    """Turn fmpy's ``FMICallException`` raised inside the block into :class:`SimulationError`
    with the FMU's recent messages from ``log`` (:class:`~.instance.FMULog`); an instance that
    returned Fatal is marked so that it is freed without fmi2Terminate."""
    from fmpy.fmi1 import FMICallException

    try:
        yield
    except FMICallException as e:
        comp = calls.component
        if comp in instances and e.status >= 4:
            instances[comp].fatal = True
        label = {2: "Discard", 3: "Error", 4: "Fatal"}.get(e.status, f"status {e.status}")
        raise SimulationError(
            f"component {comp!r} returned {label} from {calls.function} {calls.where()}.\n"
            f"Last messages of {comp!r}:\n{log.recent(comp)}") from e
