"""Build the native core of spacerobot with the system's C compilers.

One C99 source tree, several binaries:

* ``libspacerobot`` (the machine's own platform): the numerical core with its ``sr_*`` API,
  which Python binds with ctypes (:mod:`spacerobot.core`);
* one FMI 2.0 binary per model and platform: the same core, the shared FMI layer
  (``native/fmi2/``) and the model's glue (``fmu_<model>/<model>.c``), exporting only the
  ``fmi2*`` functions. ``linux64`` with the system compiler (``$CC``, cc, gcc or clang),
  ``win64`` with ``x86_64-w64-mingw32-gcc`` where that cross-compiler is installed (Debian:
  ``gcc-mingw-w64-x86-64``). A platform that cannot be built is skipped with one line saying
  why; the FMUs then claim only the platforms they carry.

Run by the package's install step (``setup.py``), or by hand::

    python native/build.py                    # everything into spacerobot/core/lib/
    python native/build.py --out DIR [--sources linalg.c ...]   # only libspacerobot, into DIR

No other build system is needed: the sources are few and compile in seconds.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Optional, Sequence

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SRC = HERE / "src"
FMI2 = HERE / "fmi2"
#: where the install step puts the binaries (inside the Python package)
DEFAULT_OUT = ROOT / "spacerobot" / "core" / "lib"
#: the models with a native FMU: model name -> model identifier
MODELS = {"estimator": "SpaceRobotEstimator", "sensors": "SpaceRobotSensors",
          "plant": "SpaceRobotPlant"}
#: the core modules each model's binary is built from (the estimator carries no plant code)
MODEL_SOURCES = {"estimator": ("sr_math.c", "linalg.c", "arm.c", "equations.c", "differencing.c",
                               "physical.c", "estimator.c", "est_paper.c", "est_joint.c"),
                 "sensors": ("sr_math.c", "rng.c", "sensors.c"),
                 "plant": ("sr_math.c", "linalg.c", "arm.c", "dynamics.c", "plant.c")}

#: flags of every compilation: C99, optimised, no contraction into FMA (the same results on
#: every platform and compiler), hidden symbols unless marked SR_API / FMI2_Export
COMMON = ["-std=c99", "-O2", "-ffp-contract=off", "-fvisibility=hidden", "-Wall", "-Wextra"]


@dataclass(frozen=True)
class Platform:
    """A target platform: its FMI 2.0 folder name, compiler candidates, file suffix, flags."""

    fmi2: str
    compilers: Sequence[str]
    suffix: str
    cflags: Sequence[str] = ()
    ldflags: Sequence[str] = ()
    libs: Sequence[str] = field(default_factory=lambda: ["-lm"])

    def compiler(self) -> Optional[str]:
        for name in self.compilers:
            if name and shutil.which(name):
                return shutil.which(name)
        return None


PLATFORMS = {
    "linux64": Platform("linux64", (os.environ.get("CC", ""), "cc", "gcc", "clang"), ".so",
                        ("-fPIC",), ("-shared", "-Wl,--no-undefined")),
    # a plain C DLL: depends on KERNEL32.dll and msvcrt.dll only
    "win64": Platform("win64", ("x86_64-w64-mingw32-gcc",), ".dll", (),
                      ("-shared", "-static-libgcc")),
}


class BuildError(RuntimeError):
    """A compilation failed; the message holds the compiler's output."""


def host_platform() -> Optional[str]:
    """The FMI 2.0 platform name of this machine, if the project builds for it."""
    import platform
    if sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64"):
        return "linux64"
    return None


def core_sources(names: Sequence[str] = ()) -> List[Path]:
    """The core's C files (all of ``native/src``, or those named)."""
    if names:
        return [SRC / n for n in names]
    return sorted(SRC.glob("*.c"))


def compile_binary(platform: Platform, sources: Sequence[Path], out: Path,
                   defines: Sequence[str] = (), includes: Sequence[Path] = (),
                   strict: bool = False) -> Path:
    """Compile and link ``sources`` into the shared library ``out`` (written atomically)."""
    cc = platform.compiler()
    if cc is None:
        raise BuildError(f"no compiler for {platform.fmi2} (tried {', '.join(filter(None, platform.compilers))})")
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=platform.suffix, dir=out.parent)
    os.close(fd)
    cmd = [cc, *COMMON, *(["-Werror"] if strict else []), *platform.cflags,
           *(f"-D{d}" for d in defines), *(f"-I{p}" for p in (SRC, *includes)),
           *map(str, sources), "-o", tmp, *platform.ldflags, *platform.libs]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        if os.path.exists(tmp):            # the linker may have removed it already
            os.unlink(tmp)
        raise BuildError(f"{' '.join(cmd)}\n{res.stdout}{res.stderr}")
    os.replace(tmp, out)
    return out


def build_library(out_dir: Path, sources: Sequence[str] = (), strict: bool = False) -> Path:
    """``libspacerobot`` for this machine into ``out_dir``."""
    plat = PLATFORMS[host_platform() or "linux64"]
    return compile_binary(plat, core_sources(sources), Path(out_dir) / f"libspacerobot{plat.suffix}",
                          defines=["SR_BUILD_LIBRARY"], strict=strict)


def model_glue(model: str) -> Path:
    """The model's FMI glue, ``fmu_<model>/<model>.c``."""
    return ROOT / f"fmu_{model}" / f"{model}.c"


def build_fmu_binary(model: str, platform: str, out_dir: Path, strict: bool = False) -> Path:
    """The FMI 2.0 binary of ``model`` for ``platform`` into ``out_dir/<platform>/``."""
    plat = PLATFORMS[platform]
    sources = [*core_sources(MODEL_SOURCES[model]), *sorted(FMI2.glob("*.c")), model_glue(model)]
    out = Path(out_dir) / plat.fmi2 / f"{MODELS[model]}{plat.suffix}"
    return compile_binary(plat, sources, out, includes=[FMI2], strict=strict)


def build_all(out_dir: Path = DEFAULT_OUT, strict: bool = False, log=print) -> dict:
    """The library and every model's FMU binary for every platform that has a compiler.

    Returns ``{"library": path, "fmu": {platform: [paths]}, "skipped": {platform: why}}``.
    Raises :class:`BuildError` if the library itself cannot be built.
    """
    out_dir = Path(out_dir)
    result = {"library": build_library(out_dir, strict=strict), "fmu": {}, "skipped": {}}
    for name, plat in PLATFORMS.items():
        if plat.compiler() is None:
            why = f"no {' or '.join(filter(None, plat.compilers))} on PATH"
            result["skipped"][name] = why
            log(f"spacerobot: {name} FMU binaries not built: {why}")
            continue
        result["fmu"][name] = [build_fmu_binary(m, name, out_dir / "fmu", strict=strict)
                               for m in MODELS]
    return result


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, help="build only libspacerobot, into this folder")
    ap.add_argument("--sources", nargs="*", default=(), help="with --out: only these native/src files")
    ap.add_argument("--strict", action="store_true", help="warnings are errors")
    a = ap.parse_args(argv)
    try:
        if a.out:
            print(build_library(a.out, a.sources, a.strict))
        else:
            res = build_all(strict=a.strict)
            print(res["library"])
            for paths in res["fmu"].values():
                for p in paths:
                    print(p)
    except BuildError as e:
        print(f"spacerobot: native build failed:\n{e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
