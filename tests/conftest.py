"""Shared fixtures: FMUs built once per test session, and a minimal fmpy loop over the pair.

The loop here is deliberately low level (it lets tests inject samples, save/restore state, and
read every output); the SSP runner in ``spacerobot.system`` is tested separately.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)

from spacerobot import interface
from spacerobot.fmi.build import build_fmu
from spacerobot.robots import PLANAR, scenario


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fmus")


_BUILT: dict = {}


def built_fmus(robot: str, out: Path) -> dict:
    """``{'plant': Path, 'estimator': Path}`` for ``robot``, built once per session."""
    if robot not in _BUILT:
        sc = scenario(robot)
        d = out / robot
        _BUILT[robot] = {"plant": build_fmu("plant", sc, d), "estimator": build_fmu("estimator", sc, d)}
    return _BUILT[robot]


@pytest.fixture(scope="session")
def planar_fmus(fmu_dir) -> dict:
    return built_fmus("planar", fmu_dir)


@pytest.fixture(scope="session")
def spatial_fmus(fmu_dir) -> dict:
    return built_fmus("spatial", fmu_dir)


class Slave:
    """An instantiated FMU with name-based get/set (fmpy low-level API)."""

    def __init__(self, path: Path, name: str):
        self.md = read_model_description(str(path))
        self.dir = extract(str(path))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier,
                             instanceName=name)
        self.fmu.instantiate()

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

    def names(self, causality: str):
        return [n for n, v in self.vars.items() if v.causality == causality]

    def free(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()


_EXTRACTED: dict = {}


def logged_slave(path, name: str) -> Slave:
    """A conftest ``Slave`` instantiated with its own logger; ``slave.messages`` collects
    (status, category, message) tuples.

    The logger is called directly, not through fmpy's ``addLoggerProxy``: that proxy holds ONE
    process-wide Python target (the last registered), which would redirect the messages of
    every other instance in the test session. Our FMUs pass the whole message as the printf
    format string with ``%`` escaped, so ``%%`` is undone here.
    """
    s = Slave.__new__(Slave)
    key = str(path)
    if key not in _EXTRACTED:
        _EXTRACTED[key] = (read_model_description(key), extract(key))
    s.md, s.dir = _EXTRACTED[key]
    s.vars = {v.name: v for v in s.md.modelVariables}
    s.messages = []

    def logger(env, instance, status, category, message):
        try:
            s.messages.append((int(status), (category or b"").decode("utf-8", "replace"),
                               (message or b"").decode("utf-8", "replace").replace("%%", "%")))
        except Exception:       # never let an exception cross the C boundary
            pass

    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(logger)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    s._callbacks = (cb, logger)      # alive as long as the slave object
    s.fmu = FMU2Slave(guid=s.md.guid, unzipDirectory=s.dir,
                      modelIdentifier=s.md.coSimulation.modelIdentifier, instanceName=name)
    s.fmu.instantiate(callbacks=cb, loggingOn=True)
    return s


def started_slave(path, params: dict, name: str) -> Slave:
    """A :func:`logged_slave` set up at t = 0, with ``params`` set, and initialised."""
    s = logged_slave(path, name)
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    for k, v in params.items():
        s.set(k, v)
    s.fmu.exitInitializationMode()
    return s


FMI_ERROR, FMI_FATAL = 3, 4


def assert_initialisation_fails(path, params: dict, words) -> None:
    """Setting ``params`` makes fmi2ExitInitializationMode fail with fmi2Fatal (pythonfmu's
    status for a Python exception) and a logged error containing every one of ``words``; the
    instance is freed afterwards."""
    from fmpy.fmi1 import FMICallException

    s = logged_slave(path, "bad")
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    for k, v in params.items():
        s.set(k, v)
    with pytest.raises(FMICallException) as exc:
        s.fmu.exitInitializationMode()
    assert exc.value.status == FMI_FATAL
    errors = [m for st, _, m in s.messages if st >= FMI_ERROR]
    assert any(all(w in m for w in words) for m in errors), (words, s.messages)
    s.fmu.freeInstance()


class Pair:
    """Plant and estimator FMUs wired name-to-name, stepped at ``dt``."""

    def __init__(self, fmus: dict, plant_params: dict | None = None,
                 est_params: dict | None = None):
        self.plant = Slave(fmus["plant"], "plant")
        self.est = Slave(fmus["estimator"], "estimator")
        for s, params in ((self.plant, plant_params or {}), (self.est, est_params or {})):
            s.fmu.setupExperiment(startTime=0.0)
            s.fmu.enterInitializationMode()
            for k, v in params.items():
                s.set(k, v)
            s.fmu.exitInitializationMode()
        self.inputs = self.est.names("input")
        self._pvr = [self.plant.vars[n].valueReference for n in self.inputs]
        self._evr = [self.est.vars[n].valueReference for n in self.inputs]
        self.t = 0.0

    def sample(self) -> np.ndarray:
        return np.array(self.plant.fmu.getReal(self._pvr))

    def step(self, dt: float = 0.1, sample: np.ndarray | None = None) -> None:
        """Feed the plant outputs (or ``sample``) to the estimator, then step both."""
        self.est.fmu.setReal(self._evr, list(self.sample() if sample is None else sample))
        self.plant.fmu.doStep(self.t, dt)
        self.est.fmu.doStep(self.t, dt)
        self.t += dt

    def estimates(self) -> dict:
        return {n: self.est.get(n) for n in self.est.names("output")}

    def free(self) -> None:
        self.plant.free()
        self.est.free()


def truth_vector(sc) -> np.ndarray:
    """Truth in the order of Identifier.vector(): base m, b, I6, target m, b, I6."""
    return np.concatenate([[sc.robot.base.mass], sc.robot.base.com, sc.robot.base.inertia,
                           [sc.target.mass], sc.target.com, sc.target.inertia])


ESTIMATE_NAMES = list(interface.ESTIMATE_NAMES)

#: indices of the parameters identified by the planar model (x, y translation, z rotation)
PLANAR_IDENTIFIED = [ESTIMATE_NAMES.index(n) for n in interface.identified_estimates(PLANAR)]


def relative_errors(est: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """|est - truth| / |truth|; for a zero truth (CoM component, product of inertia) the error
    is taken relative to the body's scale: 1 m for b, the largest principal moment for I."""
    est, truth = np.asarray(est, float), np.asarray(truth, float)
    scale = np.abs(truth).copy()
    for k in range(2):
        o = 10 * k
        Imax = np.max(np.abs(truth[o + 4:o + 7]))
        for i in range(o, o + 10):
            if scale[i] == 0.0:
                scale[i] = 1.0 if i - o < 4 else Imax
    return np.abs(est - truth) / scale
