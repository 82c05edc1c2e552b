"""What the pythonfmu-hosted FMUs (``--backend pythonfmu``) carry: only the platform they were
built on (the bundled core library and the Python runtime record are this machine's; pythonfmu's
stock win64 / darwin64 binaries are dropped), and the estimator and sensors no truth (their
scenario file has placeholder bodies and zero initial velocities; the plant keeps the truth it
simulates). The native FMUs: tests/test_native_fmu.py, test_native_plant_fmu.py,
test_native_sensors_fmu.py."""
from __future__ import annotations

import json
import zipfile

import pytest

from spacerobot.fmi.build import build_fmu
from spacerobot.fmi.native import PLACEHOLDER_BODY
from spacerobot.robots import scenario


@pytest.fixture(scope="module")
def py_fmus(tmp_path_factory):
    sc = scenario("spatial")
    d = tmp_path_factory.mktemp("pyfmus")
    return sc, {k: build_fmu(k, sc, d, backend="pythonfmu") for k in ("plant", "estimator", "sensors")}


@pytest.mark.parametrize("kind", ["plant", "estimator", "sensors"])
def test_only_this_platform_is_claimed(py_fmus, kind):
    _, fmus = py_fmus
    with zipfile.ZipFile(fmus[kind]) as zf:
        plats = {n.split("/")[1] for n in zf.namelist() if n.startswith("binaries/")}
    assert plats == {"linux64"}


@pytest.mark.parametrize("kind", ["estimator", "sensors"])
def test_no_truth_in_the_estimator_and_the_sensors(py_fmus, kind):
    sc, fmus = py_fmus
    with zipfile.ZipFile(fmus[kind]) as zf:
        carried = json.loads(zf.read("resources/spacerobot_config.json"))["scenario"]
    text = json.dumps(carried)
    for body in (sc.target, sc.robot.base):             # no truth value anywhere in the file
        assert repr(float(body.mass)) not in text
    assert carried["target"]["mass"] == PLACEHOLDER_BODY.mass
    assert carried["robot"]["base"]["mass"] == PLACEHOLDER_BODY.mass
    assert carried["v0"] == [0.0, 0.0, 0.0] and carried["omega0"] == [0.0, 0.0, 0.0]


def test_the_plant_carries_its_truth(py_fmus):
    sc, fmus = py_fmus
    with zipfile.ZipFile(fmus["plant"]) as zf:
        carried = json.loads(zf.read("resources/spacerobot_config.json"))["scenario"]
    assert carried["target"]["mass"] == sc.target.mass
