"""The spatial closed loop plant -> estimator -> plant in the C host (no Python in its process).

The native plant and estimator FMUs of the spatial robot's default scenario, built from this
tree's sources (``native/build.py``, packaged by ``spacerobot.fmi.native.build_native_fmu``),
are wired in ``tests/c_host/fmu_host.c`` as the SSP wires them
(:func:`spacerobot.system.ssd.system_connections`): every plant output the estimator has as an
input (same name), and the feedback estimator ``ident.excite`` (and ``ident.excite_rate``, 1
here: no information filter without sensors) -> plant inputs of the same names (the
estimator asks for excitation until the target is identified). The host runs 60 s (600 steps of
0.1 s) from an EMPTY environment (``PATH=/usr/bin:/bin`` only):

1. linux64: every Real output of the estimator at every communication point equals the project's
   own runner (:func:`spacerobot.system.runner.run_ssp` on the system built by
   :func:`spacerobot.system.ssd.build_system` from the same two FMUs, its parameter set bound)
   within 1e-12 relative, and so do the plant's excitation level and input (the input as set
   at the previous point: the runner records the inputs set at t, the host prints them after
   the step they were set for); the feedback was
   live (the estimator switched the excitation from on to off during the run, and the run
   without the feedback wire differs); the host's wall time for the run is printed
   (benchmarks/native.py measures it too; not an assertion);
2. win64: the same host source cross-compiled with mingw, under Wine (headless), with the FMUs'
   win64 DLLs, equals the linux64 run within 1e-12 relative (the largest difference printed);
3. memory: both FMU binaries and the host built with ``-fsanitize=address,undefined`` run the
   loop (two FMUs in one process; terminate, free, unload both libraries) with no sanitizer
   report (leaks included) and the linux64 results.

Each part skips, saying why, where its tool (mingw, Wine, the ASan runtime) is missing.
"""
from __future__ import annotations

import time

import numpy as np
import pytest

import native_hosts as nh

ROBOT = "spatial"
DT = 0.1
STEPS = 600                      # 60 s
RTOL = 1e-12
#: the plant outputs printed beside the estimator's: the excitation it applied
PLANT_OUT = ["ident.excite", "excite.level"]


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return nh.work_dir(tmp_path_factory)


@pytest.fixture(scope="module")
def libs(work):
    return nh.host_binaries(work, ("plant", "estimator"), sanitized=False)


class Loop:
    """The two FMUs, the SSP's wiring as value references, the host's arguments."""

    def __init__(self, work, libs):
        from spacerobot.system.ssd import ESTIMATOR, PLANT, system_connections

        self.plant = nh.native_fmu(work, "plant", ROBOT, None, libs["plain"], "plain")
        self.est = nh.estimator_fmu(work, ROBOT, None, libs["plain"], "plain")
        conns = system_connections(ROBOT)
        self.forward = [(a, b) for s, a, d, b in conns if (s, d) == (PLANT, ESTIMATOR)]
        self.back = [(a, b) for s, a, d, b in conns if (s, d) == (ESTIMATOR, PLANT)]
        assert len(self.forward) + len(self.back) == len(conns), conns
        # every estimator input is fed, by the plant output of the same name
        assert sorted(b for _, b in self.forward) == sorted(self.est.names("Real", "input"))
        assert all(a == b for a, b in self.forward)
        assert self.back == [("ident.excite", "ident.excite"),
                             ("ident.excite_rate", "ident.excite_rate")], self.back
        self.est_out = self.est.names("Real", "output")

    def args(self, plant_bin, est_bin, plant_uri, est_uri, feedback: bool = True,
             extra=()) -> list:
        p, e = self.plant, self.est
        extra = ["-b", ",".join(f"{e.vr[a]}:{p.vr[b]}" for a, b in self.back)] if feedback else []
        return [*extra, "-e", est_bin, "-g", e.guid, "-r", est_uri,
                "-w", ",".join(f"{p.vr[a]}:{e.vr[b]}" for a, b in self.forward),
                "-o", ",".join(str(e.vr[n]) for n in self.est_out), *extra,
                plant_bin, p.guid, plant_uri, DT, STEPS,
                ",".join(str(p.vr[n]) for n in PLANT_OUT)]

    def columns(self) -> list:
        """The host's columns: time, the plant's PLANT_OUT, the estimator's Real outputs."""
        return ["time", *(f"plant.{n}" for n in PLANT_OUT),
                *(f"estimator.{n}" for n in self.est_out)]


_LOOP: dict = {}


@pytest.fixture(scope="module")
def loop(work, libs) -> Loop:
    if "loop" not in _LOOP:
        _LOOP["loop"] = Loop(work, libs)
    return _LOOP["loop"]


@pytest.fixture(scope="module")
def host(work, libs):
    return nh.compile_host(nh.HOST_SOURCE, work)





def assert_close(c_rows: np.ndarray, ref: np.ndarray, columns: list, what: str) -> float:
    err = nh.worst_relative(c_rows, ref)
    if err > RTOL:
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(c_rows == ref, 0.0, np.abs(c_rows - ref) / np.abs(ref))
        bad = [f"{columns[j]} {rel[:, j].max():.2g}" for j in range(len(columns))
               if rel[:, j].max() > RTOL]
        first = int(np.argmax((rel > RTOL).any(axis=1)))
        pytest.fail(f"{what}: {len(bad)} columns differ by more than {RTOL:g} relative, from "
                    f"t = {ref[first, 0]:g} s on; worst {err:.3g}: {', '.join(bad[:12])}")
    return err


_RUNS: dict = {}


def linux_run(loop: Loop, host, feedback: bool = True) -> np.ndarray:
    if feedback not in _RUNS:
        p, e = loop.plant, loop.est
        t = time.perf_counter()
        r = nh.run([host, *loop.args(p.so, e.so, p.uri, e.uri, feedback)], env=nh.empty_env())
        wall = time.perf_counter() - t
        assert r.returncode == 0, r.stderr[-3000:]
        if feedback:
            print(f"closed loop in the C host, {ROBOT}, {STEPS * DT:g} s: wall time {wall:.3f} s "
                  f"(process); {r.stderr.strip().splitlines()[-1]}")
        _RUNS[feedback] = nh.parse_csv(r.stdout)
    return _RUNS[feedback]


def runner_run(work, loop: Loop) -> np.ndarray:
    """The same two FMUs in the project's runner, the columns of the host's output."""
    from spacerobot.system.runner import run_ssp
    from spacerobot.system.ssd import build_system

    if "runner" not in _RUNS:
        paths = build_system(ROBOT, work / "closed_loop_system",
                             fmus={"plant": loop.plant.fmu, "estimator": loop.est.fmu})
        res = run_ssp(paths["ssp"], stop_time=STEPS * DT)
        _RUNS["runner"] = np.column_stack([res.time, *(res.data[c] for c in loop.columns()[1:])])
    return _RUNS["runner"]


# ---- 1. linux64 from an empty environment --------------------------------------------------
@pytest.mark.slow
def test_closed_loop_in_the_c_host_equals_the_runner(work, loop, host):
    c_rows = linux_run(loop, host)
    ref = runner_run(work, loop)
    assert c_rows.shape == (STEPS + 1, len(loop.columns())), c_rows.shape
    np.testing.assert_allclose(c_rows[:, 0], ref[:, 0], rtol=0, atol=1e-12)        # times
    col = {c: j for j, c in enumerate(loop.columns())}
    # the plant's input in the host's row k was set at t_(k-1); in the runner's at t_k
    j = col["plant.ident.excite"]
    assert_close(c_rows[1:, j:j + 1], ref[:-1, j:j + 1], ["plant.ident.excite"], "input")
    keep = [i for i in range(len(col)) if i != j]
    err = assert_close(c_rows[:, keep], ref[:, keep], [loop.columns()[i] for i in keep],
                       "C host vs run_ssp")
    print(f"C host vs run_ssp: {c_rows.shape[0]} rows x {len(keep) - 1} columns, worst "
          f"relative difference {err:.3g}, bit-identical rows "
          f"{int(np.all(c_rows[:, keep] == ref[:, keep], axis=1).sum())}/{c_rows.shape[0]}")
    # the feedback was live: the estimator asked for excitation, then stopped asking, and the
    # plant's input in each step was what the estimator asked for at its start
    asked = c_rows[:, col["estimator.ident.excite"]]
    applied = c_rows[:, col["plant.ident.excite"]]
    assert asked.max() > 0.5 and asked[-1] == 0.0, np.unique(asked)
    np.testing.assert_array_equal(applied[1:], asked[:-1])
    assert np.ptp(c_rows[:, col["plant.excite.level"]]) > 0.5


@pytest.mark.slow
def test_the_feedback_wire_matters(loop, host):
    """Without the wire estimator ident.excite -> plant ident.excite the plant keeps its start
    input (0: no excitation) and the estimates differ: the closed loop above is a loop."""
    with_fb, without = linux_run(loop, host), linux_run(loop, host, feedback=False)
    col = {c: j for j, c in enumerate(loop.columns())}
    assert np.all(without[:, col["plant.ident.excite"]] == 0.0)
    est = [j for c, j in col.items() if c.startswith("estimator.target.")]
    assert np.max(np.abs(with_fb[:, est] - without[:, est])) > 1e-6


# ---- 2. win64 under Wine ----------------------------------------------------------------------
@pytest.mark.slow
def test_closed_loop_win64_under_wine_equals_linux64(work, loop, host):
    nh.require(nh.mingw(), "mingw-w64 (x86_64-w64-mingw32-gcc)")
    nh.require(nh.wine(), "Wine")
    p, e = loop.plant, loop.est
    assert p.dll.is_file() and e.dll.is_file(), "the FMUs carry no win64 binary"
    exe = nh.compile_host(nh.HOST_SOURCE, work, "win64")
    t = time.perf_counter()
    r = nh.run_wine(work, [exe, *loop.args(nh.wine_path(p.dll), nh.wine_path(e.dll), p.wine_uri,
                                           e.wine_uri)])
    elapsed = time.perf_counter() - t
    assert r.returncode == 0, r.stderr[-3000:]
    w_rows, l_rows = nh.parse_csv(r.stdout), linux_run(loop, host)
    assert w_rows.shape == l_rows.shape, (w_rows.shape, l_rows.shape)
    err = assert_close(w_rows, l_rows, loop.columns(), "win64 vs linux64")
    print(f"closed loop win64 under Wine ({elapsed:.2f} s; {r.stderr.strip().splitlines()[-1]}) "
          f"vs linux64: worst relative difference {err:.3g}, max |difference| "
          f"{float(np.max(np.abs(w_rows - l_rows))):.3g}, bit-identical rows "
          f"{int(np.all(w_rows == l_rows, axis=1).sum())}/{w_rows.shape[0]}")


# ---- 3. memory safety -------------------------------------------------------------------------
@pytest.mark.slow
def test_closed_loop_sanitized_runs_clean(work, loop, host):
    why = nh.asan_missing(work)
    if why:
        pytest.skip(why)
    libs = nh.fmu_binaries(work, ("plant", "estimator"), sanitized=True)
    p = nh.native_fmu(work, "plant", ROBOT, None, libs["sanitized"], "sanitized")
    e = nh.estimator_fmu(work, ROBOT, None, libs["sanitized"], "sanitized")
    exe = nh.compile_host(nh.HOST_SOURCE, work, sanitize=True)
    t = time.perf_counter()
    r = nh.run([exe, *loop.args(p.so, e.so, p.uri, e.uri, extra=["-x", "dlclose"])],
               env=nh.empty_env(nh.SANITIZER_ENV))
    reports = nh.sanitizer_reports(r.stderr)
    assert not reports, "\n".join(reports[:20]) + "\n" + r.stderr[-3000:]
    assert r.returncode == 0, r.stderr[-3000:]
    err = assert_close(nh.parse_csv(r.stdout), linux_run(loop, host), loop.columns(), "sanitized")
    print(f"closed loop ASan/UBSan clean in {time.perf_counter() - t:.1f} s; vs linux64 worst "
          f"relative difference {err:.3g}")
