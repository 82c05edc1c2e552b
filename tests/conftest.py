"""Shared fixtures: FMUs built once per test session (each pytest-xdist worker has its own), and the pair of them stepped by the
project's co-simulation loop (:class:`spacerobot.Master`), with a hook to inject samples.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description

from spacerobot import interface
from spacerobot.fmi.build import build_fmu
from spacerobot.robots import PLANAR, scenario
from spacerobot import FMUInstance, Master, logger_callbacks


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fmus")


_BUILT: dict = {}


def built_fmus(robot: str, out: Path) -> dict:
    """``{'plant': Path, 'estimator': Path, 'sensors': Path}`` for ``robot``, built once per
    session."""
    if robot not in _BUILT:
        sc = scenario(robot)
        d = out / robot
        _BUILT[robot] = {kind: build_fmu(kind, sc, d) for kind in ("plant", "estimator", "sensors")}
    return _BUILT[robot]


@pytest.fixture(scope="session")
def planar_fmus(fmu_dir) -> dict:
    return built_fmus("planar", fmu_dir)


@pytest.fixture(scope="session")
def spatial_fmus(fmu_dir) -> dict:
    return built_fmus("spatial", fmu_dir)


#: an instantiated FMU with name-based get/set (fmpy low-level API)
Slave = FMUInstance


_EXTRACTED: dict = {}


def logged_slave(path, name: str) -> Slave:
    """A conftest ``Slave`` instantiated with its own logger
    (:func:`spacerobot.logger_callbacks`); ``slave.messages`` collects
    (status, category, message) tuples."""
    key = str(path)
    if key not in _EXTRACTED:
        _EXTRACTED[key] = (read_model_description(key), extract(key))
    messages = []
    cb = logger_callbacks(lambda _inst, status, category, text:
                          messages.append((status, category, text)))
    s = Slave(path, name, callbacks=cb, logging_on=True, extracted=_EXTRACTED[key])
    s.messages = messages
    return s


def started_slave(path, params: dict, name: str) -> Slave:
    """A :func:`logged_slave` set up at t = 0, with ``params`` set, and initialised."""
    return logged_slave(path, name).init(params)


FMI_ERROR = 3


def assert_initialisation_fails(path, params: dict, words) -> None:
    """Setting ``params`` makes fmi2ExitInitializationMode fail with fmi2Error and a logged
    error containing every one of ``words``; the instance is freed afterwards."""
    from fmpy.fmi1 import FMICallException

    s = logged_slave(path, "bad")
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    for k, v in params.items():
        s.set(k, v)
    with pytest.raises(FMICallException) as exc:
        s.fmu.exitInitializationMode()
    assert exc.value.status == FMI_ERROR
    errors = [m for st, _, m in s.messages if st >= FMI_ERROR]
    assert any(all(w in m for w in words) for m in errors), (words, s.messages)
    s.fmu.freeInstance()


class Pair:
    """Plant and estimator FMUs wired name-to-name, stepped at ``dt`` by :class:`Master`."""

    def __init__(self, fmus: dict, plant_params: dict | None = None,
                 est_params: dict | None = None):
        self.plant = Slave(fmus["plant"], "plant").init(plant_params)
        self.est = Slave(fmus["estimator"], "estimator").init(est_params)
        self.inputs = self.est.names("input")
        self.master = Master({"plant": self.plant, "estimator": self.est},
                             [("plant", n, "estimator", n) for n in self.inputs])
        self._read = self.plant.reader(self.inputs)
        self.t = 0.0

    def sample(self) -> np.ndarray:
        return self._read()

    def step(self, dt: float = 0.1, sample: np.ndarray | None = None) -> None:
        """Feed the plant outputs (or ``sample`` instead) to the estimator, then step both."""
        self.master.exchange()
        if sample is not None:
            self.est.set_many(self.inputs, sample)
        self.master.do_step(self.t, dt)
        self.t += dt

    def estimates(self) -> dict:
        return {n: self.est.get(n) for n in self.est.names("output")}

    def free(self) -> None:
        self.plant.free()
        self.est.free()


#: a 5-joint arm on a 900 kg hub: a servicer the estimator's options were not developed on
ARM5_URDF = str(Path(__file__).resolve().parent / "data" / "arm5.urdf")


def truth_vector(sc) -> np.ndarray:
    """Truth in the order of Identifier.vector(): base m, b, I6, target m, b, I6."""
    return interface.estimate_vector(sc.robot.base, sc.target)


ESTIMATE_NAMES = list(interface.ESTIMATE_NAMES)

#: indices of the parameters identified by the planar model (x, y translation, z rotation)
PLANAR_IDENTIFIED = [ESTIMATE_NAMES.index(n) for n in interface.identified_estimates(PLANAR)]


#: |est - truth| / |truth|, relative to the body's scale where the truth is zero
relative_errors = interface.relative_errors
