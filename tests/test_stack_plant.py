"""The plant needs little stack: hosts that step FMUs on worker threads give them 64 KiB to
1 MiB (musl's default thread stack is 128 KiB).

* Every function frame of the plant's C sources (native/build.py MODEL_SOURCES["plant"] and
  the plant FMU's glue) is at most 16 KiB, as gcc measures it (-O3 -fstack-usage, the build's
  flags), and none is of unbounded dynamic size.
* The plant core runs in a thread with a 64 KiB stack (tests/c_host/stack_plant.c, compiled
  here with the system compiler and the build's flags from the plant's sources): the robot
  record read, the model built with two hinged panels and two slosh modes, 4 s of
  communication steps of 0.1 s (100 internal RK4 steps each) with the excitation ramping in, a
  change of rate, the propellant used, the outputs,
  controls and references after every step; its end state equals the library's plant run the
  same way (to 1e-9: the same code, compiled twice). The host's own check: a thread that first
  uses 256 KiB of its stack crashes with 64 KiB and runs with 1 MiB.
Skipped, with the reason, without a C compiler that supports -fstack-usage or POSIX threads.
"""
from __future__ import annotations

import importlib.util
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from spacerobot.core.plant import NativePlant
from spacerobot.core.robot_record import write_robot_record
from spacerobot.robots import (SPATIAL_PANELS, SPATIAL_SLOSH, Appendages, Controller,
                               Excitation, Propellant, RigidBody, Slosh, get_robot)

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "native" / "src"
HOST = ROOT / "tests" / "c_host" / "stack_plant.c"
FRAME_MAX = 16 * 1024
STACK = 64 * 1024


def _build():
    spec = importlib.util.spec_from_file_location("_sr_native_build_stack",
                                                  ROOT / "native" / "build.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


BUILD = _build()


def _cc() -> str:
    if sys.platform.startswith("win"):
        pytest.skip("POSIX threads (pthread_attr_setstacksize) are not available on Windows")
    for name in ("cc", "gcc", "clang"):
        if shutil.which(name):
            return shutil.which(name)
    pytest.skip("no C compiler (cc, gcc or clang) on the PATH")


@pytest.fixture(scope="module")
def objects(tmp_path_factory):
    """The plant's sources and the plant FMU's glue compiled with the build's flags and
    -fstack-usage: (objects of the core, the stack-usage files of all)."""
    cc = _cc()
    out = tmp_path_factory.mktemp("stackobj")
    core = [SRC / s for s in BUILD.MODEL_SOURCES["plant"]]
    objs, sus = [], []
    for i, src in enumerate(core + [ROOT / "fmu_plant" / "plant.c"]):
        obj = out / f"{i}_{src.stem}.o"
        r = subprocess.run([cc, *BUILD.COMMON, "-fstack-usage", f"-I{SRC}",
                            f"-I{ROOT / 'native' / 'fmi'}", "-c", str(src), "-o", str(obj)],
                           capture_output=True, text=True)
        if r.returncode != 0 and "stack-usage" in r.stderr:
            pytest.skip(f"{cc} does not support -fstack-usage: {r.stderr.strip()[:200]}")
        assert r.returncode == 0, r.stderr
        sus.append(obj.with_suffix(".su"))
        if src in core:
            objs.append(obj)
    return cc, objs, sus


@pytest.mark.slow
def test_no_frame_of_the_plant_above_16_kib(objects):
    _, _, sus = objects
    frames = []
    for su in sus:
        if not su.exists():
            pytest.skip(f"the compiler wrote no stack-usage file {su.name}")
        for line in su.read_text().splitlines():
            where, size, kind = line.rsplit("\t", 2)
            frames.append((int(size), kind, where))
    assert len(frames) > 100                                   # every file was measured
    worst = max(frames)
    assert worst[0] <= FRAME_MAX, worst
    assert all(kind in ("static", "dynamic,bounded") for _, kind, _ in frames), \
        [f for f in frames if f[1] not in ("static", "dynamic,bounded")]


@pytest.fixture(scope="module")
def host(objects, tmp_path_factory):
    cc, objs, _ = objects
    out = tmp_path_factory.mktemp("stackhost")
    exe = out / "stack_plant"
    r = subprocess.run([cc, *BUILD.COMMON, f"-I{SRC}", str(HOST), *map(str, objs), "-o",
                        str(exe), "-lpthread", "-lm"], capture_output=True, text=True)
    if r.returncode != 0 and re.search(r"pthread\.h|lpthread", r.stderr):
        pytest.skip(f"no POSIX threads: {r.stderr.strip()[:200]}")
    assert r.returncode == 0, r.stderr
    record = out / "spatial.txt"
    write_robot_record(get_robot("spatial"), record)
    return exe, record


def _run(host, stack, *extra):
    exe, record = host
    return subprocess.run([str(exe), str(record), str(stack), *extra], capture_output=True,
                          text=True, timeout=120)


def _library_plant_end(robot):
    """The host's run through the library: its target, controller, excitation, propellant,
    initial velocities and home posture 0; r_S[0] after 40 steps of 0.1 s."""
    p = NativePlant(robot, robot.base, RigidBody(250.0, (0.1, 0.05, 0.2), (20.0, 25.0, 30.0,
                                                                            0.0, 0.0, 0.0)),
                    Controller(K_D=0.7071), (1.0, 2.0, 3.0), (0.1, 0.2, 0.3), 1e-3,
                    Excitation(att_max=0.3, q_max=0.3, qd_max=0.2, qdd_max=0.1, period=8.0,
                               ramp=1.0),
                    Propellant(m0=80.0, Isp=220.0, R=0.27, arm=1.0, r=(0.3, 0.2, -0.2)),
                    q_home=np.zeros(robot.n_joints), flex=Appendages(2, SPATIAL_PANELS[:2] * 2),
                    slosh=Slosh(2, SPATIAL_SLOSH[:2] * 2))
    p.set_excitation(1.0)
    for k in range(40):
        if k == 15:
            p.set_excitation_rate(3.0)
        p.advance(0.1)
    return p.t, p.outputs()["r_S"][0]


@pytest.mark.slow
def test_a_plant_step_runs_in_a_thread_with_a_64_kib_stack(host):
    r = _run(host, STACK)
    assert r.returncode == 0, (r.returncode, r.stdout, r.stderr)
    word, t, x = r.stdout.split()
    assert word == "ok"
    t_ref, x_ref = _library_plant_end(get_robot("spatial"))
    assert float(t) == pytest.approx(4.0, abs=1e-12) and t_ref == pytest.approx(4.0, abs=1e-12)
    assert float(x) == pytest.approx(x_ref, rel=1e-9) and abs(x_ref) > 1.0


@pytest.mark.slow
def test_the_host_thread_has_the_stack_it_asked_for(host):
    """A thread that uses 256 KiB of its stack crashes with 64 KiB, and runs with 1 MiB."""
    assert _run(host, STACK, "hog").returncode != 0
    assert _run(host, 1024 * 1024, "hog").returncode == 0
