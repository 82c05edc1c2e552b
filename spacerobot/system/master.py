"""The co-simulation loop: fixed communication points, Jacobi exchange, one doStep per
component and point.

At every communication point ``t`` the master reads the connected outputs and sets the
connected inputs, source by source in the order of the connections, then steps every component
from ``t`` to the next point. The plant and the estimator change their outputs only when they
step, so a connection may go either way between them (plant -> estimator and estimator ->
plant alike): each input gets the value its source had at ``t``. The sensors FMU is a direct
feedthrough: listed after the plant -> sensors connections, its outputs carry the sample of
``t`` to the estimator at ``t``.
"""
from __future__ import annotations

import collections
import contextlib
import math
import signal
import sys
import threading
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

from .errors import Calls, SimulationError
from .instance import ArrayIO, stepper

#: (start component, start connector, end component, end connector)
Connection = Tuple[str, str, str, str]


def time_grid(start: float, stop: float, step: float) -> List[float]:
    """Communication points ``start + k step`` up to ``stop``; a stop time that is not on that
    grid gets a shorter last step, so that the run ends exactly at the stop time."""
    if not (math.isfinite(stop) and stop > start):
        raise ValueError(f"stop_time must be finite and > start time {start}, got {stop}")
    n_steps = max(1, int(math.ceil((stop - start) / step - 1e-9)))
    return [min(start + k * step, stop) for k in range(n_steps)] + [stop]


def initialize(instances: Mapping[str, object], start: float, stop: float,
               calls: Optional[Calls] = None) -> None:
    """fmi2SetupExperiment, fmi2EnterInitializationMode, fmi2ExitInitializationMode of every
    instance (parameters are set before, between instantiation and this call)."""
    calls = calls or Calls()
    calls.phase, calls.t = "initialisation", start
    for name, inst in instances.items():
        calls(name, "fmi2SetupExperiment")
        inst.fmu.setupExperiment(startTime=start, stopTime=stop)
        calls(name, "fmi2EnterInitializationMode")
        inst.fmu.enterInitializationMode()
        calls(name, "fmi2ExitInitializationMode")
        inst.fmu.exitInitializationMode()
        inst.initialized = True


class Master:
    """Fixed-step Jacobi master over :class:`~.instance.FMUInstance` objects.

    Parameters
    ----------
    instances : ``{component name: FMUInstance}``, instantiated and initialised
    connections : every ``(source, output, destination, input)`` to wire
    calls : :class:`~.errors.Calls` kept up to date for error messages

    Raises
    ------
    SimulationError
        A connection between variables of different FMI types.
    """

    def __init__(self, instances: Mapping[str, object], connections: Sequence[Connection],
                 calls: Optional[Calls] = None):
        self.instances = dict(instances)
        self.calls = calls or Calls()
        # batched fmi2Get/fmi2Set per (source, destination, type)
        wires: Dict[tuple, Tuple[List[int], List[int]]] = collections.defaultdict(
            lambda: ([], []))
        for a, ac, b, bc in connections:
            va, vb = self.instances[a].var(ac), self.instances[b].var(bc)
            if va.type != vb.type:
                raise SimulationError(f"connection {a}.{ac} ({va.type}) -> {b}.{bc} ({vb.type}): "
                                      f"types differ")
            typ = {"Real": "Real", "Boolean": "Boolean"}.get(va.type, "Integer")
            wires[(a, b, typ)][0].append(va.valueReference)
            wires[(a, b, typ)][1].append(vb.valueReference)
        # one array per wire: the destination's set sends what the source's get read into it
        self._wires = []
        for (a, b, typ), (src, dst) in wires.items():
            get = ArrayIO(self.instances[a].fmu, typ, src)
            self._wires.append((a, b, typ, get, ArrayIO(self.instances[b].fmu, typ, dst,
                                                        values=get.values),
                                f"fmi2Get{typ}", f"fmi2Set{typ}"))
        self._steps = [(name, stepper(inst.fmu)) for name, inst in self.instances.items()]

    def exchange(self) -> None:
        """For each (source, destination) pair in the order of the connections: read the
        connected outputs, set the connected inputs.

        For components whose outputs change only in fmi2DoStep this equals reading every
        output before setting any input. A direct-feedthrough component (the sensors FMU)
        whose outgoing connections follow its incoming ones passes on, within the same
        communication point, the values just set.
        """
        calls = self.calls
        for a, b, _, get, put, get_name, set_name in self._wires:
            calls(a, get_name)
            get.get()
            calls(b, set_name)
            put.set()

    def do_step(self, t: float, dt: float) -> None:
        """fmi2DoStep(t, dt) of every component, in the order of ``instances``."""
        self.calls.t = t
        for name, step in self._steps:
            self.calls(name, "fmi2DoStep")
            step(t, dt)

    def step(self, t: float, dt: float) -> None:
        """One communication step: :meth:`exchange` at ``t``, then :meth:`do_step`."""
        self.calls.t = t
        self.exchange()
        self.do_step(t, dt)

    def run(self, points: Sequence[float], recorder=None, progress: Optional[bool] = None,
            desc: str = "") -> None:
        """The stepping loop: at every point exchange, record (``recorder.record(k, t)``),
        and step to the next point.
        ``progress``: tqdm bar (None: only on a terminal, after 2 s)."""
        from tqdm import tqdm

        self.calls.phase = "stepping"
        n_steps = len(points) - 1
        bar = tqdm(total=n_steps, disable=not _use_progress(progress), unit="step", desc=desc,
                   delay=0.0 if progress else 2.0, leave=False)
        with deferred_interrupt() as interrupted:
            try:
                for k, t in enumerate(points):
                    if interrupted():
                        raise KeyboardInterrupt(f"interrupted at t = {t:g} s")
                    self.calls.t = t
                    self.exchange()
                    if recorder is not None:
                        recorder.record(k, t)
                    if k == n_steps:
                        break
                    self.do_step(t, points[k + 1] - t)
                    bar.update(1)
            finally:
                bar.close()


@contextlib.contextmanager
def deferred_interrupt():
    """Within the block, Ctrl-C (SIGINT) only sets a flag, which the stepping loop checks
    between communication steps: the interrupt then never lands between two FMU calls of one
    exchange or step (the FMUs left at different times), and the loop stops cleanly with
    KeyboardInterrupt.
    Yields the function that tells whether SIGINT arrived. Only in the main thread and only if
    Python's default handler is installed; otherwise that function always returns False."""
    hit = []
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield lambda: False
        return
    previous = signal.signal(signal.SIGINT, lambda signum, frame: hit.append(signum))
    try:
        yield lambda: bool(hit)
    finally:
        signal.signal(signal.SIGINT, previous)


def _use_progress(progress: Optional[bool]) -> bool:
    if progress is not None:
        return bool(progress)
    try:
        return sys.stderr.isatty()
    except Exception:
        return False
