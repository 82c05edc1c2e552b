"""The compiled-kernel cache (spacerobot.jit) shared by the library and the FMUs (issue #13).

Numba's cached code names the module it was compiled in. When the library
(``spacerobot.plant.kernels``) and the FMUs (``_spacerobot_plant.plant.kernels``) shared one
cache folder, whichever came second failed: the library with ``No module named
'_spacerobot_estimator'``, the FMUs in a Python without the project with ``No module named
'spacerobot'``. Here, on fresh caches, in fresh processes:

- the FMUs run first, from fmpy in a virtual environment that holds only fmpy and the FMUs'
  runtime packages (numpy, numba, pin and what they need; not the project), then the core
  library runs on the cache they filled;
- the FMUs run in that environment on a cache the library alone filled, with results equal
  to the same FMUs run here to 1e-12;
- a corrupt cache entry and an unwritable cache fall back with a warning.

Every test file passing on its own on a fresh cache is checked by CI (.ci/each_test_file_alone).
"""
from __future__ import annotations

import importlib.metadata as metadata
import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from conftest import Pair
from spacerobot import jit

N = 8                                   # communication steps of 0.1 s
RUNTIME = ("fmpy", "numpy", "numba", "pin")     # what the venv gets, with their requirements

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
                       env=_env(root / "no-cache"), cwd=str(root))
    assert r.returncode != 0 and "No module named 'spacerobot'" in r.stderr
    return python


def _env(cache: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "NUMBA"))}
    env["SPACEROBOT_CACHE_DIR"] = str(cache)
    return env


def _run(python, script: str, args, cache: Path) -> subprocess.CompletedProcess:
    r = subprocess.run([str(python), "-c", script, *map(str, args)], capture_output=True,
                       text=True, env=_env(cache), timeout=900, cwd=str(cache.parent))
    assert r.returncode == 0, r.stderr[-4000:]
    # the cache is used as it is: no entry written by another user that had to be compiled again
    assert "RuntimeWarning" not in r.stderr, r.stderr[-4000:]
    return r


def _kernel_folders(cache: Path, package: str) -> list:
    """Cache folders of the plant's and the estimator's kernel modules as ``package`` (the
    library or an FMU's bundle) imports them."""
    lib = Path(jit.__file__).parent
    deps = {"plant": ("rigid_body",), "estimator": ()}     # as the packages' jit.load calls
    return [jit.cache_folder(f"{package}.{sub}.kernels", (lib / sub / "kernels.py").read_bytes()
                             + b"".join((lib / sub / f"{d}.py").read_bytes() for d in deps[sub]),
                             cache) for sub in ("plant", "estimator")]


def _fmu_estimates(planar_fmus) -> dict:
    pair = Pair(planar_fmus)
    try:
        for _ in range(N):
            pair.step(0.1)
        return pair.estimates()
    finally:
        pair.free()


def test_fmus_first_then_the_library_then_fmus_after_the_library(planar_fmus, runtime_venv,
                                                                 tmp_path):
    from spacerobot.fmi.build import build_fmu
    from spacerobot.robots import scenario

    # the pythonfmu-hosted estimator, whose Python core compiles kernels (the native one has none)
    python_fmus = {"plant": planar_fmus["plant"],
                   "estimator": build_fmu("estimator", scenario("planar"), tmp_path / "py",
                                          backend="pythonfmu")}
    fmus = [python_fmus["plant"], python_fmus["estimator"], N]
    reference = _fmu_estimates(python_fmus)

    # 1. a fresh cache filled by the FMUs, in a Python without the project
    first = tmp_path / "fmus-first"
    by_fmus = json.loads(_run(runtime_venv, FMU_RUN, fmus, first).stdout)
    for folder in _kernel_folders(first, "_spacerobot_plant")[:1] + \
            _kernel_folders(first, "_spacerobot_estimator")[1:]:
        assert list(folder.glob("__pycache__/*.nbi")), f"the FMUs did not fill {folder}"
    # 2. the core library on the cache the FMUs filled
    lib = json.loads(_run(sys.executable, LIBRARY_RUN, [N], first).stdout)
    assert len(lib) == 20 and np.all(np.isfinite(lib))
    for folder in _kernel_folders(first, "spacerobot"):
        assert list(folder.glob("__pycache__/*.nbi")), f"the library did not fill {folder}"

    # 3. a fresh cache that only the library filled: the FMUs in the venv again
    second = tmp_path / "library-first"
    second.mkdir()
    for folder in _kernel_folders(first, "spacerobot"):
        shutil.copytree(folder, second / folder.name)
    after_lib = json.loads(_run(runtime_venv, FMU_RUN, fmus, second).stdout)

    for got in (by_fmus, after_lib):
        assert len(got) > 40 and set(got) <= set(reference)
        for name, value in ((n, reference[n]) for n in got):
            assert abs(got[name] - value) <= 1e-12 * max(1.0, abs(value)), (name, got[name], value)


KERNEL_DEMO = textwrap.dedent("""
    import numpy as np
    from numba import njit

    @njit(cache=True)
    def twice(x):
        return 2.0 * x
""")


def _demo_package(tmp_path: Path) -> Path:
    pkg = tmp_path / "src" / "srjit_cache_demo"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "kern.py").write_text(KERNEL_DEMO)
    return tmp_path / "src"


def _demo_call(src: Path, cache: Path) -> subprocess.CompletedProcess:
    code = ("import sys, warnings; sys.path.insert(0, sys.argv[1]); warnings.simplefilter('always')\n"
            "import srjit_cache_demo\nfrom spacerobot import jit\n"
            "m = jit.load('srjit_cache_demo', 'kern')\nprint(m.twice(21.0))\n")
    return subprocess.run([sys.executable, "-c", code, str(src)], capture_output=True, text=True,
                          env=_env(cache), timeout=300)


def test_a_corrupt_cache_entry_is_compiled_again_with_a_warning(tmp_path):
    src, cache = _demo_package(tmp_path), tmp_path / "cache"
    first = _demo_call(src, cache)
    assert first.returncode == 0 and first.stdout.strip() == "42.0", first.stderr
    entries = list(cache.glob("kern-*/__pycache__/*.nb[ic]"))
    assert entries, "nothing was cached"
    for entry in entries:
        entry.write_bytes(b"\x80\x04garbage, not a pickle")
    again = _demo_call(src, cache)
    assert again.returncode == 0 and again.stdout.strip() == "42.0", again.stderr
    assert "RuntimeWarning" in again.stderr and "cannot be read" in again.stderr


def test_an_unwritable_cache_falls_back_with_a_warning(tmp_path):
    src = _demo_package(tmp_path)
    blocker = tmp_path / "a_file"           # SPACEROBOT_CACHE_DIR pointing at a file
    blocker.write_text("")
    r = _demo_call(src, blocker / "cache")
    assert r.returncode == 0 and r.stdout.strip() == "42.0", r.stderr
    assert "RuntimeWarning" in r.stderr and "cannot be written" in r.stderr
