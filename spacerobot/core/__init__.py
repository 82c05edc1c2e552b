"""The native core (C99, ``native/src``) bound with ctypes.

The install step (``setup.py`` -> ``native/build.py``) compiles ``libspacerobot`` into
``spacerobot/core/lib/``; the estimator FMU's binary is built from the same sources, so the
library, the command line and the FMUs run one implementation of the mathematics.

``SPACEROBOT_CORE_LIB`` names another build of the library (tests of a fresh build).
"""
from __future__ import annotations

import ctypes
import os
from pathlib import Path
from typing import Optional

import numpy as np

#: the binaries the install step built (``native/build.py``)
LIB_DIR = Path(__file__).resolve().parent / "lib"

_DOUBLE_P = ctypes.POINTER(ctypes.c_double)

#: the library's file name on each platform, in the order looked for
LIB_NAMES = ("libspacerobot.so", "libspacerobot.dylib", "libspacerobot.dll")


class CoreUnavailable(ImportError):
    """The native library is not built (an install without its build step)."""


def library_path() -> Path:
    """The library to load: ``$SPACEROBOT_CORE_LIB``, else the installed build."""
    env = os.environ.get("SPACEROBOT_CORE_LIB")
    if env:
        return Path(env)
    for name in LIB_NAMES:
        if (LIB_DIR / name).is_file():
            return LIB_DIR / name
    return LIB_DIR / "libspacerobot.so"


def load_library(path: Optional[os.PathLike] = None) -> ctypes.CDLL:
    """Load ``libspacerobot`` (``path`` or :func:`library_path`)."""
    p = Path(path) if path else library_path()
    if not p.is_file():
        raise CoreUnavailable(
            f"the native core is not built ({p} is missing): reinstall the package "
            f"(pip install -e .), which compiles it, or run python native/build.py")
    return ctypes.CDLL(str(p))


_LIB: Optional[ctypes.CDLL] = None


def lib() -> ctypes.CDLL:
    """The loaded library (loaded once per process)."""
    global _LIB
    if _LIB is None:
        _LIB = load_library()
    return _LIB


def dptr(a: np.ndarray):
    """``double *`` to the data of a C-contiguous float64 array (kept alive by the caller)."""
    if a.dtype != np.float64 or not a.flags.c_contiguous:
        raise TypeError("expected a C-contiguous float64 array")
    return a.ctypes.data_as(_DOUBLE_P)
