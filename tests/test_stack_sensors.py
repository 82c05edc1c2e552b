"""The sensors FMU's stack and heap: every function of its binary's sources (the sensor models, the
glue, the FMI layer of both versions) has a frame of at most 16 kB (gcc -O3 -fstack-usage, the
build's flags); a whole run of the FMU (instantiate, initialise, 20 steps with the realistic
noise, read every output, free) works in a thread with a 64 KiB stack (tests/c_host/stack_host.c)
with the outputs of the same run on an 8 MiB stack; and an instance takes the heap its
variables and its state need (glibc's mallinfo2 around fmi2Instantiate), not fixed slots for
4096 variables (688 kB).
"""
from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import native_hosts as nh

FRAME_LIMIT = 16 * 1024           # bytes: the largest frame allowed
THREAD_STACK = 64 * 1024          # bytes: the stack the run gets
STACK_HOST = Path(__file__).resolve().parent / "c_host" / "stack_host.c"
MODEL = "sensors"


def _frames(cc: str, source: Path, work: Path, defines=()) -> list:
    """``[(function, bytes, qualifiers)]`` of ``source`` compiled with the build's flags and
    -fstack-usage (gcc's .su file: ``file:line:column:function<TAB>bytes<TAB>qualifiers``)."""
    nb = nh.native_build()
    obj = work / f"{source.parent.name}_{source.stem}{''.join(defines)}.o"   # two sensors.c
    cmd = [cc, *nb.COMMON, "-fPIC", "-fstack-usage", *(f"-D{d}" for d in defines),
           f"-I{nb.SRC}", f"-I{nb.FMI}", "-c", str(source), "-o", str(obj)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, f"{' '.join(cmd)}\n{r.stderr}"
    out = []
    for line in obj.with_suffix(".su").read_text().splitlines():
        where, size, qualifiers = line.rsplit("\t", 2)
        out.append((where.rsplit(":", 1)[-1], int(size), qualifiers))
    return out


def _gcc() -> str:
    gcc = shutil.which("gcc")
    if gcc is None:
        pytest.skip("gcc is not installed (-fstack-usage)")
    return gcc


def test_the_frame_reader_sees_a_large_frame(tmp_path):
    """The check below can fail: a function with a 20 kB array is read as such."""
    src = tmp_path / "big.c"
    src.write_text("double big(int i) { volatile double a[2560]; a[i] = i; return a[i / 2]; }\n")
    frames = dict((f, (n, q)) for f, n, q in _frames(_gcc(), src, tmp_path))
    assert frames["big"][0] > FRAME_LIMIT and "static" in frames["big"][1]


@pytest.mark.slow
def test_no_frame_above_16_kB(tmp_path):
    nb = nh.native_build()
    gcc = _gcc()
    sources = [*nb.core_sources(nb.MODEL_SOURCES[MODEL]), nb.model_glue(MODEL)]
    found = {}
    for src in sources:
        found[f"{src.parent.name}/{src.name}"] = _frames(gcc, src, tmp_path)
    for version in nb.FMI_VERSIONS:
        for src in nb.layer_sources(version):
            found[f"{src.name} (FMI {version}.0)"] = _frames(gcc, src, tmp_path,
                                                             (f"FMI_VERSION={version}",))
    assert all(found.values()), [k for k, v in found.items() if not v]
    names = {f for frames in found.values() for f, _, _ in frames}
    assert {"sr_sensors_advance", "sr_fmi_do_step", "sr_model_do_step", "fmi2DoStep",
            "fmi3DoStep"} <= names
    too_big = [(where, f, n, q) for where, frames in found.items() for f, n, q in frames
               if n > FRAME_LIMIT or not re.fullmatch(r"static|dynamic,bounded", q)]
    assert not too_big, too_big
    largest = max((n, f) for frames in found.values() for f, n, _ in frames)
    print(f"largest frame: {largest[1]} {largest[0]} bytes")


@pytest.fixture(scope="module")
def sensors_fmu(tmp_path_factory):
    if nh.c_compiler() is None:
        pytest.skip("no C compiler")
    work = nh.work_dir(tmp_path_factory)
    lib = nh.fmu_binaries(work, [MODEL], sanitized=False)["plain"]
    return work, nh.native_fmu(work, MODEL, "spatial", None, lib, "stack")


def _run(exe: Path, fmu, stack: int, outputs):
    """(the outputs after 20 steps, the heap bytes of the instance)."""
    cmd = [str(exe), str(fmu.so), fmu.guid, fmu.uri, str(stack), "20", "0.1",
           ",".join(str(vr) for vr in outputs)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=nh.empty_env())
    assert r.returncode == 0, f"stack {stack}: exit status {r.returncode}\n{r.stderr[-2000:]}"
    lines = r.stdout.split("\n")
    assert lines[0].startswith("heap "), r.stdout[:200]
    return np.array([float(x) for x in lines[1:] if x]), int(lines[0].split()[1])


def test_a_run_in_a_thread_with_a_64_KiB_stack(sensors_fmu, tmp_path):
    work, fmu = sensors_fmu
    cc = nh.c_compiler()
    exe = tmp_path / "stack_host"
    r = subprocess.run([cc, "-std=c99", "-O1", "-Wall", "-Wextra", "-Werror", "-pthread", "-o",
                        str(exe), str(STACK_HOST), "-ldl"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    outputs = fmu.vrs("Real", "output")
    small, heap = _run(exe, fmu, THREAD_STACK, outputs)
    large, _ = _run(exe, fmu, 8 << 20, outputs)
    assert small.shape == (len(outputs),) and np.all(np.isfinite(small))
    assert np.array_equal(small, large)
    # the measurements differ from the inputs' start values: the noise was drawn and applied
    start = np.array([fmu.start["true." + fmu.variables[vr].name] for vr in outputs])
    assert np.count_nonzero(small != start) > len(outputs) // 2


def test_an_instance_takes_the_heap_its_variables_need(sensors_fmu, tmp_path):
    """The variable slots follow the table: the whole instance (variables, values, the sensors'
    state with its 100-sample delay ring, 57.6 kB) within 200 kB, where 4096 fixed slots
    alone took 688 kB."""
    import ctypes.util
    if not ctypes.util.find_library("c") or nh.c_compiler() is None:
        pytest.skip("no C library or compiler")
    work, fmu = sensors_fmu
    exe = tmp_path / "stack_host"
    subprocess.run([nh.c_compiler(), "-std=c99", "-O1", "-pthread", "-o", str(exe),
                    str(STACK_HOST), "-ldl"], check=True)
    _, heap = _run(exe, fmu, THREAD_STACK, fmu.vrs("Real", "output")[:1])
    if heap < 0:
        pytest.skip("mallinfo2 is glibc's (2.33 or later)")
    print(f"the sensors instance ({len(fmu.variables)} variables): {heap} bytes of heap")
    assert 57_600 < heap < 200_000
