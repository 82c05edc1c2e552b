"""The estimator never imports plant code or Pinocchio, in the library and in its FMU."""
import ast
import zipfile
from pathlib import Path

import pytest

from spacerobot.fmi.build import BUNDLES

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


def test_estimator_fmu_contains_no_plant_code(planar_fmus):
    names = zipfile.ZipFile(planar_fmus["estimator"]).namelist()
    assert any(n.endswith("_spacerobot_estimator/estimator/identifier.py") for n in names)
    assert not any("/plant/" in n or n.endswith("/plant") for n in names), names
    for n in names:
        if n.endswith(".py") and "pythonfmu/" not in n:
            src = zipfile.ZipFile(planar_fmus["estimator"]).read(n).decode()
            assert "pinocchio" not in src.replace("Pinocchio", ""), n


def test_the_two_fmus_bundle_their_library_under_distinct_names(planar_fmus):
    plant = {n.split("/")[1] for n in zipfile.ZipFile(planar_fmus["plant"]).namelist()
             if n.startswith("resources/_spacerobot")}
    est = {n.split("/")[1] for n in zipfile.ZipFile(planar_fmus["estimator"]).namelist()
           if n.startswith("resources/_spacerobot")}
    assert plant == {"_spacerobot_plant"} and est == {"_spacerobot_estimator"}
