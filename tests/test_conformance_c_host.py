"""Interface conformance (issue #5, #13), part 5: a host that is not Python.

tests/c_host/fmu_host.c is compiled here with the system C compiler against fmpy's bundled FMI
2.0 headers. It dlopen()s the FMU binaries (the project's front library, docs/fmus.md) and
drives them through the FMI C API only, started with an EMPTY environment (only PATH: no
LD_PRELOAD, PYTHONHOME, PYTHONPATH, not even HOME):

- the plant alone for 20 steps after 20 instantiate/free cycles: every output equals fmpy's run
  of the same FMU to 1e-12, and a state serialised in C, restored and re-run gives bit-identical
  values; exit status 0;
- plant and estimator wired in C (two FMUs in one process; both robots): the estimates equal
  fmpy's wired run to 1e-12;
- exit status 0 whether the host frees its instances, also dlcloses the libraries, or neither;
  the same with two FMUs of each robot (four FMUs) in one process;
- a missing or broken record of the Python installation: fmi2Instantiate returns NULL and the
  host's logger gets the reason.

The FMUs are the pythonfmu-hosted ones (``--backend pythonfmu``: the front library is theirs;
the native FMUs' C hosts: tests/test_native_fmu_hosts.py). Skipped, with the reason, when the FMUs
were built without the front library (no C compiler or no shared libpython at build time).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from test_conformance_util import free_instances  # noqa: F401  (autouse fixture)
from test_conformance_util import DT, OK, ROBOTS, Inst

_PY_FMUS: dict = {}


def fmus_for(request, robot: str) -> dict:
    """The pythonfmu-hosted FMUs of ``robot``, built once per session."""
    if robot not in _PY_FMUS:
        from spacerobot.fmi.build import build_fmu
        from spacerobot.robots import scenario

        d = request.getfixturevalue("fmu_dir") / f"pythonfmu_{robot}"
        _PY_FMUS[robot] = {kind: build_fmu(kind, scenario(robot), d, backend="pythonfmu")
                           for kind in ("plant", "estimator", "sensors")}
    return _PY_FMUS[robot]

from spacerobot.fmi import front_library
from spacerobot.fmi.front_library import c_compiler

SOURCE = Path(__file__).parent / "c_host" / "fmu_host.c"
N = 20


def fmi_headers() -> Path | None:
    import fmpy

    d = Path(fmpy.__file__).parent / "c-code"
    return d if (d / "fmi2Functions.h").is_file() else None


def host_environment() -> dict:
    """Empty but for PATH: what a tool started from a desktop or a scheduler may see."""
    return {"PATH": os.environ.get("PATH", "/usr/bin:/bin")}


@pytest.fixture(scope="module")
def host(tmp_path_factory) -> Path:
    if sys.platform != "linux":
        pytest.skip("the C host test is written for Linux (dlopen, binaries/linux64)")
    try:
        front_library.front_binary()
    except front_library.FrontLibraryUnavailable as e:
        pytest.skip(f"the FMUs carry pythonfmu's stock binary here: {e}")
    cc = c_compiler()
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


def run_host(host: Path, args) -> subprocess.CompletedProcess:
    return subprocess.run([str(host), *map(str, args)], capture_output=True, text=True,
                          env=host_environment(), timeout=600)


def parse(stdout: str) -> np.ndarray:
    return np.array([[float(x) for x in line.split(",")] for line in stdout.strip().splitlines()])


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("kind", ["plant", "sensors"])
def test_c_host_runs_the_plant_like_fmpy(request, host, robot, kind):
    """An FMU without connected inputs (the plant; the sensors at their start inputs)."""
    fmus = fmus_for(request, robot)
    plant = Unzipped(fmus[kind])
    r = run_host(host, ["-c", 20, "-s", N // 2, plant.so, plant.md.guid, plant.uri, DT, N,
                        ",".join(str(plant.vr[n]) for n in plant.reals)])
    assert r.returncode == 0, r.stderr[-3000:]
    assert "20 instantiate/free cycles done" in r.stderr
    assert "state round trip after step 10" in r.stderr and "identical" in r.stderr
    c_rows = parse(r.stdout)
    assert c_rows.shape == (N + 1, 1 + len(plant.reals))

    inst = Inst(fmus[kind], "fmpy").init()
    rows = [[0.0, *inst.values(plant.reals).values()]]
    for k in range(N):
        assert inst.step(k * DT, DT) == OK
        rows.append([(k + 1) * DT, *inst.values(plant.reals).values()])
    inst.free()
    py_rows = np.array(rows)
    scale = np.maximum(np.abs(py_rows), 1.0)
    err = np.max(np.abs(c_rows - py_rows) / scale)
    assert err <= 1e-12, err
    assert np.ptp(py_rows[:, 1:], axis=0).max() > (0.1 if kind == "plant" else 1e-3)  # it moved


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


def wired_args(plant: Unzipped, est: Unzipped, n: int = N) -> list:
    inputs = [v.name for v in est.md.modelVariables if v.causality == "input"]
    return ["-e", est.so, "-g", est.md.guid, "-r", est.uri,
            "-w", ",".join(f"{plant.vr[k]}:{est.vr[k]}" for k in inputs),
            "-o", str(est.vr["target.m"]), plant.so, plant.md.guid, plant.uri, DT, n,
            plant.vr["base.r[1]"]]


@pytest.mark.parametrize("mode", ["free", "dlclose", "none"])
def test_c_host_exits_cleanly_however_it_ends(request, host, mode):
    """No crash at exit (pythonfmu 0.7.0 alone aborts with a double free, exit status 134)
    whether the host frees its instances, also unloads the libraries, or does neither."""
    plant = Unzipped(fmus_for(request, "planar")["plant"])
    est = Unzipped(fmus_for(request, "planar")["estimator"])
    r = run_host(host, ["-x", mode, "-c", 2, *wired_args(plant, est, 3)])
    assert r.returncode == 0, (r.returncode, r.stderr[-3000:])
    assert len(r.stdout.strip().splitlines()) == 4


def test_c_host_runs_four_fmus_in_one_process(request, host, tmp_path):
    """Both robots' plant + estimator in one process: the spatial pair loaded after the planar
    one, same results as when each pair runs alone."""
    pairs = {robot: (Unzipped(fmus_for(request, robot)["plant"]),
                     Unzipped(fmus_for(request, robot)["estimator"])) for robot in ROBOTS}
    src = tmp_path / "four.c"
    # the host's main, run twice in one process: once per robot (a second copy of main's
    # state would be a second host; here the same libraries stay loaded in between)
    code = SOURCE.read_text().replace("int main(int argc, char **argv)",
                                      "static int host_main(int argc, char **argv)")
    code += """
int main(int argc, char **argv) {
    int split = 1, rc;
    while (split < argc && strcmp(argv[split], "--") != 0) split++;
    rc = host_main(split, argv);
    if (rc) return rc;
    argv[split] = argv[0];
    optind = 1;
    return host_main(argc - split, argv + split);
}
"""
    src.write_text(code)
    exe = tmp_path / "four"
    # src lives in tmp_path: -I finds the header the host includes (tests/c_host/fmi2_host.h)
    r = subprocess.run([c_compiler(), "-std=c99", "-D_POSIX_C_SOURCE=200809L", "-O1",
                        f"-I{fmi_headers()}", f"-I{SOURCE.parent}", "-o", str(exe), str(src), "-ldl"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    both = run_host(exe, [*wired_args(*pairs["planar"]), "--", *wired_args(*pairs["spatial"])])
    assert both.returncode == 0, both.stderr[-3000:]
    alone = {robot: run_host(host, wired_args(*pairs[robot])) for robot in ROBOTS}
    assert all(a.returncode == 0 for a in alone.values())
    assert both.stdout == alone["planar"].stdout + alone["spatial"].stdout


def broken_copy(unzipped: Unzipped, tmp_path: Path, edit) -> Unzipped:
    """A copy of an extracted FMU whose record resources/python_runtime.txt is changed by
    ``edit(text) -> text | None`` (None: the record is deleted)."""
    dst = tmp_path / "fmu"
    shutil.copytree(unzipped.dir, dst)
    copy = Unzipped.__new__(Unzipped)
    copy.__dict__.update(unzipped.__dict__)
    copy.dir, copy.so = dst, dst / unzipped.so.relative_to(unzipped.dir)
    copy.uri = (dst / "resources").as_uri()
    record = dst / "resources" / front_library.RECORD_NAME
    text = edit(record.read_text())
    if text is None:
        record.unlink()
    else:
        record.write_text(text)
    return copy


@pytest.mark.parametrize("case,edit,words", [
    ("missing record", lambda t: None, ["python_runtime.txt", "cannot be read"]),
    ("incomplete record", lambda t: "version=3.11\n", ["is incomplete"]),
    ("Python home gone", lambda t: t.replace("home=", "home=/nonexistent"),
     ["home /nonexistent", "does not exist"]),
    ("libpython gone", lambda t: t.replace("library=", "library=/nonexistent"),
     ["Python library", "/nonexistent", "cannot be loaded"]),
    ("package folder gone", lambda t: t.replace("path=", "path=/nonexistent", 1),
     ["search path", "/nonexistent", "does not exist"]),
])
def test_c_host_gets_null_and_the_reason_when_the_python_is_missing(request, host, tmp_path,
                                                                     case, edit, words):
    plant = broken_copy(Unzipped(fmus_for(request, "planar")["plant"]), tmp_path, edit)
    r = run_host(host, [plant.so, plant.md.guid, plant.uri, DT, 1, 0])
    assert r.returncode == 4, (case, r.returncode, r.stderr[-2000:])
    assert "fmi2Instantiate of" in r.stderr and "returned NULL" in r.stderr
    logged = [line for line in r.stderr.splitlines() if "[status 3][logStatusError]" in line]
    assert any(all(w in line for w in words) for line in logged), (case, r.stderr[-2000:])


def test_the_record_names_this_python_and_where_the_runtime_packages_are(request):
    """resources/python_runtime.txt: this interpreter's home and libpython, and a search path
    that reaches numpy (the FMUs' only runtime package) and the standard library but not the
    project."""
    import numpy

    from spacerobot.fmi.build import fmu_backend

    for kind in ("plant", "estimator", "sensors"):
        assert fmu_backend(fmus_for(request, "planar")[kind]) == "pythonfmu"
        fmu = Unzipped(fmus_for(request, "planar")[kind])
        record = (fmu.dir / "resources" / front_library.RECORD_NAME).read_text().splitlines()
        values = {}
        for line in record:
            if "=" in line and not line.startswith("#"):
                key, value = line.split("=", 1)
                values.setdefault(key, []).append(value)
        assert values["version"] == [f"{sys.version_info.major}.{sys.version_info.minor}"]
        assert values["home"] == [sys.base_prefix]
        assert Path(values["library"][0]).is_file() and "libpython" in values["library"][0]
        paths = [Path(p) for p in values["path"]]
        folders = [Path(numpy.__file__).parent.parent, Path(os.__file__).parent]
        for folder in folders:                   # site-packages and the standard library
            assert folder.resolve() in [p.resolve() for p in paths], folder
        project = Path(__file__).resolve().parents[1]
        assert all(p.resolve() != project for p in paths)
        assert (fmu.dir / "binaries" / "linux64" / front_library.PYTHONFMU_NAME).is_file()


def test_without_a_c_compiler_the_build_warns_and_keeps_pythonfmus_binary(monkeypatch, tmp_path):
    """The documented fallback: a RuntimeWarning, pythonfmu's stock binary, no record; the FMU
    still runs in a Python host, where refusals are fmi2Fatal (the stock binary's only error)."""
    import zipfile

    import pythonfmu
    from fmpy.fmi1 import FMICallException

    from spacerobot.fmi.build import build_fmu
    from spacerobot.robots import scenario

    monkeypatch.setattr(front_library, "c_compiler", lambda: None)
    monkeypatch.setattr(front_library, "front_binary",
                        lambda: front_library.compile_front(tmp_path / "front.so"))
    with pytest.warns(RuntimeWarning, match="keeping pythonfmu's stock binary.*no C compiler"):
        fmu = build_fmu("estimator", scenario("planar"), tmp_path / "stock", backend="pythonfmu")
    stock = (Path(pythonfmu.__file__).parent / "resources" / "binaries" / "linux64"
             / "libpythonfmu-export.so").read_bytes()
    with zipfile.ZipFile(fmu) as z:
        assert z.read("binaries/linux64/SpaceRobotEstimator.so") == stock
        assert f"resources/{front_library.RECORD_NAME}" not in z.namelist()
    inst = Inst(fmu, "stock")
    inst.fmu.setupExperiment(startTime=0.0)
    inst.fmu.enterInitializationMode()
    inst.set("lambda", 0.0)
    with pytest.raises(FMICallException) as exc:
        inst.fmu.exitInitializationMode()
    assert exc.value.status == 4
    assert any("lambda" in m for _, _, m in inst.messages)
