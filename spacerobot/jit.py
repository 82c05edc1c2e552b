"""Loading of the Numba-compiled kernel modules with a compilation cache that persists.

Numba compiles a kernel on its first call in a process (seconds) and can keep the machine
code on disk, in a directory derived from the kernel's source path. An FMU's sources live in
a fresh temporary directory each time a host extracts it, so that cache would never be found
again. :func:`load` therefore imports a kernel module from a copy of its source in a directory
of the user's cache (``$SPACEROBOT_CACHE_DIR``, else ``$XDG_CACHE_HOME/spacerobot``, else
``~/.cache/spacerobot``) named by the module's full name and the source's content hash:
every extraction of an FMU built from the same source shares one compiled cache, so only the
very first run on a machine compiles.

The full name is part of the folder name because Numba's cached code refers to the module by
that name: the library (``spacerobot.plant.kernels``) and the FMUs (``_spacerobot_plant.
plant.kernels``) each get their own folder, so that neither ever loads code that imports the
other's package (which the other's Python environment may not have).

Nothing here can stop a run: if the cache directory cannot be written, the module is imported
from where it is (Numba then keeps its cache beside it, in its own per-user folder, or in a
temporary folder for this process); a cache entry that cannot be read (corrupt, truncated) is
compiled again and one that cannot be written is skipped. Each of these gives a
:class:`RuntimeWarning` and is listed in :data:`NOTICES` (the FMUs log them through the FMI
logger).

A kernel module must be self-contained (only NumPy, Numba and its own functions), or name the
sibling kernel modules it calls in ``load(..., deps=...)``: Numba keys a cached function by its
own source file and does not notice a change in a compiled callee that lives in another file,
so the sources of those callees are hashed into the cache folder's name as well. (The plant's
and the estimator's kernel modules, in different FMUs, each carry their own small Cholesky
solve.)
"""
from __future__ import annotations

import functools
import hashlib
import importlib.util
import os
import sys
import tempfile
import warnings
from pathlib import Path
from types import ModuleType
from typing import List

#: warnings given while loading kernels in this process (also issued as RuntimeWarning)
NOTICES: List[str] = []


def _notice(msg: str) -> None:
    if msg not in NOTICES:
        NOTICES.append(msg)
        warnings.warn(msg, RuntimeWarning, stacklevel=3)


def cache_root() -> Path:
    """Directory that holds the content-addressed kernel sources and their Numba caches."""
    env = os.environ.get("SPACEROBOT_CACHE_DIR")
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "spacerobot"


def cache_folder(full_name: str, code: bytes, root: Path | None = None) -> Path:
    """Folder of the module ``full_name`` with source ``code`` under ``root`` (default
    :func:`cache_root`)."""
    key = hashlib.sha256(full_name.encode() + b"\0" + code).hexdigest()[:20]
    return (cache_root() if root is None else root) / f"{full_name.rsplit('.', 1)[-1]}-{key}"


def _stable_copy(full_name: str, src: Path, deps: bytes = b"") -> Path:
    """The path of the copy of ``src`` in its :func:`cache_folder`, written if needed; ``deps``
    (the sources of the kernel modules it calls) is part of the folder's key."""
    code = src.read_bytes()
    folder = cache_folder(full_name, code + deps)
    dst = folder / src.name
    if not (dst.is_file() and dst.read_bytes() == code):
        folder.mkdir(parents=True, exist_ok=True)
        tmp = folder / f".{src.name}.{os.getpid()}.tmp"
        tmp.write_bytes(code)
        os.replace(tmp, dst)          # atomic: concurrent processes see a whole file
    return dst


def _guard_cache(module: ModuleType) -> None:
    """Make every cached Numba function of ``module`` recompile instead of failing on a cache
    entry it cannot read, and skip an entry it cannot write."""
    try:
        from numba.core.dispatcher import Dispatcher
    except ImportError:                 # not a Numba module
        return
    for obj in list(vars(module).values()):
        cache = getattr(obj, "_cache", None) if isinstance(obj, Dispatcher) else None
        if cache is None or not hasattr(cache, "load_overload"):
            continue
        where = f"{module.__name__}.{getattr(obj, '__name__', '?')}"

        def load(*args, _orig=cache.load_overload, _where=where):
            try:
                return _orig(*args)
            except Exception as e:      # corrupt/truncated/foreign entry: compile instead
                _notice(f"kernel cache entry of {_where} in {cache_root()} cannot be read "
                        f"({type(e).__name__}: {e}); compiling it again")
                return None

        def save(*args, _orig=cache.save_overload, _where=where):
            try:
                _orig(*args)
            except Exception as e:      # e.g. the folder became read-only: run uncached
                _notice(f"kernel cache entry of {_where} cannot be written "
                        f"({type(e).__name__}: {e}); it will be compiled again next time")

        cache.load_overload, cache.save_overload = load, save


@functools.lru_cache(maxsize=None)
def _scratch_cache_dir() -> str:
    return tempfile.mkdtemp(prefix="spacerobot-numba-")


def _exec(full: str, path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(full, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[full] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[full]
        raise
    return module


def load(package: str, name: str, deps: tuple = ()) -> ModuleType:
    """Import the kernel module ``package.name`` (see the module docstring); idempotent.

    The module is registered under its ordinary name, so ``from .name import f`` in the
    package finds it; relative imports inside it resolve against ``package`` as usual.
    ``deps`` names the sibling kernel modules whose compiled functions it calls (load them
    first): their sources are part of its cache key, since Numba's cache of a caller does not
    notice a change in a callee of another file.
    """
    full = f"{package}.{name}"
    if full in sys.modules:
        return sys.modules[full]
    src = Path(sys.modules[package].__file__).with_name(f"{name}.py")
    try:
        path = _stable_copy(full, src, b"".join(src.with_name(f"{d}.py").read_bytes()
                                                 for d in deps))
    except (OSError, RuntimeError) as e:    # unwritable cache, or no home directory
        _notice(f"kernel cache {cache_root()} cannot be written ({e}); {full} is imported "
                f"from {src.parent} and its compiled code cached by Numba beside it if possible")
        path = src
    try:
        module = _exec(full, path)
    except RuntimeError as e:
        if "cannot cache" not in str(e):
            raise
        # Numba found no writable place for its cache: a temporary one, for this process only
        from numba.core import config

        _notice(f"no writable place for the compiled kernels of {full} ({e}); they are "
                "compiled in every process")
        saved, config.CACHE_DIR = config.CACHE_DIR, _scratch_cache_dir()
        try:
            module = _exec(full, path)
        finally:
            config.CACHE_DIR = saved
    _guard_cache(module)
    return module
