"""The native FMUs (estimator, sensors, plant) in real hosts (no Python in the FMU's process but
the test's fmpy run).

Each FMU is built from this tree's sources (``native/build.py``, assembled by
``spacerobot.fmi.native.build_native_fmu``), copied to a fresh folder and driven by the C host
``tests/c_host/fmu_host.c`` (one source: gcc + dlopen, mingw + LoadLibrary) from an EMPTY
environment (``PATH=/usr/bin:/bin`` only), for the planar "medium" and the spatial default
scenarios, with an input file per model:

* estimator: 30 s of samples recorded from the Python plant (:class:`spacerobot.plant.Plant`);
* sensors (direct feedthrough; default noise, ``noise.scale`` 1): the same 30 s of plant
  samples as its inputs ``true.<name>``;
* plant: 30 s of excitation levels ``ident.excite`` (1, 0.5, 0, with one value above 1 and one
  below 0 that the plant clips with a warning).

1. linux64: every output at every sample equals the same FMU run in fmpy to 1e-12 relative
   (integers exactly); a state serialised mid-run and restored reproduces the run bit for bit;
   3 create/free cycles first; and the run is what it should be (checked against independent
   facts): the estimates end near the truth (the samples reached the estimator as meant); the
   sensor outputs lie within a few noise standard deviations of the true inputs and differ
   from them; the plant moved and its attitude matrix stays orthonormal;
2. win64: the DLL, run by the same host source cross-compiled with mingw under Wine
   (headless), gives the linux64 results to 1e-12 relative; it imports only KERNEL32.dll and
   msvcrt.dll;
3. memory: the FMU binary and host built with ``-fsanitize=address,undefined`` run the same
   scenarios (5 create/free cycles, the state round trip, terminate, free, unload the library)
   with no sanitizer report (leaks included) and the same results; the plain binary under
   ``valgrind --error-exitcode=1`` memcheck likewise (no error, no definite leak). The plant's
   memory runs take its first 5 s (its 100 integration steps per sample are slow under
   valgrind); the others the whole 30 s.

Each part skips, saying why, where its tool (mingw, Wine, valgrind, the ASan runtime) is missing.
"""
from __future__ import annotations

import subprocess
import time

import numpy as np
import pytest

import native_hosts as nh

DT = 0.1
SECONDS = 30.0
N = int(round(SECONDS / DT))
STATE_STEP = N // 2
SCENARIOS = [("planar", "medium"), ("spatial", None)]  # the spatial robot's default target
KINDS = ["estimator", "sensors", "plant"]
CASES = [(kind, robot, target) for kind in KINDS for robot, target in SCENARIOS]
IDS = [f"{kind}-{robot}-{target or 'default'}" for kind, robot, target in CASES]
#: steps of the memory runs (sanitised, valgrind) per model: the plant integrates 100 internal
#: steps per sample (valgrind: ~50 ms a sample)
MEMORY_STEPS = {"estimator": N, "sensors": N, "plant": 50}
RTOL = 1e-12


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return nh.work_dir(tmp_path_factory)


@pytest.fixture(scope="module")
def libs(work):
    return nh.host_binaries(work, KINDS)


def record(robot: str, target, fmu: nh.Extracted, samples: int = N, sensors_seed=None):
    """The plant's outputs at t = 0, DT, ..., (samples - 1) DT as the estimator's (or the sensors'
    ``true.<name>``) inputs: (value references, rows of values) and the truth of the 20
    estimates. With a ``sensors_seed``: through the realistic sensors, the plant excited
    (level 1)."""
    from spacerobot import interface
    from spacerobot.interface import estimator_vars
    from spacerobot.plant import Plant
    from spacerobot.robots import scenario
    from spacerobot.sensors import SensorSuite

    sc = scenario(robot, target)
    keys = {v.name: v.key for v in estimator_vars(sc.robot, sc)}
    keys.update({f"true.{n}": k for n, k in keys.items()})
    names = fmu.names("Real", "input")
    p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
              excitation=sc.excitation)
    sensors = None
    if sensors_seed is not None:
        p.set_excitation(1.0)
        sensors = SensorSuite(sc.robot.n_joints, seed=sensors_seed, dt=DT)
    rows = []
    for _ in range(samples):
        out = p.outputs() if sensors is None else sensors.update(p.outputs(), DT)
        rows.append([float(np.asarray(out[keys[n][0]])[keys[n][1]]) for n in names])
        p.advance(DT)
    rows = np.array(rows)
    assert np.all(np.isfinite(rows)) and np.ptp(rows, axis=0).max() > 0.1     # it moved
    return [fmu.vr[n] for n in names], rows, interface.estimate_vector(sc.robot.base, sc.target)


def write_inputs(path, vrs, rows):
    """The host's input file: the value references, then each row's values as exact bits."""
    path.write_text(",".join(map(str, vrs)) + "\n" + "".join(
        ",".join(nh.hex_bits(x) for x in row) + "\n" for row in rows))
    return path


def excitation_levels(fmu: nh.Extracted):
    """The plant's input ``ident.excite`` at each sample: full, half, none, with one level above
    1 and one below 0 (clipped by the plant, with a warning)."""
    levels = np.where(np.arange(N) < N // 3, 1.0, np.where(np.arange(N) < 2 * N // 3, 0.5, 0.0))
    levels[N // 6], levels[N // 2] = 1.5, -0.25
    return [fmu.vr["ident.excite"]], levels[:, None], None


class Case:
    """One model and scenario: its FMU, its input file, the fmpy run."""

    def __init__(self, work, libs, kind, robot, target):
        self.kind, self.robot, self.target = kind, robot, target
        self.tag = f"{kind}-{robot}-{target or 'default'}"
        self.fmu = nh.native_fmu(work, kind, robot, target, libs["plain"], "plain")
        self.in_vr, self.samples, self.truth = (excitation_levels(self.fmu) if kind == "plant"
                                                else record(robot, target, self.fmu))
        self.memory_steps = MEMORY_STEPS[kind]
        self.csv = work / f"inputs_{self.tag}.csv"
        write_inputs(self.csv, self.in_vr, self.samples)
        self.real_out = self.fmu.vrs("Real", "output")
        self.int_out = self.fmu.vrs("Integer", "output")
        self.fmpy = self.run_fmpy()

    def run_fmpy(self) -> np.ndarray:
        """The same FMU, the same samples, in fmpy (the reference host): rows as the C host
        prints them (t, Real outputs, Integer outputs)."""
        from fmpy.fmi2 import FMU2Slave

        s = FMU2Slave(guid=self.fmu.guid, unzipDirectory=str(self.fmu.dir),
                      modelIdentifier=self.fmu.ident, instanceName="fmpy")
        s.instantiate()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()

        def row(t):
            return [t, *s.getReal(self.real_out), *s.getInteger(self.int_out)]

        rows = [row(0.0)]
        for k in range(N):
            s.setReal(self.in_vr, list(self.samples[k]))
            s.doStep(k * DT, DT)
            rows.append(row((k + 1) * DT))
        s.terminate()
        s.freeInstance()
        return np.array(rows)

    def host_args(self, binary, uri, csv, *extra):
        return [*extra, "-i", csv, "-j", ",".join(map(str, self.int_out)), binary, self.fmu.guid,
                uri, DT, N, ",".join(map(str, self.real_out))]


_CASES: dict = {}


@pytest.fixture(scope="module", params=CASES, ids=IDS)
def case(request, work, libs) -> Case:
    if request.param not in _CASES:
        _CASES[request.param] = Case(work, libs, *request.param)
    return _CASES[request.param]





def assert_same_run(c_rows: np.ndarray, ref: np.ndarray, case: "Case", what: str) -> float:
    """Every row of the run equal to the reference run: times and Integers exactly, Reals to
    RTOL relative; else the message names the outputs that differ and where they start to."""
    n_int = len(case.int_out)
    assert c_rows.shape == ref.shape, (what, c_rows.shape, ref.shape)
    np.testing.assert_array_equal(c_rows[:, 0], ref[:, 0])                   # times
    names = case.fmu.names("Real", "output")
    n_real = c_rows.shape[1] - n_int
    a, b = c_rows[:, 1:n_real], ref[:, 1:n_real]
    err = nh.worst_relative(a, b)
    if err > RTOL:
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(a == b, 0.0, np.abs(a - b) / np.abs(b))
        cols = [j for j in range(a.shape[1]) if rel[:, j].max() > RTOL]
        first = int(np.argmax((rel > RTOL).any(axis=1)))
        detail = ", ".join(f"{names[j]} {rel[:, j].max():.2g}" for j in cols)
        pytest.fail(f"{what}: {len(cols)} of {len(names)} Real outputs differ by more than "
                    f"{RTOL:g} relative, from sample {first} (t = {c_rows[first, 0]:g} s) on; "
                    f"worst {err:.3g}; per output: {detail}")
    np.testing.assert_array_equal(c_rows[:, n_real:], ref[:, n_real:])       # integer outputs
    return err


_LINUX_RUNS: dict = {}


def linux_run(case: Case, host) -> np.ndarray:
    if case.tag not in _LINUX_RUNS:
        t = time.perf_counter()
        r = nh.run([host, *case.host_args(case.fmu.so, case.fmu.uri, case.csv, "-c", 3,
                                          "-s", STATE_STEP)], env=nh.empty_env())
        assert r.returncode == 0, r.stderr[-3000:]
        assert "3 instantiate/free cycles done" in r.stderr
        assert f"state round trip after step {STATE_STEP}" in r.stderr and "identical" in r.stderr
        print(f"{case.tag}: linux64 host {time.perf_counter() - t:.2f} s; "
              f"{r.stderr.strip().splitlines()[-1]}")
        _LINUX_RUNS[case.tag] = nh.parse_csv(r.stdout)
    return _LINUX_RUNS[case.tag]


@pytest.fixture(scope="module")
def host(work, libs):
    return nh.compile_host(nh.HOST_SOURCE, work)


# ---- 1. linux64 from an empty environment ------------------------------------------------------
def test_c_host_from_an_empty_environment_equals_fmpy(case, host):
    c_rows = linux_run(case, host)
    err = assert_same_run(c_rows, case.fmpy, case, "C host vs fmpy")
    print(f"{case.tag}: C host vs fmpy, {c_rows.shape[0]} rows x {c_rows.shape[1] - 1} outputs, "
          f"worst relative difference {err:.3g}")
    {"estimator": check_estimator_run, "sensors": check_sensors_run,
     "plant": check_plant_run}[case.kind](case, c_rows)


def check_estimator_run(case: Case, c_rows: np.ndarray) -> None:
    # the samples reached the estimator as meant: every sample used, none rejected ...
    names = case.fmu.names("Integer", "output")
    last = dict(zip(names, c_rows[-1, -len(case.int_out):]))
    assert last["diag.samples"] >= N - 2 and last["diag.rejected"] == 0, last
    # ... and the estimates moved from the guesses towards the truth (target mass within 5 %)
    est = dict(zip(case.fmu.names("Real", "output"), c_rows[-1, 1:-len(case.int_out)]))
    first = dict(zip(case.fmu.names("Real", "output"), c_rows[0, 1:-len(case.int_out)]))
    m_true = case.truth[10]
    assert abs(est["target.m"] - m_true) <= 0.05 * m_true, (est["target.m"], m_true)
    assert abs(est["target.m"] - m_true) < abs(first["target.m"] - m_true)


def check_sensors_run(case: Case, c_rows: np.ndarray) -> None:
    """The outputs after the step from t_k measure the inputs set at t_k (direct feedthrough):
    joint angles within 1e-3 rad of the truth (encoder noise 5e-6 rad, resolution 1.2e-5 rad),
    the position within 0.1 m (navigation noise 1 cm), and not equal to it (noise.scale 1)."""
    out = dict(zip(case.fmu.names("Real", "output"), c_rows[1:, 1:].T))
    true = dict(zip(case.fmu.names("Real", "input"), case.samples.T))
    q = [n for n in out if n.startswith("arm.q[")]
    assert q and all(np.max(np.abs(out[n] - true[f"true.{n}"])) < 1e-3 for n in q), \
        {n: float(np.max(np.abs(out[n] - true[f"true.{n}"]))) for n in q}
    dr = np.max(np.abs(out["base.r[1]"] - true["true.base.r[1]"]))
    assert 0.0 < dr < 0.1, dr


def check_plant_run(case: Case, c_rows: np.ndarray) -> None:
    """The plant moved, and its attitude matrix stays orthonormal to 1e-9 (an invariant of the
    rigid-body integration)."""
    out = dict(zip(case.fmu.names("Real", "output"), c_rows[:, 1:].T))
    assert np.all(np.isfinite(c_rows))
    assert np.ptp(out["arm.q[1]"]) > 1e-3 and np.ptp(out["base.r[1]"]) > 0.1
    A = np.stack([out[f"base.A[{i},{j}]"] for i in (1, 2, 3) for j in (1, 2, 3)], axis=1)
    A = A.reshape(-1, 3, 3)
    dev = np.max(np.abs(A @ A.transpose(0, 2, 1) - np.eye(3)))
    assert dev < 1e-9, dev


def test_c_host_refuses_what_it_cannot_run(case, host, tmp_path):
    """The host's failures are exit codes with a reason, never a crash: a wrong GUID
    (fmi2Instantiate returns NULL after the FMU logged why), a missing binary."""
    args = case.host_args(case.fmu.so, case.fmu.uri, case.csv)
    bad = list(args)
    bad[bad.index(case.fmu.guid)] = "{00000000-0000-0000-0000-000000000000}"
    r = nh.run([host, *bad], env=nh.empty_env())
    assert r.returncode == 4 and "returned NULL" in r.stderr, r.stderr[-2000:]
    assert any("[status 3][logStatusError]" in line and "guid" in line.lower()
               for line in r.stderr.splitlines()), r.stderr[-2000:]
    missing = list(args)
    missing[missing.index(case.fmu.so)] = tmp_path / "none.so"
    r = nh.run([host, *missing], env=nh.empty_env())
    assert r.returncode == 2 and "cannot load" in r.stderr


# ---- 2. win64 under Wine -----------------------------------------------------------------------
def test_win64_dll_imports_only_kernel32_and_msvcrt(case, libs):
    nh.require(nh.mingw(), "mingw-w64 (x86_64-w64-mingw32-gcc)")
    assert case.fmu.dll.is_file(), "the FMU carries no win64 binary although mingw is installed"
    r = subprocess.run(["x86_64-w64-mingw32-objdump", "-p", str(case.fmu.dll)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    dlls = sorted({line.split(":", 1)[1].strip() for line in r.stdout.splitlines()
                   if "DLL Name:" in line})
    assert dlls == ["KERNEL32.dll", "msvcrt.dll"], dlls
    exports = {line.split()[-1] for line in r.stdout.splitlines() if "fmi2" in line}
    assert {"fmi2Instantiate", "fmi2DoStep", "fmi2SerializeFMUstate"} <= exports


@pytest.mark.slow
def test_win64_dll_under_wine_equals_linux64(case, work, host):
    nh.require(nh.mingw(), "mingw-w64 (x86_64-w64-mingw32-gcc)")
    nh.require(nh.wine(), "Wine")
    exe = nh.compile_host(nh.HOST_SOURCE, work, "win64")
    t = time.perf_counter()
    r = nh.run_wine(work, [exe, *case.host_args(nh.wine_path(case.fmu.dll), case.fmu.wine_uri,
                                                nh.wine_path(case.csv), "-c", 3, "-s",
                                                STATE_STEP)])
    elapsed = time.perf_counter() - t
    assert r.returncode == 0, r.stderr[-3000:]
    assert f"state round trip after step {STATE_STEP}" in r.stderr and "identical" in r.stderr
    w_rows = nh.parse_csv(r.stdout)
    err = assert_same_run(w_rows, linux_run(case, host), case, "win64 vs linux64")
    print(f"{case.tag}: win64 under Wine ({elapsed:.2f} s) vs linux64: worst relative "
          f"difference {err:.3g}; bit-identical rows: "
          f"{int(np.all(w_rows == linux_run(case, host), axis=1).sum())}/{w_rows.shape[0]}")


@pytest.mark.slow
def test_information_filter_under_wine_equals_linux64(work, libs, host):
    """The estimator FMU with the noise profile (ident.noise_profile = 1: the information
    filter, native/src/information.c) on 70 s of the spatial default scenario through the
    realistic sensors: past the filter's replay at sample 600, with its state saved,
    serialised and restored after it (step 650); the win64 DLL under Wine gives what linux64
    gives, within 1e-12 relative (the core's results do not depend on the compiler or its
    libm), and the bound outputs crb.* are set."""
    nh.require(nh.mingw(), "mingw-w64 (x86_64-w64-mingw32-gcc)")
    nh.require(nh.wine(), "Wine")
    n, state_step = 700, 650
    fmu = nh.native_fmu(work, "estimator", "spatial", None, libs["plain"], "plain")
    in_vr, rows, _ = record("spatial", None, fmu, n, sensors_seed=3)
    csv = write_inputs(work / "inputs_information.csv", in_vr, rows)
    reals, ints = fmu.vrs("Real", "output"), fmu.vrs("Integer", "output")

    def args(binary, uri, path):
        return ["-s", state_step, "-p", f"{fmu.vr['ident.noise_profile']}=1", "-i", path, "-j",
                ",".join(map(str, ints)), binary, fmu.guid, uri, DT, n,
                ",".join(map(str, reals))]
    lin = nh.run([host, *args(fmu.so, fmu.uri, csv)], env=nh.empty_env())
    assert lin.returncode == 0, lin.stderr[-3000:]
    assert f"state round trip after step {state_step}" in lin.stderr and "identical" in lin.stderr
    exe = nh.compile_host(nh.HOST_SOURCE, work, "win64")
    win = nh.run_wine(work, [exe, *args(nh.wine_path(fmu.dll), fmu.wine_uri, nh.wine_path(csv))])
    assert win.returncode == 0, win.stderr[-3000:]
    a, b = nh.parse_csv(lin.stdout), nh.parse_csv(win.stdout)
    assert a.shape == b.shape == (n + 1, 1 + len(reals) + len(ints))
    assert np.all(np.abs(a - b) <= RTOL * np.maximum(1.0, np.abs(a)))
    crb = [1 + reals.index(fmu.vr[f"crb.{nm}"]) for nm in ("base.m", "target.Izz")]
    assert np.all(a[-1, crb] > 0)


# ---- 3. memory safety -------------------------------------------------------------------------
#: one run: 5 create/free cycles, the run (30 s; the plant's first 5 s) with its state saved,
#: serialised and restored half-way, then terminate, free and unload the library
def memory_run(case: Case) -> list:
    return ["-c", 5, "-s", case.memory_steps // 2, "-x", "dlclose"]


def memory_args(case: Case, binary, uri) -> list:
    args = case.host_args(binary, uri, case.csv, *memory_run(case))
    args[-2] = case.memory_steps                 # NSTEPS
    return args


def memory_reference(case: Case, host) -> np.ndarray:
    return linux_run(case, host)[:case.memory_steps + 1]


@pytest.mark.slow
def test_sanitized_binary_runs_clean(case, work, libs, host):
    why = nh.asan_missing(work)
    if why:
        pytest.skip(why)
    fmu = nh.native_fmu(work, case.kind, case.robot, case.target, libs["sanitized"], "sanitized")
    exe = nh.compile_host(nh.HOST_SOURCE, work, sanitize=True)
    t = time.perf_counter()
    r = nh.run([exe, *memory_args(case, fmu.so, fmu.uri)], env=nh.empty_env(nh.SANITIZER_ENV))
    assert not nh.sanitizer_reports(r.stderr), "\n".join(nh.sanitizer_reports(r.stderr)[:20])
    assert r.returncode == 0, r.stderr[-3000:]
    assert "identical" in r.stderr and "5 instantiate/free cycles done" in r.stderr
    assert_same_run(nh.parse_csv(r.stdout), memory_reference(case, host), case, "sanitized")
    print(f"{case.tag}: ASan/UBSan clean in {time.perf_counter() - t:.1f} s")


@pytest.mark.slow
def test_valgrind_memcheck_clean(case, host):
    vg = nh.require(nh.valgrind(), "valgrind")
    t = time.perf_counter()
    r = nh.run([vg, "--error-exitcode=1", "--leak-check=full", "--show-leak-kinds=definite",
                "--errors-for-leak-kinds=definite", "-q", host,
                *memory_args(case, case.fmu.so, case.fmu.uri)], env=nh.empty_env())
    assert r.returncode == 0, r.stderr[-4000:]
    assert not [line for line in r.stderr.splitlines() if line.startswith("==")], r.stderr[-4000:]
    assert "identical" in r.stderr and "5 instantiate/free cycles done" in r.stderr
    assert_same_run(nh.parse_csv(r.stdout), memory_reference(case, host), case, "valgrind")
    print(f"{case.tag}: valgrind memcheck clean in {time.perf_counter() - t:.1f} s")
