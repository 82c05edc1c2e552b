"""The pythonfmu-hosted FMUs (``--backend pythonfmu``) in a Python without the project: a
virtual environment that holds only fmpy and numpy (the FMUs' runtime packages; no Numba, no
Pinocchio) runs the pythonfmu plant and estimator from fmpy, wired, in a fresh process. Their
bundles carry the library, the native core's binding and its compiled library, so they give
the estimates they give here (to 1e-12), which are the library's Plant + Identifier's on the
same run (to 1e-12).
"""
from __future__ import annotations

import importlib.metadata as metadata
import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from conftest import Pair

N = 8                                   # communication steps of 0.1 s
RUNTIME = ("fmpy", "numpy")           # what the venv gets, with their requirements

FMU_RUN = textwrap.dedent("""
    import json, sys
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    def open_fmu(path, name):
        md = read_model_description(path)
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path),
                        modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        fmu.instantiate(); fmu.setupExperiment(startTime=0.0); fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        return fmu, {v.name: v for v in md.modelVariables}

    plant, pv = open_fmu(sys.argv[1], "plant")
    est, ev = open_fmu(sys.argv[2], "estimator")
    inputs = [n for n, v in ev.items() if v.causality == "input"]
    outputs = [n for n, v in ev.items() if v.causality == "output" and v.type == "Real"]
    vr_out, vr_in = [pv[n].valueReference for n in inputs], [ev[n].valueReference for n in inputs]
    for k in range(int(sys.argv[3])):
        est.setReal(vr_in, plant.getReal(vr_out))
        plant.doStep(k * 0.1, 0.1); est.doStep(k * 0.1, 0.1)
    print(json.dumps(dict(zip(outputs, est.getReal([ev[n].valueReference for n in outputs])))))
    for f in (plant, est): f.terminate(); f.freeInstance()
""")

LIBRARY_RUN = textwrap.dedent("""
    import json, sys
    from spacerobot.estimator import Identifier
    from spacerobot.plant import Plant
    from spacerobot.robots import scenario

    sc = scenario("planar")
    plant = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h)
    ident = Identifier(sc.robot, sc.guess, method="momentum")
    for k in range(int(sys.argv[1])):
        ident.update(k * 0.1, plant.outputs())
        plant.advance(0.1)
    print(json.dumps([float(x) for x in ident.vector()]))
""")


def _closure(names) -> set:
    """Distributions ``names`` need, with their requirements (installed ones)."""
    seen, todo = set(), list(names)
    while todo:
        name = todo.pop()
        try:
            dist = metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue                    # an optional or platform-specific requirement
        key = re.sub(r"[-_.]+", "-", dist.metadata["Name"]).lower()
        if key in seen:
            continue
        seen.add(key)
        todo += [re.match(r"[A-Za-z0-9_.-]+", r).group(0) for r in dist.requires or []
                 if "extra ==" not in r]
    return seen


@pytest.fixture(scope="module")
def runtime_venv(tmp_path_factory) -> Path:
    """A venv with fmpy and the FMUs' runtime packages only: their files are linked from this
    environment's site-packages (no download), the project and its editable finder are not."""
    root = tmp_path_factory.mktemp("venv")
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(root)], check=True)
    python = root / "bin" / "python"
    site = Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig."
                                "get_paths()['purelib'])"], capture_output=True, text=True,
                               check=True).stdout.strip())
    dists = _closure(RUNTIME)
    assert "spacerobot" not in dists
    for name in dists:
        dist = metadata.distribution(name)
        for top in {f.parts[0] for f in dist.files or [] if f.parts[0] not in ("..", "__pycache__")}:
            src = Path(dist.locate_file(top))
            if src.exists() and not (site / top).exists():
                (site / top).symlink_to(src)
    r = subprocess.run([str(python), "-c", "import spacerobot"], capture_output=True, text=True,
                       env=_env(), cwd=str(root))
    assert r.returncode != 0 and "No module named 'spacerobot'" in r.stderr
    return python


def _env() -> dict:
    return {k: v for k, v in os.environ.items()
            if not k.startswith(("PYTHON", "SPACEROBOT_CORE_LIB"))}


def _run(python, script: str, args, cwd: Path) -> subprocess.CompletedProcess:
    cwd.mkdir(parents=True, exist_ok=True)
    r = subprocess.run([str(python), "-c", script, *map(str, args)], capture_output=True,
                       text=True, env=_env(), timeout=900, cwd=str(cwd))
    assert r.returncode == 0, r.stderr[-4000:]
    return r


def _fmu_estimates(planar_fmus) -> dict:
    pair = Pair(planar_fmus)
    try:
        for _ in range(N):
            pair.step(0.1)
        return pair.estimates()
    finally:
        pair.free()


def test_pythonfmus_run_without_the_project(runtime_venv, tmp_path):
    """The pythonfmu-hosted plant and estimator run from fmpy in a Python without the project
    and give the estimates they give here (to 1e-12), which are the library's Plant +
    Identifier's (to 1e-12)."""
    from spacerobot.fmi.build import build_fmu
    from spacerobot.robots import scenario

    python_fmus = {k: build_fmu(k, scenario("planar"), tmp_path / "py", backend="pythonfmu")
                   for k in ("plant", "estimator")}
    reference = _fmu_estimates(python_fmus)
    got = json.loads(_run(runtime_venv, FMU_RUN, [python_fmus["plant"], python_fmus["estimator"],
                                                  N], tmp_path / "run").stdout)
    assert len(got) > 40 and set(got) <= set(reference)
    for name, value in ((n, reference[n]) for n in got):
        assert abs(got[name] - value) <= 1e-12 * max(1.0, abs(value)), (name, got[name], value)
    lib = json.loads(_run(sys.executable, LIBRARY_RUN, [N], tmp_path / "lib").stdout)
    from spacerobot.interface import ESTIMATE_NAMES
    assert len(lib) == 20 and np.all(np.isfinite(lib))
    for name, value in zip(ESTIMATE_NAMES, lib):
        assert abs(got[name] - value) <= 1e-12 * max(1.0, abs(value)), (name, got[name], value)
