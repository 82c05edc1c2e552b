"""The estimator never imports plant code or Pinocchio, in the library and in its FMUs (native
and pythonfmu-hosted)."""
import ast
import re
import zipfile
from pathlib import Path

import pytest

from spacerobot.fmi.build import BUNDLES, build_fmu
from spacerobot.robots import scenario

ROOT = Path(__file__).resolve().parents[1]

LIB = Path(__file__).resolve().parents[1] / "spacerobot"
FORBIDDEN = ("pinocchio", "plant")


def imported_modules(path: Path):
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            yield ("." * node.level) + (node.module or "")


def estimator_sources():
    for item in BUNDLES["estimator"]:
        p = LIB / item
        yield from (sorted(p.rglob("*.py")) if p.is_dir() else [p])


@pytest.mark.parametrize("path", list(estimator_sources()), ids=lambda p: p.name)
def test_estimator_bundle_sources_do_not_import_plant_or_pinocchio(path):
    for mod in imported_modules(path):
        parts = mod.lstrip(".").split(".")
        assert not any(p in FORBIDDEN for p in parts), f"{path} imports {mod}"


@pytest.fixture(scope="module")
def python_estimator(tmp_path_factory):
    """The pythonfmu-hosted estimator FMU (``--backend pythonfmu``)."""
    return build_fmu("estimator", scenario("planar"), tmp_path_factory.mktemp("py"),
                     backend="pythonfmu")


def test_native_estimator_sources_include_no_plant_code():
    """The native estimator's binary is built from the core modules listed for it, none of
    which is the plant's dynamics or the sensors, and none includes their headers."""
    import importlib.util
    import sys
    spec = importlib.util.spec_from_file_location("native_build", ROOT / "native" / "build.py")
    nb = sys.modules.setdefault("native_build", importlib.util.module_from_spec(spec))
    spec.loader.exec_module(nb)
    sources = [ROOT / "native" / "src" / n for n in nb.MODEL_SOURCES["estimator"]]
    sources += [ROOT / "fmu_estimator" / "estimator.c", *(ROOT / "native" / "fmi").glob("*.c")]
    for src in sources:
        assert src.stem not in ("dynamics", "sensors", "rng"), src
        for inc in re.findall(r'#include\s+"([^"]+)"', src.read_text()):
            assert inc not in ("dynamics.h", "sensors.h", "rng.h"), (src, inc)


def test_native_estimator_fmu_contains_no_plant_code(planar_fmus):
    """No Python, and no symbol of the plant's dynamics or the sensors in its binaries."""
    z = zipfile.ZipFile(planar_fmus["estimator"])
    assert not [n for n in z.namelist() if n.endswith(".py")]
    for n in z.namelist():
        if n.startswith("binaries/"):
            data = z.read(n)
            assert data and b"sr_dyn_" not in data and b"sr_sensors_" not in data, n


def test_estimator_fmu_contains_no_plant_code(python_estimator):
    names = zipfile.ZipFile(python_estimator).namelist()
    assert any(n.endswith("_spacerobot_estimator/estimator/identifier.py") for n in names)
    assert not any("/plant/" in n or n.endswith("/plant") for n in names), names
    for n in names:
        if n.endswith(".py") and "pythonfmu/" not in n:
            src = zipfile.ZipFile(python_estimator).read(n).decode()
            assert "pinocchio" not in src.replace("Pinocchio", ""), n


def test_the_two_fmus_bundle_their_library_under_distinct_names(python_estimator,
                                                                tmp_path_factory):
    """The pythonfmu-hosted plant and estimator each bundle the library under their own name;
    the plant carries the native core's library (its plant runs on it)."""
    python_plant = build_fmu("plant", scenario("planar"), tmp_path_factory.mktemp("pyplant"),
                             backend="pythonfmu")
    plant_names = zipfile.ZipFile(python_plant).namelist()
    est_names = zipfile.ZipFile(python_estimator).namelist()
    plant = {n.split("/")[1] for n in plant_names if n.startswith("resources/_spacerobot")}
    est = {n.split("/")[1] for n in est_names if n.startswith("resources/_spacerobot")}
    assert plant == {"_spacerobot_plant"} and est == {"_spacerobot_estimator"}
    assert "resources/_spacerobot_plant/core/lib/libspacerobot.so" in plant_names
