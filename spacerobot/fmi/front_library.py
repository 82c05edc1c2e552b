"""Build step of the FMUs' own FMI binary: ``front_library.c`` compiled with the system C
compiler, and the record of the Python installation it starts (docs/fmus.md, "The front
library").

pythonfmu 0.7.0's export library cannot be loaded by a host that is not Python without
``LD_PRELOAD``, ``PYTHONHOME`` and ``PYTHONPATH``, and crashes at exit (double free); the front
library fixes both. :func:`install` puts it into an FMU built by pythonfmu:

- ``binaries/linux64/<id>.so``          the front library (compiled here, for this Python)
- ``binaries/linux64/pythonfmu_export.so``  pythonfmu's library, renamed, which the front loads
- ``resources/python_runtime.txt``      the record: this interpreter's version, ``sys.base_prefix``,
                                        shared libpython and default module search path

Everything here is build time only; it is not bundled into the FMUs.
"""
from __future__ import annotations

import atexit
import functools
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import warnings
import zipfile
from pathlib import Path
from typing import List, Optional

SOURCE = Path(__file__).with_name("front_library.c")
RECORD_NAME = "python_runtime.txt"
PYTHONFMU_NAME = "pythonfmu_export.so"
PLATFORM = "linux64"


class FrontLibraryUnavailable(RuntimeError):
    """The front library cannot be built here (reason in the message)."""


def libpython() -> Optional[Path]:
    """This interpreter's shared library, or None (Python built without ``--enable-shared``)."""
    cfg = sysconfig.get_config_vars()
    if not cfg.get("Py_ENABLE_SHARED"):
        return None
    path = Path(cfg.get("LIBDIR") or "", cfg.get("LDLIBRARY") or "")
    return path if path.is_file() and ".so" in path.name else None


@functools.lru_cache(maxsize=None)
def search_path() -> List[str]:
    """The default module search path of this interpreter, as a fresh isolated process sees it
    (standard library, site-packages and the folders their ``.pth`` files add, e.g. Pinocchio's
    ``cmeel.prefix``), without ``PYTHONPATH``, the current directory or a script's folder, and
    without the project's own source tree. Only existing folders."""
    out = subprocess.run([sys.executable, "-I", "-c", "import sys, json; print(json.dumps(sys.path))"],
                         capture_output=True, text=True, check=True).stdout
    project = Path(__file__).resolve().parents[2]
    paths = []
    for p in json.loads(out):
        if p and os.path.isdir(p) and Path(p).resolve() != project and p not in paths:
            paths.append(p)
    return paths


def runtime_record() -> str:
    """Text of ``resources/python_runtime.txt`` (format: see front_library.c)."""
    lib = libpython()
    lines = ["# The Python installation this FMU runs in (written by spacerobot build; read by",
             "# binaries/linux64/*.so when the host process has no Python of its own).",
             f"version={sys.version_info.major}.{sys.version_info.minor}",
             f"home={sys.base_prefix}",
             f"library={lib}"]
    lines += [f"path={p}" for p in search_path()]
    return "\n".join(lines) + "\n"


def c_compiler() -> Optional[str]:
    """``$CC`` or the first of cc, gcc, clang on PATH."""
    for name in filter(None, (os.environ.get("CC"), "cc", "gcc", "clang")):
        found = shutil.which(name)
        if found:
            return found
    return None


def _fmi_headers() -> Path:
    import fmpy

    d = Path(fmpy.__file__).parent / "c-code"
    if not (d / "fmi2Functions.h").is_file():
        raise FrontLibraryUnavailable(f"the FMI 2.0 headers are not in {d} (fmpy's c-code)")
    return d


def compile_front(out: Path) -> Path:
    """Compile the front library into ``out`` (a .so path); raises FrontLibraryUnavailable."""
    if not sys.platform.startswith("linux"):
        raise FrontLibraryUnavailable(f"the front library is written for Linux, not {sys.platform}")
    if libpython() is None:
        raise FrontLibraryUnavailable(
            "this Python has no shared libpython (Py_ENABLE_SHARED = 0), which a host that is "
            "not Python needs to load")
    cc = c_compiler()
    if cc is None:
        raise FrontLibraryUnavailable("no C compiler found (set CC or install cc/gcc/clang)")
    cmd = [cc, "-shared", "-fPIC", "-O2", "-std=gnu11", "-Wall", "-Wextra", "-Werror",
           "-Wno-format-truncation", "-Wl,-z,defs", f"-I{sysconfig.get_paths()['include']}", f"-I{_fmi_headers()}",
           "-o", str(out), str(SOURCE), "-ldl", "-lpthread"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise FrontLibraryUnavailable(f"{' '.join(cmd)} failed:\n{r.stderr.strip()}")
    return out


@functools.lru_cache(maxsize=None)
def front_binary() -> Path:
    """The front library compiled for this Python (once per process, into a temporary folder
    removed at exit)."""
    folder = Path(tempfile.mkdtemp(prefix="spacerobot-front-"))
    atexit.register(shutil.rmtree, folder, True)
    return compile_front(folder / "front.so")


def install(fmu: Path, model_identifier: str) -> bool:
    """Replace the linux64 binary of the pythonfmu FMU ``fmu`` (in place) by the front library.

    Returns False, with a warning, when the front library cannot be built here: the FMU then
    keeps pythonfmu's stock binary, which Python hosts load but other hosts only with
    ``LD_PRELOAD``/``PYTHONHOME``/``PYTHONPATH`` and which may crash at their exit.
    """
    try:
        front = front_binary()
    except FrontLibraryUnavailable as e:
        warnings.warn(f"{fmu.name}: keeping pythonfmu's stock binary, which hosts that are not "
                      f"Python cannot load without set-up: {e}", RuntimeWarning, stacklevel=2)
        return False
    stock = f"binaries/{PLATFORM}/{model_identifier}.so"
    tmp = fmu.with_suffix(".fmu.tmp")
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
        names = src.namelist()
        if stock not in names:
            tmp.unlink()
            raise FrontLibraryUnavailable(f"{fmu} has no {stock}")
        for info in src.infolist():
            data = src.read(info)
            if info.filename == stock:
                dst.writestr(f"binaries/{PLATFORM}/{PYTHONFMU_NAME}", data)
                dst.write(front, stock)
            else:
                dst.writestr(info, data)
        dst.writestr(f"resources/{RECORD_NAME}", runtime_record())
    os.replace(tmp, fmu)
    return True
