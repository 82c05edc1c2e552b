"""The estimator never imports plant code or Pinocchio, in the library and in its FMU."""
import ast
import re
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

LIB = Path(__file__).resolve().parents[1] / "spacerobot"
FORBIDDEN = ("pinocchio", "plant")
#: the library the estimator runs on (``spacerobot.estimator`` and what it imports)
ESTIMATOR_LIBRARY = ("robots.py", "interface.py", "kinematics.py", "core", "estimator")


def imported_modules(path: Path):
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            yield ("." * node.level) + (node.module or "")


def estimator_sources():
    for item in ESTIMATOR_LIBRARY:
        p = LIB / item
        yield from (sorted(p.rglob("*.py")) if p.is_dir() else [p])


@pytest.mark.parametrize("path", list(estimator_sources()), ids=lambda p: p.name)
def test_estimator_bundle_sources_do_not_import_plant_or_pinocchio(path):
    for mod in imported_modules(path):
        parts = mod.lstrip(".").split(".")
        assert not any(p in FORBIDDEN for p in parts), f"{path} imports {mod}"


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
