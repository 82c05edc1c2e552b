"""Helpers of the interface conformance suite (tests/test_conformance_*.py); no tests here.

``Inst`` is the project's :class:`~spacerobot.FMUInstance` with its own logger callback, so
that every test can see both the status an FMI call returned and the messages the FMU logged
during that call.
"""
from __future__ import annotations

from pathlib import Path
from typing import Dict, List, Optional

import numpy as np
import pytest

from spacerobot import FMUInstance
from spacerobot import logger_callbacks

OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4
STATUS_NAMES = {0: "OK", 1: "Warning", 2: "Discard", 3: "Error", 4: "Fatal"}

ROBOTS = ("planar", "spatial")
KINDS = ("plant", "estimator", "sensors")
DT = 0.1
#: per kind, parameters other than the defaults (for the tests that need two different runs)
OTHER_PARAMETERS = {"plant": {"target.m": 123.0}, "estimator": {"guess.target.m": 42.0},
                    "sensors": {"seed": 7, "noise.gyro.arw": 1e-3}}


def fed_inputs(kind: str, names):
    """The names under which ``kind`` takes the plant samples (estimator inputs ``names``):
    the estimator's own, the sensors' ``true.<name>``, none for the plant."""
    return {"plant": None, "estimator": list(names),
            "sensors": ["true." + n for n in names]}[kind]


def fmus_for(request, robot: str) -> dict:
    """The session-built FMUs of ``robot`` (conftest fixtures planar_fmus / spatial_fmus)."""
    return request.getfixturevalue(f"{robot}_fmus")


_COUNTER = [0]


class Inst(FMUInstance):
    """An :class:`FMUInstance` with its own logger (``messages``: (status, category, text)),
    whose ``set``/``step`` return the FMI status instead of raising, for tests of the status
    codes."""

    _extracted: Dict[str, tuple] = {}

    def __init__(self, path: Path, name: str = "instance", logging_on: bool = True):
        from fmpy import extract, read_model_description

        path = str(path)
        if path not in Inst._extracted:             # one extraction per FMU file and session
            Inst._extracted[path] = (read_model_description(path), extract(path))
        _COUNTER[0] += 1
        messages: List[tuple] = []
        cb = logger_callbacks(lambda _inst, status, category, text:
                              messages.append((status, category, text)))
        super().__init__(path, f"conformance-{name}-{_COUNTER[0]}", callbacks=cb,
                         logging_on=logging_on, extracted=Inst._extracted[path])
        self.messages = messages
        self.freed = False
        _LIVE.append(self)

    # -- variables ----------------------------------------------------------------------------
    def set(self, name: str, value) -> int:
        """fmi2SetReal / fmi2SetInteger of one variable; returns the status (fmpy raises
        FMICallException above Warning)."""
        from fmpy.fmi2 import fmi2Integer, fmi2Real, fmi2ValueReference

        v = self.vars[name]
        vr = (fmi2ValueReference * 1)(v.valueReference)
        if v.type == "Integer":
            return self.fmu.fmi2SetInteger(self.fmu.component, vr, 1, (fmi2Integer * 1)(int(value)))
        return self.fmu.fmi2SetReal(self.fmu.component, vr, 1, (fmi2Real * 1)(float(value)))

    def step(self, t: float, dt: float) -> int:
        """fmi2DoStep; returns the status (fmpy raises FMICallException above Warning)."""
        return self.fmu.fmi2DoStep(self.fmu.component, t, dt, 1)

    def call(self, fn, *args):
        """Run ``fn(*args)``; return (FMI status, messages logged during the call)."""
        from fmpy.fmi1 import FMICallException

        n = len(self.messages)
        try:
            res = fn(*args)
            status = res if isinstance(res, int) else OK
        except FMICallException as e:
            status = e.status
        return status, self.messages[n:]

    def free(self) -> None:
        """fmi2FreeInstance only (no fmi2Terminate: the tests choose when to terminate)."""
        if not self.freed:
            self.initialized = False
            super().free()
            self.freed = True
        if self in _LIVE:
            _LIVE.remove(self)


_LIVE: List[Inst] = []


@pytest.fixture(autouse=True)
def free_instances():
    """Free the instances a test left behind (e.g. when an assertion failed half way)."""
    yield
    while _LIVE:
        _LIVE[-1].free()


def plant_samples(fmus: dict, n: int, dt: float = DT, params: Optional[dict] = None):
    """Run the plant alone for ``n`` steps; returns (input names of the estimator, samples),
    samples[k] = plant outputs at t = k dt in the estimator's input order (k = 0..n)."""
    key = (str(fmus["plant"]), n, dt, tuple(sorted((params or {}).items())))
    if key not in _SAMPLES:
        est = Inst(fmus["estimator"], "probe")
        names = est.names("input")
        est.free()
        plant = Inst(fmus["plant"], "sampler").init(params)
        rows = [list(plant.values(names).values())]
        for k in range(n):
            plant.step(k * dt, dt)
            rows.append(list(plant.values(names).values()))
        plant.fmu.terminate()
        plant.free()
        _SAMPLES[key] = (names, np.array(rows))
    names, rows = _SAMPLES[key]
    return names, rows.copy()


_SAMPLES: dict = {}


def feed(est: Inst, names, samples, k0: int = 0, dt: float = DT, record: bool = False):
    """Feed samples[k0:] to the estimator, one doStep(k dt, dt) each; returns the outputs after
    each step if ``record``."""
    hist = []
    for k in range(k0, len(samples)):
        est.set_many(names, samples[k])
        assert est.step(k * dt, dt) == OK
        if record:
            hist.append(est.outputs())
    return hist


def as_array(d: Dict[str, float]) -> np.ndarray:
    return np.array(list(d.values()), dtype=float)


def assert_same(a: Dict[str, float], b: Dict[str, float], what: str = "") -> None:
    """Bitwise equality of two name -> value dicts (NaN equal to NaN)."""
    assert list(a) == list(b)
    x, y = as_array(a), as_array(b)
    same = (x == y) | (np.isnan(x) & np.isnan(y))
    bad = [n for n, s in zip(a, same) if not s]
    assert not bad, f"{what}: differ in {bad[:8]}: " + ", ".join(
        f"{n}: {a[n]!r} vs {b[n]!r}" for n in bad[:4])


def skip_unless(cond: bool, reason: str) -> None:
    if not cond:
        pytest.skip(reason)
