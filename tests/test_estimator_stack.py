"""The estimator core's stack: no function frame above 16 kB, and every configuration runs in a
thread with a 64 KiB stack.

A host that steps FMUs on worker threads gives each a small stack (musl's default is 128 KiB);
the core's temporaries live in a work space beside its Data block (``sr_estimator_work_size``),
not on the stack.

* :func:`test_no_frame_above_16k`: gcc's ``-fstack-usage`` of every source the estimator FMU
  is built from (``native/build.py``'s ``MODEL_SOURCES["estimator"]`` and its glue), with the
  build's flags.
* :func:`test_every_configuration_in_a_64k_thread`: ``tests/c_host/estimator_stack.c`` runs
  every configuration of the core (its table) over 70 s of recorded samples with white noise,
  planar and spatial, in a thread with a 64 KiB stack, reading the report, the estimates and
  the message after every sample. Before the work space (the tree at e048e1d) this host died
  of SIGSEGV at the first momentum sample after the reference (``sr_estimator_update``'s own
  frame was 120 kB, its deepest chain 203 kB).
"""
from __future__ import annotations

import re
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "native" / "src"
HOST = ROOT / "tests" / "c_host" / "estimator_stack.c"
#: the largest frame allowed [bytes]
FRAME_MAX = 16 * 1024
#: the thread's stack [bytes]
STACK = 64 * 1024

sys.path.insert(0, str(ROOT / "native"))
import build as native_build  # noqa: E402


def gcc() -> str:
    cc = shutil.which("gcc")
    if cc is None:
        pytest.skip("gcc is not installed (-fstack-usage, pthreads)")
    return cc


def estimator_sources():
    return [*native_build.core_sources(native_build.MODEL_SOURCES["estimator"]),
            native_build.model_glue("estimator")]


@pytest.mark.slow
def test_no_frame_above_16k(tmp_path):
    cc = gcc()
    frames = []
    for src in estimator_sources():
        obj = tmp_path / f"{src.parent.name}_{src.stem}.o"
        subprocess.run([cc, *native_build.COMMON, "-fPIC", "-fstack-usage", f"-I{SRC}",
                        f"-I{native_build.FMI}", "-c", str(src), "-o", str(obj)], check=True,
                       cwd=tmp_path)
        for line in obj.with_suffix(".su").read_text().splitlines():
            where, size, _ = line.split("\t")
            frames.append((int(size), where.split("/")[-1]))
    assert len(frames) > 100                       # every function of every source was seen
    big = sorted((f for f in frames if f[0] > FRAME_MAX), reverse=True)
    assert not big, f"frames above {FRAME_MAX} bytes: {big}"


def _stream(robot: str, seconds: float = 70.0, dt: float = 0.1, noise: float = 1e-4):
    """``(robot, [(t, flat sample)])``: the Python plant's outputs with excitation 1, white
    noise of sd ``noise`` on every signal but the base's DCM (the estimator's sample order)."""
    from spacerobot.estimator.identifier import KEYS
    from spacerobot.plant import Plant
    from spacerobot.robots import scenario
    sc = scenario(robot)
    p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
              excitation=sc.excitation)
    p.set_excitation(1.0)
    rng = np.random.default_rng(7)
    out = []
    for k in range(int(round(seconds / dt)) + 1):
        if k:
            p.advance(dt)
        o = p.outputs()
        x = np.concatenate([np.ravel(o[key]) for key in KEYS]).astype(float)
        e = noise * rng.standard_normal(len(x))
        e[6:15] = 0.0
        out.append((k * dt, x + e))
    return sc.robot, out


@pytest.fixture(scope="module")
def host(tmp_path_factory) -> Path:
    cc = gcc()
    d = tmp_path_factory.mktemp("estimator_stack")
    exe = d / "estimator_stack"
    subprocess.run([cc, *native_build.COMMON, f"-I{SRC}", str(HOST),
                    *map(str, native_build.core_sources(native_build.MODEL_SOURCES["estimator"])),
                    "-o", str(exe), "-lpthread", "-lm"], check=True)
    return exe


def _configs(source: str):
    """The configuration names of the host's table."""
    table = source[source.index("} CONFIGS[] = {"):]
    return re.findall(r'^    \{"(\w+)", \{', table[:table.index("\n};")], re.M)


@pytest.mark.parametrize("robot", ["planar", "spatial"])
@pytest.mark.slow
def test_every_configuration_in_a_64k_thread(host, tmp_path, robot):
    from spacerobot.core.robot_record import write_robot_record
    rob, rec = _stream(robot)
    record = write_robot_record(rob, tmp_path / "robot.txt")
    samples = tmp_path / "samples.bin"
    n_flat = len(rec[0][1])
    with samples.open("wb") as f:
        f.write(struct.pack("=ii", len(rec), n_flat))
        for t, x in rec:
            f.write(np.concatenate([[t], x]).astype("=f8").tobytes())
    res = subprocess.run([str(host), str(record), str(samples), str(STACK)],
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, (res.returncode, res.stdout[-2000:], res.stderr[-2000:])
    lines = res.stdout.splitlines()
    assert lines[-1] == "done"
    seen = {}
    for line in lines[:-1]:
        f = line.split()
        seen[f[1]] = dict(zip(f[2::2], f[3::2]))
    assert sorted(seen) == sorted(_configs(HOST.read_text()))
    for name, r in seen.items():
        assert r["finite"] == "1", name
        # every configuration estimated from every sample after its differencing window (at
        # most 100 samples): the paths were taken
        full = name == "momentum_window_full"          # its ring rejects what overfills it
        assert int(r["samples"]) >= (len(rec) // 3 if full else len(rec) - 101), (name, r)
        assert int(r["status"]) in ((2, 4) if full else (2,)), (name, r)
    # the information filter replayed and the rate's choice predicted both bounds (where the
    # estimator still asked for excitation: always with ident.excite_mode = 2)
    for name in ("profile_always",):
        assert float(seen[name]["score_1"]) > 0.0, (name, seen[name])
        assert float(seen[name]["score_try"]) > 0.0, (name, seen[name])
    # the misfit path (the model-fit test's replay with the thrust held and the model error as
    # the rows' noise, the held estimates and the model-error term) ran in the thread too;
    # the rate's choice is then not tried
    for name in ("profile_misfit", "profile_misfit_joint"):
        assert seen[name]["misfit"] == "1", (name, seen[name])
        assert seen[name]["cause"] == "1", (name, seen[name])       # SR_EST_MISFIT_MODEL
        assert float(seen[name]["score_try"]) == 0.0, (name, seen[name])
    assert seen["profile_always"]["misfit"] == "0"
