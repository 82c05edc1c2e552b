"""Interface conformance (issue #5), part 5: a host that is not Python.

tests/c_host/fmu_host.c is compiled here with the system C compiler against fmpy's bundled FMI
2.0 headers. It dlopen()s the FMU binaries and drives them through the FMI C API, in the
environment docs/fmus.md documents for pythonfmu FMUs in non-Python hosts:

    LD_PRELOAD=<LIBDIR>/<LDLIBRARY>   (the shared libpython the FMU's Python code needs)
    PYTHONHOME=<sys.base_prefix>
    PYTHONPATH=<the entries of this interpreter's sys.path> (numpy, pinocchio, ...)

- the plant alone for 20 steps: every output equals fmpy's run of the same FMU to 1e-12, and a
  state serialised in C, restored and re-run gives bit-identical values;
- plant and estimator wired in C: the estimates equal fmpy's wired run to 1e-12;
- without LD_PRELOAD the binary cannot even be loaded (the requirement is real).

Skipped, with the reason, when there is no C compiler, no shared libpython or no FMI headers.
"""
from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import numpy as np
import pytest

from test_conformance_util import free_instances  # noqa: F401  (autouse fixture)
from test_conformance_util import DT, OK, ROBOTS, Inst, c_compiler, fmus_for

SOURCE = Path(__file__).parent / "c_host" / "fmu_host.c"
N = 20


def libpython() -> Path | None:
    cfg = sysconfig.get_config_vars()
    if not cfg.get("Py_ENABLE_SHARED"):
        return None
    path = Path(cfg.get("LIBDIR") or "", cfg.get("LDLIBRARY") or "")
    return path if path.is_file() and path.suffix.startswith(".so") else None


def fmi_headers() -> Path | None:
    import fmpy

    d = Path(fmpy.__file__).parent / "c-code"
    return d if (d / "fmi2Functions.h").is_file() else None


def host_environment(preload: bool = True) -> dict:
    env = dict(os.environ)
    if preload:
        env["LD_PRELOAD"] = str(libpython())
    else:
        env.pop("LD_PRELOAD", None)
    env["PYTHONHOME"] = sys.base_prefix
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p and os.path.isdir(p))
    return env


@pytest.fixture(scope="module")
def host(tmp_path_factory) -> Path:
    if sys.platform != "linux":
        pytest.skip("the C host test is written for Linux (dlopen, binaries/linux64)")
    cc = c_compiler()
    if cc is None:
        pytest.skip("no C compiler (cc, gcc or clang) on PATH")
    if libpython() is None:
        pytest.skip("this Python has no shared libpython (Py_ENABLE_SHARED = 0): a non-Python "
                    "host cannot load a pythonfmu FMU with it")
    if fmi_headers() is None:
        pytest.skip("fmpy's FMI 2.0 headers (fmpy/c-code/fmi2Functions.h) not found")
    exe = tmp_path_factory.mktemp("c_host") / "fmu_host"
    r = subprocess.run([cc, "-std=c99", "-D_POSIX_C_SOURCE=200809L", "-Wall", "-Wextra",
                        "-Werror", "-O1", f"-I{fmi_headers()}", "-o", str(exe), str(SOURCE),
                        "-ldl"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return exe


class Unzipped:
    def __init__(self, path: Path):
        from fmpy import extract, read_model_description

        self.md = read_model_description(str(path))
        self.dir = Path(extract(str(path)))
        self.so = self.dir / "binaries" / "linux64" / f"{self.md.coSimulation.modelIdentifier}.so"
        self.uri = (self.dir / "resources").as_uri()
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.reals = [v.name for v in self.md.modelVariables
                      if v.causality == "output" and v.type == "Real"]


def run_host(host: Path, args, preload=True) -> subprocess.CompletedProcess:
    return subprocess.run([str(host), *map(str, args)], capture_output=True, text=True,
                          env=host_environment(preload), timeout=300)


def parse(stdout: str) -> np.ndarray:
    return np.array([[float(x) for x in line.split(",")] for line in stdout.strip().splitlines()])


@pytest.mark.parametrize("robot", ROBOTS)
def test_c_host_runs_the_plant_like_fmpy(request, host, robot):
    fmus = fmus_for(request, robot)
    plant = Unzipped(fmus["plant"])
    r = run_host(host, ["-s", N // 2, plant.so, plant.md.guid, plant.uri, DT, N,
                        ",".join(str(plant.vr[n]) for n in plant.reals)])
    assert r.returncode == 0, r.stderr[-3000:]
    assert "state round trip after step 10" in r.stderr and "identical" in r.stderr
    c_rows = parse(r.stdout)
    assert c_rows.shape == (N + 1, 1 + len(plant.reals))

    inst = Inst(fmus["plant"], "fmpy").init()
    rows = [[0.0, *inst.values(plant.reals).values()]]
    for k in range(N):
        assert inst.step(k * DT, DT) == OK
        rows.append([(k + 1) * DT, *inst.values(plant.reals).values()])
    inst.free()
    py_rows = np.array(rows)
    scale = np.maximum(np.abs(py_rows), 1.0)
    err = np.max(np.abs(c_rows - py_rows) / scale)
    assert err <= 1e-12, err
    assert np.ptp(py_rows[:, 1:], axis=0).max() > 0.1     # it did move


@pytest.mark.parametrize("robot", ROBOTS)
def test_c_host_wires_plant_and_estimator_like_fmpy(request, host, robot):
    fmus = fmus_for(request, robot)
    plant, est = Unzipped(fmus["plant"]), Unzipped(fmus["estimator"])
    inputs = [v.name for v in est.md.modelVariables if v.causality == "input"]
    estimates = [n for n in est.reals if not n.startswith(("sd.", "diag."))]
    wires = ",".join(f"{plant.vr[n]}:{est.vr[n]}" for n in inputs)
    r = run_host(host, ["-e", est.so, "-g", est.md.guid, "-r", est.uri, "-w", wires,
                        "-o", ",".join(str(est.vr[n]) for n in estimates),
                        plant.so, plant.md.guid, plant.uri, DT, N, plant.vr["base.r[1]"]])
    assert r.returncode == 0, r.stderr[-3000:]
    c_est = parse(r.stdout)[:, 2:]

    p, e = Inst(fmus["plant"], "fmpy-plant").init(), Inst(fmus["estimator"], "fmpy-est").init()
    rows = [list(e.values(estimates).values())]
    for k in range(N):
        e.set_many(inputs, list(p.values(inputs).values()))
        assert p.step(k * DT, DT) == OK
        assert e.step(k * DT, DT) == OK
        rows.append(list(e.values(estimates).values()))
    p.free()
    e.free()
    py_est = np.array(rows)
    err = np.max(np.abs(c_est - py_est) / np.maximum(np.abs(py_est), 1.0))
    assert err <= 1e-12, err
    assert np.abs(py_est[-1] - py_est[0]).max() > 1.0     # the estimates did move


def test_c_host_needs_libpython_preloaded(request, host):
    plant = Unzipped(fmus_for(request, "planar")["plant"])
    r = run_host(host, [plant.so, plant.md.guid, plant.uri, DT, 1, 0], preload=False)
    assert r.returncode == 2 and "undefined symbol" in r.stderr, r.stderr[-2000:]
