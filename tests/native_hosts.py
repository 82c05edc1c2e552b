"""Helpers of the native FMU host tests (tests/test_native_fmu_hosts.py, test_native_fmu_fuzz.py,
test_native_closed_loop_host.py).

* the tools, each ``None`` where missing: the system C compiler, mingw-w64
  (``x86_64-w64-mingw32-gcc``), Wine, valgrind, a working ASan/UBSan runtime;
* the FMU binaries of every model (:data:`MODELS`: plant, sensors, estimator) from the
  sources in this tree, built once per test process (each pytest-xdist worker) with
  ``native/build.py`` (plain: linux64 and
  win64; sanitised: linux64 with ``-fsanitize=address,undefined``), and the FMUs of any kind
  assembled from them (:func:`spacerobot.fmi.native.build_native_fmu`), extracted to fresh
  folders;
* the C hosts (``tests/c_host/fmu_host.c``, ``fmu_fuzz.c``) compiled for Linux or Windows;
* one Wine prefix per test process under its pytest temporary folder (tests/wine.py), and
  running a host from an EMPTY environment (only ``PATH=/usr/bin:/bin``; under Wine also the
  Wine variables).
"""
from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import zipfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Dict, List, Optional, Sequence

import pytest

from wine import EMPTY_PATH, WinePrefix, wine, wine_path  # noqa: F401 (the tests' nh.wine*)

ROOT = Path(__file__).resolve().parents[1]
C_HOST = Path(__file__).resolve().parent / "c_host"
HOST_SOURCE = C_HOST / "fmu_host.c"
FUZZ_SOURCE = C_HOST / "fmu_fuzz.c"
#: the model kinds with a native FMU -> model identifier (native/build.py's MODELS)
MODELS = {"plant": "SpaceRobotPlant", "sensors": "SpaceRobotSensors",
          "estimator": "SpaceRobotEstimator"}
#: the estimator, the default of the helpers that take a model kind
MODEL = "estimator"
IDENT = MODELS[MODEL]
#: the flags of a sanitised build (FMU binary and host alike)
SANITIZE = ("-fsanitize=address,undefined", "-fno-omit-frame-pointer", "-g")
#: a sanitiser report fails the run: UBSan stops at its first finding, ASan looks for leaks
SANITIZER_ENV = {"ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0:exitcode=23",
                 "UBSAN_OPTIONS": "halt_on_error=1:print_stacktrace=1:exitcode=24"}
SANITIZER_WORDS = ("ERROR: AddressSanitizer", "ERROR: LeakSanitizer", "runtime error:",
                   "SUMMARY: UndefinedBehaviorSanitizer")

_LOCK = threading.Lock()
_CACHE: dict = {}


# ---- tools -------------------------------------------------------------------------------------
def c_compiler() -> Optional[str]:
    for name in (os.environ.get("CC", ""), "cc", "gcc", "clang"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def mingw() -> Optional[str]:
    return shutil.which("x86_64-w64-mingw32-gcc")


def valgrind() -> Optional[str]:
    return shutil.which("valgrind")


def require(tool: Optional[str], what: str) -> str:
    """``tool``, or skip the test saying what is missing."""
    if tool is None:
        pytest.skip(f"{what} is not installed")
    return tool


def asan_missing(work: Path) -> Optional[str]:
    """``None`` when a program built with :data:`SANITIZE` runs here, else why not."""
    key = "asan"
    with _LOCK:
        if key not in _CACHE:
            cc = c_compiler()
            if cc is None:
                _CACHE[key] = "no C compiler"
            else:
                src, exe = work / "asan_probe.c", work / "asan_probe"
                src.write_text("#include <stdlib.h>\nint main(void) { char *p = malloc(4); "
                               "p[0] = 1; int r = p[0] - 1; free(p); return r; }\n")
                r = subprocess.run([cc, *SANITIZE, str(src), "-o", str(exe)],
                                   capture_output=True, text=True)
                if r.returncode != 0:
                    _CACHE[key] = f"the ASan/UBSan runtime is missing ({r.stderr.strip()[-200:]})"
                else:
                    r = subprocess.run([str(exe)], capture_output=True, text=True,
                                       env={"PATH": EMPTY_PATH, **SANITIZER_ENV})
                    _CACHE[key] = (None if r.returncode == 0 else
                                   f"an ASan program does not run here: {r.stderr[-300:]}")
        return _CACHE[key]


# ---- the FMU binaries of this tree (native/build.py) ---------------------------------------------
def native_build():
    """``native/build.py`` as a private module (its PLATFORMS may be replaced in this copy)."""
    name = "_spacerobot_native_build_for_hosts"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, ROOT / "native" / "build.py")
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod
        spec.loader.exec_module(mod)
    return sys.modules[name]


def estimator_library(tmp_dir_factory):
    """The estimator library under test: $SPACEROBOT_CORE_LIB, or the installed one if it has
    every function the binding declares (and the state check), else a fresh build of
    native/src into a directory from ``tmp_dir_factory`` (pytest's tmp_path_factory)."""
    from spacerobot.core import CoreUnavailable, load_library
    from spacerobot.core.estimator import _bind
    try:
        L = _bind(load_library())
        L.sr_estimator_data_check                 # (an older build lacks it: build anew)
    except (CoreUnavailable, AttributeError, OSError, RuntimeError):
        if os.environ.get("SPACEROBOT_CORE_LIB"):
            raise
        out = tmp_dir_factory.mktemp("core")
        subprocess.run([sys.executable, str(ROOT / "native" / "build.py"), "--out", str(out)],
                       check=True, capture_output=True)
        L = _bind(load_library(next(out.glob("libspacerobot.*"))))
    return L


def build_core(tmp_dir: Path, sources: Sequence[str]):
    """The core library under test as a ``ctypes.CDLL``: ``$SPACEROBOT_CORE_LIB``, else the
    modules ``sources`` (names in ``native/src``) built by native/build.py, warnings errors."""
    import ctypes
    env = os.environ.get("SPACEROBOT_CORE_LIB")
    if env:
        return ctypes.CDLL(env)
    return ctypes.CDLL(str(native_build().build_library(tmp_dir, sources, strict=True)))


#: built binaries are kept here between sessions, by a digest of everything that makes them
BUILD_CACHE = Path(tempfile.gettempdir()) / "spacerobot-native-hosts"


def _sources(model: str = MODEL) -> List[Path]:
    nb = native_build()
    return [ROOT / "native" / "build.py", *sorted(nb.SRC.glob("*")), *sorted(nb.FMI2.glob("*")),
            nb.model_glue(model)]


def _build(platform: str, sanitize: bool, model: str = MODEL) -> Path:
    """The FMU binary of ``model`` for ``platform`` (sanitised: ``-O1`` plus :data:`SANITIZE`,
    compile and link), built by ``native/build.py``'s own ``build_fmu_binary`` (its sources,
    includes and flags) unless a build of the same sources, flags and compiler is cached."""
    nb = native_build()
    cc = nb.PLATFORMS[platform].compiler()
    if cc is None:
        raise nb.BuildError(f"no compiler for {platform}")
    h = hashlib.sha256(f"{model} {platform} {sanitize} {cc} {SANITIZE}".encode())
    h.update(subprocess.run([cc, "--version"], capture_output=True).stdout)
    for p in _sources(model):
        h.update(p.name.encode() + b"\0" + p.read_bytes())
    out_dir = BUILD_CACHE / h.hexdigest()[:24]
    target = out_dir / "fmu" / platform / f"{nb.MODELS[model]}{nb.PLATFORMS[platform].suffix}"
    if target.is_file():
        return target
    mod = nb
    if sanitize:
        # a private copy of the module whose platform adds the flags: build_fmu_binary itself
        # (sources, includes, defines) stays the tree's
        spec = importlib.util.spec_from_file_location(f"_sr_build_san_{model}_{platform}",
                                                      ROOT / "native" / "build.py")
        mod = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = mod
        spec.loader.exec_module(mod)
        base = mod.PLATFORMS[platform]
        mod.PLATFORMS = {**mod.PLATFORMS, platform: dataclasses.replace(
            base, cflags=(*base.cflags, "-O1", *SANITIZE), ldflags=(*base.ldflags, *SANITIZE))}
    built = mod.build_fmu_binary(model, platform, out_dir / "fmu")
    _prune_cache(keep=out_dir)
    return built


def _prune_cache(keep: Path, entries: int = 36) -> None:
    """Only the newest builds stay in the cache."""
    try:
        dirs = sorted((d for d in BUILD_CACHE.iterdir() if d.is_dir() and d != keep),
                      key=lambda d: d.stat().st_mtime, reverse=True)
    except OSError:
        return
    for d in dirs[entries - 1:]:
        shutil.rmtree(d, ignore_errors=True)


def fmu_binaries(work: Path, models: Sequence[str] = (MODEL,),
                 sanitized: bool = True) -> Dict[str, Path]:
    """Library folders (``<dir>/fmu/<platform>/<model identifier>.*``, as
    :func:`spacerobot.fmi.native.build_native_fmu` takes them) holding the binaries of
    ``models`` (kinds of :data:`MODELS`) from this tree's sources, each built once per process:
    ``{"plain": dir, "sanitized": dir}``; win64 inside "plain" where mingw is installed; no
    "sanitized" where the ASan runtime is missing or ``sanitized`` is false. The folders are the
    same for every call (a later call adds its models' binaries). Built in parallel."""
    unknown = [m for m in models if m not in MODELS]
    assert not unknown, f"no native model {unknown}; choose from {sorted(MODELS)}"
    variants = ["plain"] + (["sanitized"] if sanitized and asan_missing(work) is None else [])
    with _LOCK:
        done = _CACHE.setdefault("binaries_of", set())
        todo = [(m, v) for m in dict.fromkeys(models) for v in variants if (m, v) not in done]
        if not todo:
            return {k: d for k, d in _CACHE["binaries"].items() if k in variants}
    native_build()                            # imported once, before the threads use it
    jobs = []
    for m, v in todo:
        if v == "plain":
            jobs.append(("plain", "linux64", False, m))
            if mingw():
                jobs.append(("plain", "win64", False, m))
        else:
            jobs.append(("sanitized", "linux64", True, m))
    out = {}
    with ThreadPoolExecutor(max_workers=min(3, os.cpu_count() or 1)) as ex:
        built = [(kind, plat, ex.submit(_build, plat, san, m)) for kind, plat, san, m in jobs]
        for kind, plat, f in built:
            path = f.result()                 # a build error fails the test, with its output
            dst = work / f"lib_{kind}" / "fmu" / plat / path.name
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(path, dst)
            out[kind] = work / f"lib_{kind}"
    with _LOCK:
        _CACHE.setdefault("binaries", {}).update(out)
        _CACHE["binaries_of"].update(todo)
        return {k: d for k, d in _CACHE["binaries"].items() if k in variants}


# ---- FMUs --------------------------------------------------------------------------------------
@dataclasses.dataclass
class Variable:
    vr: int
    type: str
    causality: str
    variability: str
    name: str


class Extracted:
    """An FMU unzipped into a fresh folder: its binaries, resource URIs, variables (the model
    identifier, hence the binaries' names, from the variable table's ``model`` line)."""

    def __init__(self, fmu: Path, folder: Path):
        if folder.exists():
            shutil.rmtree(folder)
        folder.mkdir(parents=True)
        with zipfile.ZipFile(fmu) as z:
            z.extractall(folder)
        self.fmu = fmu
        self.dir = folder
        self.uri = (folder / "resources").as_uri()
        self.wine_uri = "file:///Z:" + (folder / "resources").as_uri()[len("file://"):]
        self.variables: List[Variable] = []
        self.ident = IDENT
        for line in (folder / "resources" / "spacerobot_variables.txt").read_text().splitlines():
            f = line.split()
            if line.startswith("guid "):
                self.guid = f[1]
            elif line.startswith("model "):
                self.ident = f[1]
            elif f and f[0].isdigit():
                self.variables.append(Variable(int(f[0]), f[1], f[2], f[3], f[6]))
        self.kind = next((k for k, i in MODELS.items() if i == self.ident), None)
        self.so = folder / "binaries" / "linux64" / f"{self.ident}.so"
        self.dll = folder / "binaries" / "win64" / f"{self.ident}.dll"
        self.vr = {v.name: v.vr for v in self.variables}
        self.start = {}
        for line in (folder / "resources" / "spacerobot_variables.txt").read_text().splitlines():
            f = line.split()
            if f and f[0].isdigit():
                self.start[f[6]] = _from_bits(f[4])

    def vrs(self, type_: str, causality: str) -> List[int]:
        return [v.vr for v in self.variables if v.type == type_ and v.causality == causality]

    def names(self, type_: str, causality: str) -> List[str]:
        return [v.name for v in self.variables if v.type == type_ and v.causality == causality]


def _from_bits(text: str) -> float:
    """A start value of the variable table: IEEE-754 bits ``0x...``."""
    import struct
    return struct.unpack("<d", struct.pack("<Q", int(text, 16)))[0]


def native_fmu(work: Path, kind: str, robot: str, target: Optional[str], lib_dir: Path,
               tag: str) -> Extracted:
    """The FMU of model ``kind`` (:data:`MODELS`) of ``scenario(robot, target)`` built from
    ``lib_dir``'s binaries, copied to a fresh folder and extracted there (cached per test process)."""
    from spacerobot.fmi.native import build_native_fmu
    from spacerobot.robots import scenario

    assert kind in MODELS, kind
    key = ("fmu", kind, robot, target, str(lib_dir), tag)
    with _LOCK:
        if key not in _CACHE:
            prefix = "fmu" if kind == MODEL else f"fmu_{kind}"
            d = work / f"{prefix}_{tag}_{robot}_{target or 'default'}"
            fmu = build_native_fmu(kind, scenario(robot, target), d / "built", lib_dir=lib_dir)
            fresh = d / "copy" / fmu.name                 # the FMU copied to a fresh folder
            fresh.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(fmu, fresh)
            _CACHE[key] = Extracted(fresh, d / "extracted")
        return _CACHE[key]


def estimator_fmu(work: Path, robot: str, target: Optional[str], lib_dir: Path,
                  tag: str) -> Extracted:
    """The estimator FMU of ``scenario(robot, target)`` (:func:`native_fmu`)."""
    return native_fmu(work, MODEL, robot, target, lib_dir, tag)


# ---- hosts -------------------------------------------------------------------------------------
def compile_host(source: Path, work: Path, platform: str = "linux64",
                 sanitize: bool = False) -> Path:
    """``source`` compiled warning-free as a Linux program (gcc, dlopen) or a Windows one
    (mingw, LoadLibrary); cached per test process."""
    key = ("host", str(source), platform, sanitize)
    with _LOCK:
        if key in _CACHE:
            return _CACHE[key]
    flags = ["-std=c99", "-O1", "-Wall", "-Wextra", "-Werror"]
    if platform == "linux64":
        cc = require(c_compiler(), "a C compiler")
        exe = work / f"{source.stem}{'_san' if sanitize else ''}"
        cmd = [cc, *flags, *(SANITIZE if sanitize else ()), "-o", str(exe), str(source),
               "-ldl", "-lm"]
    else:
        cc = require(mingw(), "mingw-w64 (x86_64-w64-mingw32-gcc)")
        exe = work / f"{source.stem}.exe"
        cmd = [cc, *flags, "-o", str(exe), str(source), "-static-libgcc"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, f"{' '.join(cmd)}\n{r.stderr}"
    with _LOCK:
        _CACHE[key] = exe
    return exe


def empty_env(extra: Optional[dict] = None) -> dict:
    """An EMPTY environment but for PATH (what a tool started by a scheduler may see)."""
    return {"PATH": EMPTY_PATH, **(extra or {})}


def wine_prefix(work: Path) -> WinePrefix:
    require(wine(), "Wine")
    with _LOCK:
        if "wine" not in _CACHE:
            _CACHE["wine"] = WinePrefix(work / "wineprefix")
        return _CACHE["wine"]


def run(cmd: Sequence, env: dict, timeout: float = 300) -> subprocess.CompletedProcess:
    """Run a host; Windows line ends (CR LF) become LF."""
    return _text(subprocess.run([str(c) for c in cmd], capture_output=True, env=env,
                                timeout=timeout))


def run_wine(work: Path, cmd: Sequence, timeout: float = 300) -> subprocess.CompletedProcess:
    """Run a Windows host under the test process's Wine prefix (:meth:`wine.WinePrefix.run`),
    as :func:`run` does."""
    return _text(wine_prefix(work).run(cmd, timeout=timeout))


def _text(r: subprocess.CompletedProcess) -> subprocess.CompletedProcess:
    return subprocess.CompletedProcess(r.args, r.returncode,
                                       r.stdout.decode(errors="replace").replace("\r", ""),
                                       r.stderr.decode(errors="replace").replace("\r", ""))


def sanitizer_reports(stderr: str) -> List[str]:
    return [line for line in stderr.splitlines() if any(w in line for w in SANITIZER_WORDS)]


def hex_bits(x: float) -> str:
    """The IEEE-754 bits of ``x`` as the host's input files take them (exact, locale-free)."""
    import struct
    return "0x%016x" % struct.unpack("<Q", struct.pack("<d", float(x)))[0]


# ---- what the tests share ------------------------------------------------------------------------
def work_dir(tmp_path_factory) -> Path:
    """The test process's folder for the native hosts' builds, FMUs and Wine prefix (one for
    every test file in the process, so that they share the builds; one per pytest-xdist
    worker)."""
    w = tmp_path_factory.getbasetemp() / "native_hosts"
    w.mkdir(exist_ok=True)
    return w


def host_binaries(work: Path, kinds, sanitized: bool = True) -> Dict[str, Path]:
    """:func:`fmu_binaries` of ``kinds``, the Wine prefix started first where Wine and mingw are
    installed (its creation overlaps the builds)."""
    if wine() and mingw():
        wine_prefix(work)
    return fmu_binaries(work, kinds, sanitized=sanitized)


def parse_csv(stdout: str):
    """A host's CSV output as a 2-D float array."""
    import numpy as np
    return np.array([[float(x) for x in line.split(",")] for line in stdout.strip().splitlines()])


def worst_relative(a, b) -> float:
    """Largest |a - b| / |b| (0 where equal; inf where only b is 0)."""
    import numpy as np
    assert a.shape == b.shape, (a.shape, b.shape)
    diff = np.abs(a - b)
    with np.errstate(divide="ignore", invalid="ignore"):
        return float(np.max(np.where(diff == 0, 0.0, diff / np.abs(b))))
