"""FMI 3.0 FMUs from the same core and FMI layer as the FMI 2.0 ones.

The binaries under test are built from this tree (``native/build.py``: ``fmi_layer.c`` with
``fmi3_api.c``, ``-DFMI_VERSION=3``; the FMI 2.0 ones for the comparison with ``fmi2_api.c``)
into a cache keyed by the sources, then packaged by :func:`spacerobot.fmi.native.build_native_fmu`.

* fmpy validates every FMI 3.0 FMU and simulates it; the outputs equal the FMI 2.0 FMU's (the
  independent computation: the FMI 2.0 layer and fmpy's FMI 2.0 path) to 1e-12 relative;
* fmusim (FMI 3.0, the Reference FMUs' host: ``$SPACEROBOT_FMUSIM``, else
  /tmp/h4/hosts/fmusim/bin/fmusim, as shared/tools/build-hosts.sh builds it) runs each FMU;
* the closed loop plant + estimator (spatial, 60 s) in the project's runner and in a loop over
  fmpy's FMU3Slave equals the FMI 2.0 loop to 1e-12 relative;
* the win64 FMI 3.0 binaries under Wine (a C host, tests/c_host/fmu_host3.c, one source with
  the Linux host, compiled against fmpy's copy of the standard's headers) equal linux64;
* wrong input and illegal calls return fmi3Error (or NULL) with a logged reason;
* the binaries export exactly the standard's fmi3 functions (fmpy's list of them), also those
  built with ``zig cc`` for macOS and ARM Linux (which cannot run here).
"""
from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import tempfile
import threading
import zipfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import native_hosts as nh

ROOT = Path(__file__).resolve().parents[1]
FMUSIM = Path(os.environ.get("SPACEROBOT_FMUSIM", "/tmp/h4/hosts/fmusim/bin/fmusim"))
HOST3 = Path(__file__).resolve().parent / "c_host" / "fmu_host3.c"
KINDS = ("plant", "estimator", "sensors")
ROBOT = "spatial"
RTOL = 1e-12
CACHE = Path(tempfile.gettempdir()) / "spacerobot-fmi3-tests"
_LOCK = threading.Lock()


def _nb():
    """``native/build.py`` as a module (tests/native_hosts.py loads it once)."""
    from native_hosts import native_build
    return native_build()


def _digest() -> str:
    nb = _nb()
    h = hashlib.sha256()
    for p in [ROOT / "native" / "build.py", *sorted(nb.SRC.glob("*")), *sorted(nb.FMI.glob("*")),
              *(nb.model_glue(m) for m in nb.MODELS)]:
        h.update(p.name.encode() + b"\0" + p.read_bytes())
    for plat in nb.PLATFORMS.values():
        cc = plat.compiler()
        if cc:
            h.update(subprocess.run([cc, "--version"], capture_output=True).stdout)
    return h.hexdigest()[:24]


@pytest.fixture(scope="session")
def lib_dir() -> Path:
    """A library folder (``fmu/<platform>/``) with this tree's FMU binaries: FMI 3.0 for
    x86_64-linux (every model) and x86_64-windows (plant, estimator; where mingw is installed),
    FMI 2.0 for linux64 (every model), built in parallel, cached by the sources' digest."""
    nb = _nb()
    out = CACHE / _digest()
    jobs = [(m, "linux64", 3) for m in KINDS] + [(m, "linux64", 2) for m in KINDS]
    if nh.mingw():
        jobs += [(m, "win64", 3) for m in ("plant", "estimator")]
    todo = [(m, p, v) for m, p, v in jobs
            if not (out / "fmu" / nb.PLATFORMS[p].folder(v)
                    / f"{nb.MODELS[m]}{nb.PLATFORMS[p].suffix}").is_file()]
    with ThreadPoolExecutor(max_workers=2) as ex:
        for f in [ex.submit(nb.build_fmu_binary, m, p, out / "fmu", True, v) for m, p, v in todo]:
            f.result()
    return out


@pytest.fixture(scope="session")
def fmus(lib_dir, tmp_path_factory):
    """``{(kind, version): .fmu}`` of the spatial robot's default scenario."""
    from spacerobot.fmi.native import build_native_fmu
    from spacerobot.robots import scenario

    d = tmp_path_factory.mktemp("fmi3_fmus")
    sc = scenario(ROBOT)
    return {(k, v): build_native_fmu(k, sc, d / f"fmi{v}", lib_dir=lib_dir, fmi_version=v)
            for k in KINDS for v in (2, 3)}


def rel_err(a, b) -> float:
    """Largest |a - b| / max(|a|, |b|) (0 where both are equal, zeros included)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape, (a.shape, b.shape)
    diff = np.abs(a - b)
    scale = np.maximum(np.abs(a), np.abs(b))
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(diff == 0, 0.0, diff / scale)
    return float(np.max(r)) if r.size else 0.0


# ---- the model description ---------------------------------------------------------------------
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.slow
def test_fmpy_validates_and_the_variables_are_the_fmi2_ones(fmus, kind):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    f3 = fmus[(kind, 3)]
    assert validate_fmu(str(f3)) == []
    md3, md2 = read_model_description(str(f3)), read_model_description(str(fmus[(kind, 2)]))
    assert md3.fmiVersion == "3.0" and md3.coSimulation is not None
    assert md3.modelExchange is None and md3.scheduledExecution is None
    assert md3.guid != md2.guid                        # another model description
    v3 = {v.name: v for v in md3.modelVariables if v.causality != "independent"}
    v2 = {v.name: v for v in md2.modelVariables}
    assert list(v3) == list(v2)                        # same names, same order
    for name, a in v3.items():
        b = v2[name]
        assert (a.valueReference, a.causality, a.variability) == \
            (b.valueReference, b.causality, b.variability), name
        assert {"Real": "Float64", "Integer": "Int32"}[b.type] == a.type, name
        assert a.start == b.start and a.unit == b.unit, name
    (time,) = [v for v in md3.modelVariables if v.causality == "independent"]
    assert time.name == "time" and time.valueReference == len(v2)
    outs3 = {o.variable.name: sorted(d.name for d in (o.dependencies or []))
             for o in md3.outputs}
    outs2 = {o.variable.name: sorted(d.name for d in (o.dependencies or []))
             for o in md2.outputs}
    assert outs3 == outs2 and len(outs3) == sum(v.causality == "output" for v in v2.values())
    cs = md3.coSimulation
    assert cs.canGetAndSetFMUstate and cs.canSerializeFMUstate and not cs.needsExecutionTool


# ---- fmpy: simulate, compare with FMI 2.0 --------------------------------------------------------
@pytest.mark.parametrize("kind", KINDS)
def test_fmpy_simulates_fmi3_equal_to_fmi2(fmus, kind):
    from fmpy import simulate_fmu

    args = dict(stop_time=5.0, output_interval=0.1)
    r3 = simulate_fmu(str(fmus[(kind, 3)]), **args)
    r2 = simulate_fmu(str(fmus[(kind, 2)]), **args)
    assert r3.dtype.names == r2.dtype.names and len(r3) == len(r2) == 51
    a3 = np.array(r3.tolist(), float)
    a2 = np.array(r2.tolist(), float)
    assert np.all(np.isfinite(a3))
    assert rel_err(a3, a2) <= RTOL
    assert np.ptp(a3[:, 1:], axis=0).max() > 0          # the outputs move


# ---- fmusim ------------------------------------------------------------------------------------
def _read_csv(path: Path):
    import csv
    rows = list(csv.reader(path.read_text().strip().splitlines()))
    return rows[0], np.array([[float(x) for x in r] for r in rows[1:]])


@pytest.mark.parametrize("kind", KINDS)
def test_fmusim_runs_each_fmu(fmus, kind, tmp_path):
    from fmpy import simulate_fmu

    if not FMUSIM.is_file():
        pytest.skip(f"fmusim (FMI 3.0) is not built at {FMUSIM} (shared/tools/build-hosts.sh)")
    out = tmp_path / "fmusim.csv"
    r = nh.run([FMUSIM, "--interface-type", "cs", "--stop-time", "3", "--output-interval", "0.1",
                "--output-file", out, fmus[(kind, 3)]], env=nh.empty_env())
    assert r.returncode == 0, r.stderr[-2000:]
    head, rows = _read_csv(out)
    assert len(rows) == 31 and np.all(np.isfinite(rows))
    ref = simulate_fmu(str(fmus[(kind, 3)]), stop_time=3.0, output_interval=0.1)
    assert rel_err(rows, np.array(ref[head].tolist(), float)) <= 1e-15 * 100   # %.16g text


def test_fmusim_state_round_trip(fmus, tmp_path):
    """fmusim saves the serialised FMU state at 1 s and continues from it: the same as a run
    straight to 2 s (fmi3GetFMUState, fmi3SerializeFMUState, fmi3DeserializeFMUState,
    fmi3SetFMUState)."""
    if not FMUSIM.is_file():
        pytest.skip(f"fmusim (FMI 3.0) is not built at {FMUSIM}")
    fmu = fmus[("plant", 3)]
    state, a, b = tmp_path / "state.bin", tmp_path / "a.csv", tmp_path / "b.csv"
    common = ["--interface-type", "cs", "--output-interval", "0.1"]
    r = nh.run([FMUSIM, *common, "--stop-time", "1", "--final-fmu-state-file", state,
                "--output-file", tmp_path / "first.csv", fmu], env=nh.empty_env())
    assert r.returncode == 0 and state.stat().st_size > 0, r.stderr[-2000:]
    r = nh.run([FMUSIM, *common, "--start-time", "1", "--stop-time", "2",
                "--initial-fmu-state-file", state, "--output-file", b, fmu], env=nh.empty_env())
    assert r.returncode == 0, r.stderr[-2000:]
    r = nh.run([FMUSIM, *common, "--stop-time", "2", "--output-file", a, fmu], env=nh.empty_env())
    assert r.returncode == 0, r.stderr[-2000:]
    ha, ra = _read_csv(a)
    hb, rb = _read_csv(b)
    assert ha == hb
    assert rel_err(rb[-1], ra[-1]) <= 1e-15 * 100


# ---- the closed loop: the project's runner and fmpy --------------------------------------------
@pytest.fixture(scope="session")
def ssps(fmus, tmp_path_factory):
    from spacerobot.system.ssd import build_system

    d = tmp_path_factory.mktemp("fmi3_ssp")
    return {v: build_system(ROBOT, d / f"fmi{v}", fmus={k: fmus[(k, v)] for k in
                                                         ("plant", "estimator")})["ssp"]
            for v in (2, 3)}


@pytest.mark.slow
def test_runner_closed_loop_fmi3_equals_fmi2(ssps):
    from spacerobot.system.runner import run_ssp

    r3, r2 = run_ssp(ssps[3], progress=False), run_ssp(ssps[2], progress=False)
    assert r3.stop_time == r2.stop_time == 60.0 and len(r3.time) == 601
    assert list(r3.data) == list(r2.data) and len(r3.data) > 100
    worst = max(rel_err(r3.data[c], r2.data[c]) for c in r2.data)
    assert worst <= RTOL, worst
    assert r3.final == r2.final and r3.log == r2.log == []
    # the estimator identified something: the loop is not trivially equal
    assert any(abs(r3.final[k] - r3.truth[k]) < 0.1 * abs(r3.truth[k]) for k in r3.truth
               if r3.truth[k])


@pytest.mark.slow
def test_runner_sensors_system_fmi3_equals_fmi2(fmus, tmp_path):
    """The system with the sensors FMU (direct feedthrough, ``realistic`` noise) in the runner:
    FMI 3.0 equals FMI 2.0."""
    from spacerobot.system.runner import run_ssp
    from spacerobot.system.ssd import build_system

    res = {v: run_ssp(build_system(ROBOT, tmp_path / f"fmi{v}", sensors=True,
                                   fmus={k: fmus[(k, v)] for k in KINDS})["ssp"],
                      stop_time=20.0, progress=False) for v in (2, 3)}
    assert list(res[3].data) == list(res[2].data) and len(res[3].time) == 201
    assert max(rel_err(res[3].data[c], res[2].data[c]) for c in res[2].data) <= RTOL
    assert np.ptp(res[3].data["sensors.base.omega[1]"]) > 0


OMSIMULATOR = Path(os.environ.get("SPACEROBOT_OMSIMULATOR",
                                  "/tmp/h4/hosts/OMSimulator/install/bin/OMSimulator"))


def test_omsimulator_runs_the_fmi3_ssp_equal_to_fmi2(ssps, tmp_path):
    """OMSimulator (its FMI 3.0 import) runs the FMI 3.0 .ssp for 60 s from an empty
    environment: every column of its result equals its run of the FMI 2.0 .ssp, in which it
    finds no algebraic loop (its FMI 3.0 import reads no InitialUnknown, docs/fmus.md)."""
    import csv

    if not OMSIMULATOR.is_file():
        pytest.skip(f"OMSimulator is not built at {OMSIMULATOR} (shared/tools/build-hosts.sh)")
    res = {}
    for v in (2, 3):
        out = tmp_path / f"oms{v}.csv"
        r = subprocess.run([str(OMSIMULATOR), "--stopTime=60", f"--resultFile={out}",
                            str(ssps[v])], cwd=tmp_path, capture_output=True, text=True,
                           env=nh.empty_env(), timeout=600)
        assert r.returncode == 0 and out.is_file(), (r.stdout + r.stderr)[-2000:]
        assert "error" not in (r.stdout + r.stderr).lower(), (r.stdout + r.stderr)[-2000:]
        if v == 2:      # every InitialUnknown declares its dependencies: no loop through them
            assert "alg. loop" not in (r.stdout + r.stderr).lower(), r.stdout[-2000:]
        rows = list(csv.reader(out.read_text().splitlines()))
        res[v] = (rows[0], np.array([[float(x) for x in row] for row in rows[1:]]))
    (h2, a2), (h3, a3) = res[2], res[3]
    assert set(h3) - set(h2) == {f"SpaceRobot_{ROBOT}.root.{c}.time"
                                 for c in ("plant", "estimator")}
    cols = [c for c in h2 if c != "time"]
    assert len(cols) > 100 and a3.shape[0] == a2.shape[0] > 600
    assert a3[-1, h3.index("time")] == 60.0
    assert rel_err(a3[:, [h3.index(c) for c in cols]], a2[:, [h2.index(c) for c in cols]]) <= RTOL


def _fmpy_loop(fmus, version: int, stop: float = 60.0, h: float = 0.1):
    """plant + estimator over fmpy's FMU2Slave / FMU3Slave: a Jacobi exchange of the SSD's
    connections at every communication point; returns every output at every point."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    from spacerobot.system.ssd import system_connections

    insts, mds, dirs = {}, {}, []
    for k in ("plant", "estimator"):
        path = str(fmus[(k, version)])
        md = read_model_description(path)
        d = extract(path)
        dirs.append(d)
        cls = FMU3Slave if version == 3 else FMU2Slave
        fmu = cls(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName=k)
        fmu.instantiate()
        if version == 3:
            fmu.enterInitializationMode(startTime=0.0, stopTime=stop)
        else:
            fmu.setupExperiment(startTime=0.0, stopTime=stop)
            fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        insts[k], mds[k] = fmu, {v.name: v for v in md.modelVariables}
    get = {3: lambda f, vr: f.getFloat64(vr), 2: lambda f, vr: f.getReal(vr)}[version]
    put = {3: lambda f, vr, x: f.setFloat64(vr, x), 2: lambda f, vr, x: f.setReal(vr, x)}[version]
    geti = {3: lambda f, vr: f.getInt32(vr), 2: lambda f, vr: f.getInteger(vr)}[version]
    puti = {3: lambda f, vr, x: f.setInt32(vr, x), 2: lambda f, vr, x: f.setInteger(vr, x)}[version]
    wires = []
    for a, ac, b, bc in system_connections(ROBOT):
        va, vb = mds[a][ac], mds[b][bc]
        wires.append((a, va.valueReference, b, vb.valueReference, va.type in ("Real", "Float64")))
    outs = {k: [v.valueReference for v in m.values() if v.causality == "output"
                and v.type in ("Real", "Float64")] for k, m in mds.items()}
    rows = []
    n = int(round(stop / h))
    try:
        for i in range(n + 1):
            t = i * h
            vals = [(b, vrb, real, (get if real else geti)(insts[a], [vra])[0])
                    for a, vra, b, vrb, real in wires]
            for b, vrb, real, x in vals:
                (put if real else puti)(insts[b], [vrb], [x])
            rows.append(np.concatenate([get(insts[k], outs[k]) for k in ("plant", "estimator")]))
            if i < n:
                for k in ("plant", "estimator"):
                    insts[k].doStep(currentCommunicationPoint=t, communicationStepSize=h)
    finally:
        for f in insts.values():
            f.terminate()
            f.freeInstance()
        for d in dirs:
            shutil.rmtree(d, ignore_errors=True)
    return np.array(rows)


@pytest.mark.slow
def test_fmpy_closed_loop_fmi3_equals_fmi2(fmus):
    a3, a2 = _fmpy_loop(fmus, 3), _fmpy_loop(fmus, 2)
    assert a3.shape == a2.shape and a3.shape[0] == 601
    assert np.all(np.isfinite(a3))
    assert rel_err(a3, a2) <= RTOL


# ---- Windows under Wine ------------------------------------------------------------------------
def _fmpy_headers() -> Path:
    import fmpy
    d = Path(fmpy.__file__).parent / "c-code"
    if not (d / "fmi3FunctionTypes.h").is_file():
        pytest.skip(f"fmpy's FMI 3.0 headers ({d}/fmi3FunctionTypes.h) not found")
    return d


def _host(work: Path, platform: str) -> Path:
    inc = _fmpy_headers()
    flags = ["-std=c99", "-O1", "-Wall", "-Wextra", "-Werror", f"-I{inc}"]
    if platform == "linux64":
        exe, cmd = work / "fmu_host3", [nh.require(nh.c_compiler(), "a C compiler")]
        libs = ["-ldl", "-lm"]
    else:
        exe, cmd = work / "fmu_host3.exe", [nh.require(nh.mingw(), "mingw-w64")]
        libs = ["-static-libgcc"]
    r = subprocess.run([*cmd, *flags, "-o", str(exe), str(HOST3), *libs],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return exe


def _unzip(fmu: Path, d: Path) -> Path:
    with zipfile.ZipFile(fmu) as z:
        z.extractall(d)
    return d


def _loop_args(fmus, work: Path, win: bool, stop: float = 20.0):
    """fmu_host3's arguments for the closed loop plant + estimator (wires from the SSD)."""
    from fmpy import read_model_description

    from spacerobot.system.ssd import system_connections

    plat, suf = ("x86_64-windows", ".dll") if win else ("x86_64-linux", ".so")
    parts = {}
    for k in ("plant", "estimator"):
        md = read_model_description(str(fmus[(k, 3)]))
        d = _unzip(fmus[(k, 3)], work / f"{k}_{'win' if win else 'linux'}")
        binary = d / "binaries" / plat / f"{md.coSimulation.modelIdentifier}{suf}"
        res = d / "resources"
        parts[k] = (nh.wine_path(binary) if win else str(binary), md.guid,
                    nh.wine_path(res) + "\\" if win else f"{res}/",
                    {v.name: v for v in md.modelVariables})
    pv, ev = parts["plant"][3], parts["estimator"][3]
    w, b = [], []
    for a, ac, bb, bc in system_connections(ROBOT):
        if a == "plant":
            w.append(f"{pv[ac].valueReference}:{ev[bc].valueReference}")
        else:
            b.append(f"{ev[ac].valueReference}:{pv[bc].valueReference}")
    assert all(pv[ac].type == "Float64" for a, ac, _, _ in system_connections(ROBOT)
               if a == "plant")
    p_out = [v.valueReference for v in pv.values() if v.causality == "output"]
    e_out = [v.valueReference for v in ev.values() if v.causality == "output"
             and v.type == "Float64"]
    return ["-e", parts["estimator"][0], "-g", parts["estimator"][1], "-r", parts["estimator"][2],
            "-w", ",".join(w), "-b", ",".join(b), "-o", ",".join(map(str, e_out)),
            parts["plant"][0], parts["plant"][1], parts["plant"][2], "0.1",
            str(int(round(stop / 0.1))), ",".join(map(str, p_out))]


@pytest.mark.slow
def test_c_host_linux_closed_loop_equals_fmpy(fmus, tmp_path):
    host = _host(tmp_path, "linux64")
    r = nh.run([host, *_loop_args(fmus, tmp_path, False)], env=nh.empty_env())
    assert r.returncode == 0, r.stderr[-3000:]
    rows = nh.parse_csv(r.stdout)
    ref = _fmpy_loop(fmus, 3, stop=20.0)
    assert rows.shape == (201, 1 + ref.shape[1])
    assert rel_err(rows[:, 1:], ref) <= RTOL


@pytest.mark.slow
def test_win64_fmi3_under_wine_equals_linux64(fmus, lib_dir, tmp_path_factory):
    nh.require(nh.wine(), "Wine")
    nh.require(nh.mingw(), "mingw-w64 (x86_64-w64-mingw32-gcc)")
    work = nh.work_dir(tmp_path_factory)
    wd = tmp_path_factory.mktemp("fmi3_wine")
    for k in ("plant", "estimator"):
        assert any(n.startswith("binaries/x86_64-windows/")
                   for n in zipfile.ZipFile(fmus[(k, 3)]).namelist()), k
    linux = nh.run([_host(wd, "linux64"), *_loop_args(fmus, wd, False)], env=nh.empty_env())
    assert linux.returncode == 0, linux.stderr[-3000:]
    r = nh.run_wine(work, [_host(wd, "win64"), *_loop_args(fmus, wd, True)])
    assert r.returncode == 0, r.stderr[-3000:]
    w, lx = nh.parse_csv(r.stdout), nh.parse_csv(linux.stdout)
    assert w.shape == lx.shape and w.shape[0] == 201
    assert rel_err(w, lx) <= RTOL
    assert r.stdout == linux.stdout          # in fact the same text: the same bits (%.17g)


# ---- refused calls -----------------------------------------------------------------------------
class Log(list):
    def __call__(self, env, status, category, message):
        self.append((int(status), category.decode(), message.decode()))


def _slave(fmus, kind="plant", log=None, instantiate=True):
    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Slave

    path = str(fmus[(kind, 3)])
    md = read_model_description(path)
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=extract(path),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="t")
    if instantiate:
        fmu.instantiate(loggingOn=True, logMessage=log)
    return fmu, {v.name: v.valueReference for v in md.modelVariables}


def _error(log, call, *words):
    """``call()`` raises fmpy's FMICallException with fmi3Error, and the last logged message is
    an error naming ``words``."""
    from fmpy.fmi1 import FMICallException
    n = len(log)
    with pytest.raises(FMICallException) as e:
        call()
    assert e.value.status == 3
    assert len(log) > n and log[-1][0] == 3 and log[-1][1] == "logStatusError", log[n:]
    for w in words:
        assert w in log[-1][2], (w, log[-1])


def test_bad_input_and_lifecycle_errors_are_fmi3error_with_a_log_line(fmus):
    log = Log()
    fmu, vr = _slave(fmus, log=log)
    out, par = vr["base.r[1]"], vr["base.m"]
    _error(log, lambda: fmu.doStep(0.0, 0.1), "fmi3DoStep", "instantiated")
    _error(log, lambda: fmu.exitInitializationMode(), "fmi3ExitInitializationMode")
    _error(log, lambda: fmu.getFloat64([99999]), "unknown value reference 99999")
    _error(log, lambda: fmu.getInt32([out]), "base.r[1]", "not of type Int32")
    _error(log, lambda: fmu.setFloat64([out], [1.0]), "base.r[1]", "output")
    _error(log, lambda: fmu.getBoolean([out]), "fmi3GetBoolean", "no variables of this type")
    _error(log, lambda: fmu.getFloat64([out], nValues=2), "nValues (2)", "nValueReferences (1)")
    _error(log, lambda: fmu.setFloat64([vr["time"]], [1.0]), "independent")
    _error(log, lambda: fmu.enterEventMode(), "hasEventMode is false")
    _error(log, lambda: fmu.enterStepMode(), "fmi3EnterStepMode")
    _error(log, lambda: fmu.fmi3GetNumberOfContinuousStates(fmu.component, ctypes.byref(
        ctypes.c_size_t())), "co-simulation only")
    fmu.setFloat64([par], [float("nan")])
    fmu.enterInitializationMode(startTime=0.0)
    _error(log, lambda: fmu.enterInitializationMode(), "fmi3EnterInitializationMode",
           "only allowed once")
    _error(log, lambda: fmu.exitInitializationMode(), "base.m = nan")
    fmu.setFloat64([par], [500.0])
    fmu.exitInitializationMode()
    fmu.doStep(0.0, 0.1)
    assert fmu.getFloat64([vr["time"]]) == [pytest.approx(0.1, rel=0, abs=1e-15)]
    _error(log, lambda: fmu.setFloat64([par], [400.0]), "base.m", "fixed parameter")
    fmu.terminate()
    _error(log, lambda: fmu.terminate(), "fmi3Terminate", "terminated")
    fmu.reset()                                        # back to instantiated: usable again
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    fmu.doStep(0.0, 0.1)
    fmu.terminate()
    fmu.freeInstance()


def test_discarded_step_and_unsupported_instantiation(fmus):
    from fmpy.fmi1 import FMICallException

    log = Log()
    fmu, _ = _slave(fmus, log=log)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    with pytest.raises(FMICallException) as e:
        fmu.doStep(0.0, -0.1)
    assert e.value.status == 2 and log[-1][1] == "logStatusDiscard" and "rejected" in log[-1][2]
    fmu.terminate()
    fmu.freeInstance()
    # a wrong instantiation token, event mode asked for, model exchange: no instance, a log line
    bad = Log()
    fmu, _ = _slave(fmus, instantiate=False)
    fmu.guid = "{00000000-0000-4000-8000-000000000000}"
    with pytest.raises(Exception, match="instantiate"):
        fmu.instantiate(logMessage=bad)
    assert bad and "instantiationToken" in bad[-1][2] and bad[-1][0] == 3
    fmu, _ = _slave(fmus, instantiate=False)
    with pytest.raises(Exception, match="instantiate"):
        fmu.instantiate(eventModeUsed=True, logMessage=bad)
    assert "eventModeUsed" in bad[-1][2]
    from fmpy.fmi3 import fmi3LogMessageCallback
    cb = fmi3LogMessageCallback(bad)
    inst = fmu.fmi3InstantiateModelExchange(b"me", fmu.guid.encode(), b"/", False, False, None, cb)
    assert not inst and "co-simulation only" in bad[-1][2]


def test_fmu_state_round_trip(fmus):
    """Get, serialise, deserialise and set the FMU state: the run from the restored state
    repeats the first run's outputs exactly (the same binary, the same arithmetic)."""
    fmu, vr = _slave(fmus, "estimator")
    outs = [vr[n] for n in ("base.m", "target.m", "sd.base.m")]
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.doStep(0.0, 0.1)
    state = fmu.getFMUState()
    blob = fmu.serializeFMUState(state)
    fmu.freeFMUState(state)
    first = []
    for i in range(1, 4):
        fmu.doStep(0.1 * i, 0.1)
        first.append(fmu.getFloat64(outs))
    restored = fmu.deserializeFMUState(blob)
    fmu.setFMUState(restored)
    fmu.freeFMUState(restored)
    again = []
    for i in range(1, 4):
        fmu.doStep(0.1 * i, 0.1)
        again.append(fmu.getFloat64(outs))
    assert again == first and len(blob) > 100
    fmu.terminate()
    fmu.freeInstance()


# ---- the communication point -------------------------------------------------------------------
def _stepped(fmus, kind, version, steps=3, h=0.1):
    """An instance of ``kind`` (FMI ``version``) initialised at t = 0 and stepped ``steps`` times by
    ``h`` (each step from the end of the last); returns (fmu, log, time, the output value
    references, state) where ``state()`` serialises the FMU state."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    from spacerobot import logger_callbacks

    path = str(fmus[(kind, version)])
    md = read_model_description(path)
    cls = FMU3Slave if version == 3 else FMU2Slave
    fmu = cls(guid=md.guid, unzipDirectory=extract(path),
              modelIdentifier=md.coSimulation.modelIdentifier, instanceName="t")
    log = Log()
    if version == 3:
        fmu.instantiate(loggingOn=True, logMessage=log)
        fmu.enterInitializationMode(startTime=0.0)
        get, getstate, serialise, free = (fmu.getFloat64, fmu.getFMUState,
                                          fmu.serializeFMUState, fmu.freeFMUState)
    else:
        fmu._cb = logger_callbacks(lambda _i, st, cat, msg: log.append((st, cat, msg)))
        fmu.instantiate(callbacks=fmu._cb, loggingOn=True)
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        get, getstate, serialise, free = (fmu.getReal, fmu.getFMUstate, fmu.serializeFMUstate,
                                          fmu.freeFMUstate)
    fmu.exitInitializationMode()
    t = 0.0
    for _ in range(steps):
        fmu.doStep(t, h)
        t = t + h

    def state():
        s = getstate()
        blob = serialise(s)
        free(s)
        return bytes(blob)
    outs = [v.valueReference for v in md.modelVariables
            if v.causality == "output" and v.type in ("Real", "Float64")]
    return fmu, log, t, outs, get, state


@pytest.mark.parametrize("version", (2, 3))
@pytest.mark.parametrize("kind", KINDS)
def test_a_step_from_another_time_is_refused_and_changes_nothing(fmus, kind, version):
    """doStep from a communication point other than the instance's time (ahead, behind, a
    millionth of the step off) is an illegal argument: fmi<V>Error with a logged error that
    names both times, and the FMU state (its serialised bytes: values, time, the core's state)
    and every output are as before. A point off by round-off only (a unit in the last place)
    is the instance's time; after the refusals the run goes on as one that never saw them."""
    from fmpy.fmi1 import FMICallException

    h = 0.1
    fmu, log, t, outs, get, state = _stepped(fmus, kind, version)
    ref, rlog, _, _, rget, _ = _stepped(fmus, kind, version, steps=5)
    y0 = get(outs)                     # the outputs first: the sensors' are computed when read
    before = state()
    for bad in (t + 1.0, t - h, t + 1.5e-6 * h, 0.0):
        n = len(log)
        with pytest.raises(FMICallException) as e:
            fmu.doStep(bad, h)
        assert e.value.status == 3, (bad, log[n:])
        st, cat, msg = log[-1]
        assert (st, cat) == (3, "logStatusError"), log[n:]
        assert f"fmi{version}DoStep: the communication point" in msg and "differs from the " \
            "FMU's time" in msg and "step refused, state unchanged" in msg, msg
        assert repr(float(t)) in msg or f"{t:.17g}" in msg, msg
        assert state() == before and get(outs) == y0, bad
    fmu.doStep(float(np.nextafter(t, np.inf)), h)          # round-off: the same point
    fmu.doStep(t + h, h)
    assert get(outs) == rget(outs)                          # as if nothing had been refused
    for f in (fmu, ref):
        f.terminate()
        f.freeInstance()


# ---- exported symbols --------------------------------------------------------------------------
def _standard_fmi3_functions():
    """The FMI 3.0 functions, from fmpy (which resolves every one of them)."""
    from fmpy.fmi3 import _FMU3
    return sorted(n for n in dir(_FMU3) if n.startswith("fmi3"))


def test_fmi3_binaries_export_exactly_the_standard_functions(lib_dir):
    nb = _nb()
    std = _standard_fmi3_functions()
    assert len(std) == 75
    seen = 0
    for plat in ("x86_64-linux", "x86_64-windows"):
        for p in sorted((lib_dir / "fmu" / plat).glob("SpaceRobot*")):
            assert nb.exported_symbols(p) == std, p
            seen += 1
    assert seen >= 3
    for p in sorted((lib_dir / "fmu" / "linux64").glob("SpaceRobot*")):
        names = nb.exported_symbols(p)
        assert names and all(n.startswith("fmi2") for n in names) and "fmi2DoStep" in names
    if shutil.which("nm"):                      # the reader agrees with binutils on ELF
        p = lib_dir / "fmu" / "x86_64-linux" / "SpaceRobotPlant.so"
        r = subprocess.run(["nm", "-D", "--defined-only", str(p)], capture_output=True, text=True)
        assert sorted(ln.split()[-1] for ln in r.stdout.splitlines() if " T " in ln) == std


@pytest.fixture(scope="session")
def zig_binaries():
    """The sensors' FMI 3.0 binaries for the zig platforms, built from this tree (cached by the
    sources' digest; the first build per target compiles zig's C runtime: minutes)."""
    nb = _nb()
    why = nb.zig_missing()
    if why:
        pytest.skip(f"zig cc unavailable: {why}")
    out = CACHE / f"zig-{_digest()}"
    paths = {name: out / "fmu" / plat.fmi3 / f"SpaceRobotSensors{plat.suffix}"
             for name, plat in nb.ZIG_PLATFORMS.items()}
    with ThreadPoolExecutor(max_workers=2) as ex:
        futs = [ex.submit(nb.build_fmu_binary, "sensors", name, out / "fmu", True, 3)
                for name, p in paths.items() if not p.is_file()]
        for f in futs:
            f.result()
    return paths


def test_zig_binaries_export_exactly_the_standard_functions(zig_binaries):
    nb = _nb()
    std = _standard_fmi3_functions()
    magic = {".so": b"\x7fELF", ".dylib": b"\xcf\xfa\xed\xfe"}
    for name, p in zig_binaries.items():
        assert p.read_bytes()[:4] == magic[p.suffix], p
        assert nb.check_exports(p, 3) == std, name
        if shutil.which("llvm-nm"):             # the reader agrees with LLVM's
            r = subprocess.run(["llvm-nm", "-gU", "--defined-only", str(p)],
                               capture_output=True, text=True)
            names = sorted(ln.split()[-1].removeprefix("_") if p.suffix == ".dylib"
                           else ln.split()[-1] for ln in r.stdout.splitlines())
            assert [n for n in names if n.startswith("fmi3")] == std, name


def test_fmi3_api_matches_the_standards_declarations(tmp_path):
    """fmi3_api.c compiled against the standard's header (fmpy's copy of fmi3Functions.h in place
    of the project's fmi3.h): a definition that differed from the standard's prototype in any
    type would not compile ("conflicting types"), and every one of the 75 functions is
    defined (the object exports them all)."""
    cc = nh.require(nh.c_compiler(), "a C compiler")
    inc = _fmpy_headers()
    (tmp_path / "fmi3.h").write_text('#include "fmi3Functions.h"\n')
    obj = tmp_path / "fmi3_api.o"
    fmi = ROOT / "native" / "fmi"
    r = subprocess.run([cc, "-std=c99", "-O1", "-Wall", "-Wextra", "-Werror", "-fPIC",
                        "-DFMI_VERSION=3", f"-I{tmp_path}", f"-I{inc}", f"-I{fmi}",
                        f"-I{ROOT / 'native' / 'src'}", "-c",
                        str(fmi / "fmi3_api.c"), "-o", str(obj)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    if shutil.which("nm"):
        r = subprocess.run(["nm", "--defined-only", str(obj)], capture_output=True, text=True)
        defined = sorted(ln.split()[-1] for ln in r.stdout.splitlines() if " T " in ln)
        assert defined == _standard_fmi3_functions()
