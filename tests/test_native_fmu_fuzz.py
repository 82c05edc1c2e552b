"""A randomised FMI 2.0 call test of the native FMUs: estimator, sensors, plant
(tests/c_host/fmu_fuzz.c).

With a seeded generator the C fuzzer makes 2 x 10^4 calls in random order on four instances
at once (one of them an instance of the other robot, served by the same binary): every fmi2
function, NaN / Inf / huge / negative / denormal values, out-of-range and wrong-type value
references, NULL arrays and instances, every lifecycle call in every phase, FMU states got,
set (into another instance: refused), serialised, deserialised (also in another instance, from
random bytes, from damaged copies and from the other robot), freed or left to
fmi2FreeInstance. It checks every returned status against FMI 2.0 and the layer's contract (a
refused call leaves the instance as it was: a later valid doStep works and the outputs stay
finite) and ends with every instance freed. What each model may legally do is told to the
fuzzer (:data:`MODEL_FLAGS`): the sensors are a direct feedthrough (``-T``: their outputs
measure the inputs set now, so a non-finite or huge input may give non-finite outputs); the
plant discards a step while its input ``ident.excite`` or ``ident.excite_rate`` is NaN
(``-N``) or one longer than
100 s (``-H``), and a valid step of an instance with changed parameters or from a damaged
state may fail its integration and be discarded (``-F``; with the start parameters it must
succeed). Run, for each model:

* linux64, two seeds: exit 0, every function called, no fmi2Fatal, no violation, log lines
  well formed, damaged states restored and stepped, other instances' and the other robot's
  states refused;
* the FMU binary and the fuzzer built with ``-fsanitize=address,undefined``: no report;
* the win64 DLL under Wine: the same summary as linux64 for the same seed (same statuses);
* the plain binary under valgrind memcheck: clean;
* the damage sweep (sanitised): every 4-byte word of a real state (:data:`SWEEP`: of a
  force-method estimator with differenced accelerations and a residual-correlation ring; of
  sensors with a 3-sample delay ring; of the plant), set in turn to values dangerous as counts
  or indices, deserialised, restored and stepped: refused or run, never an out-of-bounds
  access;
* accepted extreme parameters (the estimator): every Real and Integer parameter set to extreme
  values in initialisation; either fmi2ExitInitializationMode refuses it, or the instance steps
  through real samples with finite outputs.

The plant's fuzz runs make fewer calls (:data:`CALLS_OF`), and its valgrind run draws no wild
step between 1 s and 100 s (:data:`VALGRIND_EXTRA`): a plant step integrates 100 internal
steps per 0.1 s, so that each run stays within seconds.
"""
from __future__ import annotations

import math
import re
import time

import numpy as np
import pytest

import native_hosts as nh

CALLS = 20000
SEEDS = [1, 2]
ALL_FUNCTIONS = 34
KINDS = ["estimator", "sensors", "plant"]
#: calls of a fuzz run (linux64, sanitised, Wine) and of the valgrind run, per model
CALLS_OF = {"estimator": (CALLS, 10_000), "sensors": (CALLS, 10_000), "plant": (10_000, 2_000)}
#: the valgrind run of the plant shortens its wild steps to at most 1 s (those up to 100 s
#: cost up to 10^5 integration steps each: minutes under valgrind; the longer ones are still
#: drawn, and discarded)
VALGRIND_EXTRA = {"plant": ["-w", 1]}


def model_flags(fmu: nh.Extracted) -> list:
    """What the model may legally do, told to the fuzzer (see fmu_fuzz.c's options)."""
    if fmu.kind == "sensors":
        return ["-T"]                                  # direct feedthrough
    if fmu.kind == "plant":
        return ["-N", f'{fmu.vr["ident.excite"]},{fmu.vr["ident.excite_rate"]}', "-H", 100,
                "-F"]
    return []


#: the damage sweep per model: steps before the state is taken, Integer parameters
SWEEP = {"estimator": (12, {"method": 2, "accel_source": 2, "ident.diff_half_window": 2,
                            "ident.corr_lags": 3}),
         "sensors": (12, {"noise.delay": 3, "seed": 7}),
         "plant": (5, {})}


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return nh.work_dir(tmp_path_factory)


@pytest.fixture(scope="module")
def libs(work):
    return nh.host_binaries(work, KINDS)


@pytest.fixture(scope="module", params=KINDS)
def kind(request):
    return request.param


@pytest.fixture(scope="module")
def fmus(work, libs, kind):
    """The model's FMU of the planar robot under test, and of the spatial robot (whose states
    it must refuse)."""
    return {"planar": nh.native_fmu(work, kind, "planar", "medium", libs["plain"], "plain"),
            "spatial": nh.native_fmu(work, kind, "spatial", None, libs["plain"], "plain")}


@pytest.fixture(scope="module")
def fuzz(work, libs):
    return nh.compile_host(nh.FUZZ_SOURCE, work)


def fuzz_args(fmu: nh.Extracted, other: nh.Extracted, binary, uri: str, other_uri: str,
              calls: int = CALLS, seed: int = 1, extra=()) -> list:
    def vrs(t, c):
        return ",".join(map(str, fmu.vrs(t, c)))
    return ["-n", calls, "-S", seed, "-k", 4, "-L", 5, *model_flags(fmu), *extra,
            "-R", vrs("Real", "input"), "-P", vrs("Real", "parameter"),
            "-I", vrs("Integer", "parameter"), "-O", vrs("Real", "output"),
            "-Z", vrs("Integer", "output"), "-g", other.guid, "-u", other_uri,
            "-m", len(other.variables), binary, fmu.guid, uri, len(fmu.variables)]


def summary(stdout: str) -> dict:
    """The fuzzer's summary: per function [calls, ok, warning, discard, error, fatal], totals."""
    out = {"functions": {}}
    for line in stdout.splitlines():
        f = line.split()
        if f and f[0].startswith("fmi2") and len(f) == 7:
            out["functions"][f[0]] = [int(x) for x in f[1:]]
        elif f and f[0] == "total":
            out.update(total=int(f[1]), violations=int(f[7]))
        elif f and f[0] == "log-lines":
            out["log"] = {f[i]: int(f[i + 1]) for i in range(1, len(f), 2)}
        elif f and f[0] == "damaged-states-restored":
            out.update(damaged_restored=int(f[1]), damaged_steps=int(f[3]),
                       foreign_refused=int(f[5]))
        elif f and f[0] == "damage-sweep" and f[1] == "states":
            out.update(sweep_states=int(f[2]), sweep_refused=int(f[4]))
    return out


def check_summary(r, what: str, calls: int = CALLS) -> dict:
    violations = [line for line in r.stdout.splitlines() if line.startswith(("VIOLATION", "BAD"))]
    assert not violations, (what, violations[:20])
    assert r.returncode == 0, (what, r.returncode, r.stdout[-2000:], r.stderr[-3000:])
    s = summary(r.stdout)
    assert len(s["functions"]) == ALL_FUNCTIONS, sorted(s["functions"])
    never = [f for f, c in s["functions"].items() if c[0] == 0]
    assert not never, (what, "never called", never)
    assert s["total"] >= calls and s["violations"] == 0, (what, s["total"], s["violations"])
    assert all(c[5] == 0 for c in s["functions"].values()), (what, "fmi2Fatal returned")
    assert s["log"]["fatal"] == 0 and s["log"]["bad"] == 0, (what, s["log"])
    # the interesting paths were taken: steps, refusals, damaged and foreign states
    fn = s["functions"]
    f = calls / CALLS                           # the thresholds of 2 x 10^4 calls, scaled
    assert fn["fmi2DoStep"][1] > 500 * f and fn["fmi2DoStep"][3] > 100 * f, fn["fmi2DoStep"]
    assert fn["fmi2SetReal"][4] > 100 * f and fn["fmi2ExitInitializationMode"][1] > 50 * f
    # (the plant's valgrind run, 2000 calls: 11 damaged states restored, 1 step from one: its
    # state's excitation rates, checked too, refuse more of the damaged states)
    assert s["damaged_restored"] > 10 * f and s["damaged_steps"] >= max(1.0, 10 * f), s
    assert s["foreign_refused"] > 10 * f, s
    return s


def print_summary(s: dict, what: str, seconds: float) -> None:
    statuses = np.sum([c[1:] for c in s["functions"].values()], axis=0)
    print(f"{what}: {s['total']} calls in {seconds:.2f} s, {len(s['functions'])} functions; "
          f"statuses ok/warning/discard/error/fatal = {'/'.join(map(str, statuses))}; "
          f"damaged states restored {s['damaged_restored']} (steps {s['damaged_steps']}), "
          f"foreign refused {s['foreign_refused']}; violations {s['violations']}")


_LINUX: dict = {}


def linux_fuzz(fuzz, fmus, seed):
    p, o = fmus["planar"], fmus["spatial"]
    key = (p.kind, seed)
    if key not in _LINUX:
        t = time.perf_counter()
        r = nh.run([fuzz, *fuzz_args(p, o, p.so, p.uri, o.uri, calls=CALLS_OF[p.kind][0],
                                     seed=seed)], env=nh.empty_env())
        _LINUX[key] = (r, time.perf_counter() - t)
    return _LINUX[key]


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.slow
def test_fuzz_linux64(fuzz, fmus, kind, seed):
    r, seconds = linux_fuzz(fuzz, fmus, seed)
    what = f"{kind} linux64 seed {seed}"
    print_summary(check_summary(r, what, CALLS_OF[kind][0]), what, seconds)


@pytest.mark.slow
def test_fuzz_sanitized(work, libs, fmus, kind):
    why = nh.asan_missing(work)
    if why:
        pytest.skip(why)
    p = nh.native_fmu(work, kind, "planar", "medium", libs["sanitized"], "sanitized")
    o = fmus["spatial"]
    exe = nh.compile_host(nh.FUZZ_SOURCE, work, sanitize=True)
    t = time.perf_counter()
    r = nh.run([exe, *fuzz_args(p, o, p.so, p.uri, o.uri, calls=CALLS_OF[kind][0],
                                seed=SEEDS[0])], env=nh.empty_env(nh.SANITIZER_ENV))
    reports = nh.sanitizer_reports(r.stderr)
    assert not reports, "\n".join(reports[:20]) + "\n" + r.stderr[-4000:]
    print_summary(check_summary(r, f"{kind} sanitized", CALLS_OF[kind][0]),
                  f"{kind} ASan/UBSan", time.perf_counter() - t)


@pytest.mark.slow
def test_fuzz_win64_under_wine_same_statuses_as_linux64(work, fuzz, fmus, kind):
    nh.require(nh.mingw(), "mingw-w64 (x86_64-w64-mingw32-gcc)")
    nh.require(nh.wine(), "Wine")
    p, o = fmus["planar"], fmus["spatial"]
    exe = nh.compile_host(nh.FUZZ_SOURCE, work, "win64")
    t = time.perf_counter()
    r = nh.run_wine(work, [exe, *fuzz_args(p, o, nh.wine_path(p.dll), p.wine_uri, o.wine_uri,
                                           calls=CALLS_OF[kind][0], seed=SEEDS[0])])
    s = check_summary(r, f"{kind} win64", CALLS_OF[kind][0])
    print_summary(s, f"{kind} win64 under Wine", time.perf_counter() - t)
    lin = summary(linux_fuzz(fuzz, fmus, SEEDS[0])[0].stdout)
    assert s == lin, "the same calls gave other statuses on win64"


@pytest.mark.slow
def test_fuzz_valgrind(fuzz, fmus, kind):
    vg = nh.require(nh.valgrind(), "valgrind")
    p, o = fmus["planar"], fmus["spatial"]
    t = time.perf_counter()
    r = nh.run([vg, "--error-exitcode=99", "--leak-check=full", "--show-leak-kinds=definite",
                "--errors-for-leak-kinds=definite", "-q", fuzz,
                *fuzz_args(p, o, p.so, p.uri, o.uri, calls=CALLS_OF[kind][1], seed=3,
                           extra=VALGRIND_EXTRA.get(kind, ()))],
               env=nh.empty_env())
    assert r.returncode != 99, r.stderr[-4000:]
    print_summary(check_summary(r, f"{kind} valgrind", CALLS_OF[kind][1]),
                  f"{kind} valgrind memcheck", time.perf_counter() - t)


@pytest.mark.slow
def test_damaged_state_sweep_sanitized(work, libs, fmus, kind):
    """A state is bytes a host may hand back: a damaged one is refused or run, never trusted
    into an out-of-bounds index (estimator: force method, differenced accelerations: history
    ring; ident.corr_lags: residual rings; sensors: the delay ring; plant: its state vector)."""
    why = nh.asan_missing(work)
    if why:
        pytest.skip(why)
    p = nh.native_fmu(work, kind, "planar", "medium", libs["sanitized"], "sanitized")
    o = fmus["spatial"]
    exe = nh.compile_host(nh.FUZZ_SOURCE, work, sanitize=True)
    steps, params = SWEEP[kind]
    extra = ["-D", steps]
    for name, value in params.items():
        extra += ["-p", f"{p.vr[name]}={value}"]
    t = time.perf_counter()
    r = nh.run([exe, *fuzz_args(p, o, p.so, p.uri, o.uri, calls=200, seed=5, extra=extra)],
               env=nh.empty_env(nh.SANITIZER_ENV))
    reports = nh.sanitizer_reports(r.stderr)
    first = r.stderr[r.stderr.find("ERROR:") - 200:][:3000] if "ERROR:" in r.stderr else ""
    assert not reports, "\n".join(reports[:10]) + "\n" + first
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
    s = summary(r.stdout)
    if kind == "estimator":
        samples = re.search(r"integer outputs after filling: (.*)", r.stdout).group(1).split()
        assert int(samples[p.names("Integer", "output").index("diag.samples")]) >= 8, samples
    # every word past the 64-byte header of the state (its values and the model's block)
    assert s["sweep_states"] > (1000 if kind == "estimator" else 300), s
    print(f"{kind} damage sweep: {s['sweep_states']} damaged states ({s['sweep_refused']} "
          f"refused) in {time.perf_counter() - t:.1f} s, no sanitizer report")


# ---- accepted extreme parameters ----------------------------------------------------------------
EXTREME_REALS = [math.nan, math.inf, -math.inf, 1e308, -1e308, 1e16, -1e16, 5e-324, -1.0, 0.0]
EXTREME_INTS = [-2**31, 2**31 - 1, -1, 0, 3, 10_001]


@pytest.mark.slow
def test_accepted_extreme_parameters_keep_outputs_finite(work, libs):
    """Each parameter alone at an extreme value: refused at fmi2ExitInitializationMode (with a
    logged reason), or the estimator steps 10 real samples with every output finite."""
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    from spacerobot import logger_callbacks

    from spacerobot.interface import estimator_vars
    from spacerobot.plant import Plant
    from spacerobot.robots import scenario

    fmu = nh.estimator_fmu(work, "planar", "medium", libs["plain"], "plain")
    sc = scenario("planar", "medium")
    keys = {v.name: v.key for v in estimator_vars(sc.robot, sc)}
    inputs = fmu.names("Real", "input")
    plant = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
                  excitation=sc.excitation)
    samples = []
    for _ in range(10):
        out = plant.outputs()
        samples.append([float(np.asarray(out[keys[n][0]])[keys[n][1]]) for n in inputs])
        plant.advance(0.1)
    in_vr, real_out, int_out = fmu.vrs("Real", "input"), fmu.vrs("Real", "output"), \
        fmu.vrs("Integer", "output")
    cases = [(n, "Real", v) for n in fmu.names("Real", "parameter") for v in EXTREME_REALS]
    cases += [(n, "Integer", v) for n in fmu.names("Integer", "parameter") for v in EXTREME_INTS]
    messages = []
    callbacks = logger_callbacks(lambda _inst, status, _cat, text: messages.append((status, text)))
    bad, refused, accepted = [], 0, 0
    for name, type_, value in cases:
        s = FMU2Slave(guid=fmu.guid, unzipDirectory=str(fmu.dir), modelIdentifier=fmu.ident,
                      instanceName="extreme")
        s.instantiate(callbacks=callbacks)
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        (s.setReal if type_ == "Real" else s.setInteger)([fmu.vr[name]], [value])
        del messages[:]
        try:
            s.exitInitializationMode()
        except FMICallException as e:            # refused: fmi2Error with a logged reason
            refused += 1
            assert e.status == 3 and any(st == 3 and ("invalid estimator parameters" in m or
                                                      "non-finite parameter value" in m)
                                         for st, m in messages), (name, value, messages)
            s.freeInstance()
            continue
        accepted += 1
        for k, row in enumerate(samples):
            s.setReal(in_vr, row)
            s.doStep(k * 0.1, 0.1)
            y = np.array(s.getReal(real_out))
            if not np.all(np.isfinite(y)):
                which = [fmu.names("Real", "output")[i] for i in np.where(~np.isfinite(y))[0]]
                bad.append(f"{name} = {value!r}: after sample {k} {which[:4]} not finite")
                break
        s.getInteger(int_out)
        s.terminate()
        s.freeInstance()
    print(f"extreme parameters: {len(cases)} cases, {refused} refused, {accepted} accepted, "
          f"{len(bad)} with non-finite outputs")
    assert not bad, "accepted parameters that give non-finite outputs:\n" + "\n".join(bad)




@pytest.mark.parametrize("model", ["sensors", "plant"])
@pytest.mark.slow
def test_accepted_extreme_parameters_of_sensors_and_plant(work, libs, model):
    """Each parameter alone at an extreme value: refused at fmi2ExitInitializationMode (with a
    logged reason), or 10 steps (the sensors: 10 real plant samples as their true inputs; the
    plant: full excitation) each either fmi2OK with every output finite or, for the plant
    only, fmi2Discard (its integration failed; the state and the outputs stay as before)."""
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    from spacerobot import logger_callbacks

    nh.fmu_binaries(work, [model], sanitized=False)
    fmu = nh.native_fmu(work, model, "planar", "medium", libs["plain"], "plain")
    in_vr, real_out = fmu.vrs("Real", "input"), fmu.vrs("Real", "output")
    if model == "sensors":
        from spacerobot.interface import estimator_vars
        from spacerobot.plant import Plant
        from spacerobot.robots import scenario

        sc = scenario("planar", "medium")
        keys = {f"true.{v.name}": v.key for v in estimator_vars(sc.robot, sc)}
        plant = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
                      excitation=sc.excitation)
        samples = []
        for _ in range(10):
            out = plant.outputs()
            samples.append([float(np.asarray(out[keys[n][0]])[keys[n][1]])
                            for n in fmu.names("Real", "input")])
            plant.advance(0.1)
    else:
        samples = [[1.0]] * 10
    cases = [(n, "Real", v) for n in fmu.names("Real", "parameter") for v in EXTREME_REALS]
    cases += [(n, "Integer", v) for n in fmu.names("Integer", "parameter") for v in EXTREME_INTS]
    messages = []
    callbacks = logger_callbacks(lambda _inst, status, _cat, text: messages.append((status, text)))
    bad, refused, accepted, discarded = [], 0, 0, 0
    for name, type_, value in cases:
        s = FMU2Slave(guid=fmu.guid, unzipDirectory=str(fmu.dir), modelIdentifier=fmu.ident,
                      instanceName="extreme")
        s.instantiate(callbacks=callbacks)
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        (s.setReal if type_ == "Real" else s.setInteger)([fmu.vr[name]], [value])
        del messages[:]
        try:
            s.exitInitializationMode()
        except FMICallException as e:
            refused += 1
            assert e.status == 3 and any(st == 3 for st, _ in messages), (name, value, messages)
            s.freeInstance()
            continue
        accepted += 1
        for k, row in enumerate(samples):
            s.setReal(in_vr, row)
            try:
                s.doStep(k * 0.1, 0.1)
            except FMICallException as e:
                if not (model == "plant" and e.status == 2):
                    bad.append(f"{name} = {value!r}: step {k} returned status {e.status}")
                    break
                discarded += 1
            y = np.array(s.getReal(real_out))
            if not np.all(np.isfinite(y)):
                which = [fmu.names("Real", "output")[i] for i in np.where(~np.isfinite(y))[0]]
                bad.append(f"{name} = {value!r}: after step {k} {which[:4]} not finite")
                break
        s.terminate()
        s.freeInstance()
    print(f"{model} extreme parameters: {len(cases)} cases, {refused} refused, {accepted} "
          f"accepted ({discarded} steps discarded), {len(bad)} with non-finite outputs:\n  "
          + "\n  ".join(bad))
    assert not bad, "accepted parameters that give non-finite outputs:\n" + "\n".join(bad)
