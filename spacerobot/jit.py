"""Loading of the Numba-compiled kernel modules with a compilation cache that persists.

Numba compiles a kernel on its first call in a process (seconds) and can keep the machine
code on disk, in a directory derived from the kernel's source path. An FMU's sources live in
a fresh temporary directory each time a host extracts it, so that cache would never be found
again. :func:`load` therefore imports a kernel module from a copy of its source in a
content-addressed directory of the user's cache (``$SPACEROBOT_CACHE_DIR``, else
``$XDG_CACHE_HOME/spacerobot``, else ``~/.cache/spacerobot``): the library and every
extraction of every FMU built from the same source share one compiled cache, so only the very
first run on a machine compiles. If that directory cannot be written, the module is imported
from where it is (and compiled in each new process).

A kernel module must be self-contained (only NumPy, Numba and its own functions): Numba keys a
cached function by its own source file and does not notice a change in a compiled callee that
lives in another file, and here the content hash of the one file names the cache. That is why
the plant's and the estimator's kernel modules each carry their own small Cholesky solve.
"""
from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
from pathlib import Path
from types import ModuleType


def cache_root() -> Path:
    """Directory that holds the content-addressed kernel sources and their Numba caches."""
    env = os.environ.get("SPACEROBOT_CACHE_DIR")
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "spacerobot"


def _stable_copy(src: Path) -> Path:
    """The path of a copy of ``src`` under :func:`cache_root` named by its content hash."""
    code = src.read_bytes()
    folder = cache_root() / f"{src.stem}-{hashlib.sha256(code).hexdigest()[:20]}"
    dst = folder / src.name
    if not (dst.is_file() and dst.read_bytes() == code):
        folder.mkdir(parents=True, exist_ok=True)
        tmp = folder / f".{src.name}.{os.getpid()}.tmp"
        tmp.write_bytes(code)
        os.replace(tmp, dst)          # atomic: concurrent processes see a whole file
    return dst


def load(package: str, name: str) -> ModuleType:
    """Import the kernel module ``package.name`` (see the module docstring); idempotent.

    The module is registered under its ordinary name, so ``from .name import f`` in the
    package finds it; relative imports inside it resolve against ``package`` as usual.
    """
    full = f"{package}.{name}"
    if full in sys.modules:
        return sys.modules[full]
    src = Path(sys.modules[package].__file__).with_name(f"{name}.py")
    try:
        path = _stable_copy(src)
    except (OSError, RuntimeError):     # unwritable cache, or no home directory to put it in
        path = src
    spec = importlib.util.spec_from_file_location(full, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[full] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[full]
        raise
    return module
