"""Build the native core of spacerobot with the system's C compilers.

One C99 source tree, several binaries:

* ``libspacerobot`` (the machine's own platform): the numerical core with its ``sr_*`` API,
  which Python binds with ctypes (:mod:`spacerobot.core`);
* one FMI 2.0 and one FMI 3.0 binary per model and platform: the same core, the shared FMI
  layer (``native/fmi/``: ``fmi_layer.c`` and the thin ``fmi2_api.c`` or ``fmi3_api.c``,
  chosen by ``-DFMI_VERSION=2|3``) and the model's glue (``fmu_<model>/<model>.c``), exporting
  only the ``fmi2*`` or ``fmi3*`` functions, into ``<out>/fmu/<platform folder>/`` (FMI 2.0
  folders ``linux64``, ``win64``, ``darwin64``; FMI 3.0 ``x86_64-linux``, ``x86_64-windows``,
  ...). ``linux64`` with the system compiler (``$CC``, cc, gcc or clang), ``win64`` with
  ``x86_64-w64-mingw32-gcc`` where that cross-compiler is installed (Debian:
  ``gcc-mingw-w64-x86-64``). A platform that cannot be built is skipped with one line saying
  why; the FMUs then claim only the platforms they carry.
* only when asked (``--zig``, or ``SPACEROBOT_BUILD_ZIG=1`` in the install step's
  environment): the FMI 3.0 binaries for ``x86_64-darwin``, ``aarch64-darwin`` and
  ``aarch64-linux`` with ``zig cc`` from the ``ziglang`` package (``pip install ziglang``). Its first build per target
  compiles zig's C runtime (up to minutes), hence not in the default install. These binaries
  cannot run here: :func:`exported_symbols` checks what they export.

Run by the package's install step (``setup.py``), or by hand::

    python native/build.py                    # everything into spacerobot/core/lib/
    python native/build.py --zig              # ... and the macOS / ARM Linux binaries
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
#: the shared FMI layer (FMI 2.0 and 3.0)
FMI = HERE / "fmi"
FMI2 = FMI            # its former name, kept for the tests' build helpers
#: the FMI versions built, and the API file of each
FMI_VERSIONS = (2, 3)
#: where the install step puts the binaries (inside the Python package)
DEFAULT_OUT = ROOT / "spacerobot" / "core" / "lib"
#: the models with a native FMU: model name -> model identifier
MODELS = {"estimator": "SpaceRobotEstimator", "sensors": "SpaceRobotSensors",
          "plant": "SpaceRobotPlant"}
#: the core modules each model's binary is built from (the estimator carries no plant code)
MODEL_SOURCES = {"estimator": ("sr_math.c", "sr_text.c", "linalg.c", "arm.c", "body.c", "sample.c",
                               "equations.c", "differencing.c", "physical.c", "sensor_noise.c",
                               "standard_params.c", "noise_profile.c", "information.c", "info_rows.c", "info_fit.c",
                               "excite_design.c", "est_options.c", "est_model.c", "est_rows.c",
                               "est_rls.c", "est_uncertainty.c", "est_eiv.c", "est_corr.c",
                               "est_tracker.c", "est_consider.c", "est_paper.c", "est_joint.c",
                               "est_fit.c", "est_hold.c", "est_modal.c", "band.c", "est_band.c",
                               "est_report.c", "est_update.c"),
                 "sensors": ("sr_math.c", "sr_text.c", "sample.c", "rng.c", "sensor_noise.c", "sensors.c"),
                 "plant": ("sr_math.c", "sr_text.c", "linalg.c", "arm.c", "body.c", "sample.c",
                           "dynamics.c", "dynamics_aba.c", "dynamics_crba.c", "dynamics_state.c",
                           "plant.c", "plant_params.c", "plant_step.c", "plant_control.c",
                           "plant_excitation.c", "plant_propellant.c", "plant_leaves.c")}

#: flags of every compilation: C99, optimised (-O3: 9 % fewer instructions per estimator sample
#: than -O2, the same results bit for bit: no reassociation without -ffast-math), no contraction
#: into FMA (the same results on every platform and compiler), hidden symbols unless marked
#: SR_API / FMI2_Export / FMI3_Export
COMMON = ["-std=c99", "-O3", "-ffp-contract=off", "-fvisibility=hidden", "-Wall", "-Wextra"]


@dataclass(frozen=True)
class Platform:
    """A target platform: its FMI 2.0 folder name (None: FMI 2.0 names none), compiler
    candidates, file suffix, flags, its FMI 3.0 folder name, and, for a ``zig cc`` platform,
    zig's target triple."""

    fmi2: Optional[str]
    compilers: Sequence[str]
    suffix: str
    cflags: Sequence[str] = ()
    ldflags: Sequence[str] = ()
    libs: Sequence[str] = field(default_factory=lambda: ["-lm"])
    fmi3: Optional[str] = None
    zig_target: Optional[str] = None

    def compiler(self) -> Optional[str]:
        if self.zig_target:
            return sys.executable if zig_missing() is None else None
        for name in self.compilers:
            if name and shutil.which(name):
                return shutil.which(name)
        return None

    def command(self) -> Optional[List[str]]:
        """The compiler command (a list: ``zig cc`` is ``python -m ziglang cc -target T``)."""
        cc = self.compiler()
        if cc is None:
            return None
        return [cc, "-m", "ziglang", "cc", "-target", self.zig_target] if self.zig_target else [cc]

    def folder(self, fmi_version: int) -> Optional[str]:
        """The platform's binaries folder in an FMU of ``fmi_version`` (None: not defined)."""
        return self.fmi3 if fmi_version == 3 else self.fmi2

    @property
    def name(self) -> str:
        return self.fmi2 or self.fmi3


PLATFORMS = {
    "linux64": Platform("linux64", (os.environ.get("CC", ""), "cc", "gcc", "clang"), ".so",
                        ("-fPIC",), ("-shared", "-Wl,--no-undefined"), fmi3="x86_64-linux"),
    # a plain C DLL: depends on KERNEL32.dll and msvcrt.dll only
    "win64": Platform("win64", ("x86_64-w64-mingw32-gcc",), ".dll", (),
                      ("-shared", "-static-libgcc"), fmi3="x86_64-windows"),
}
#: the platforms built with ``zig cc`` (only when asked: :func:`build_all` ``zig=True``), for
#: FMI 3.0 only: FMI 2.0 names no folder for ARM, and its FMUs keep linux64 + win64
ZIG_PLATFORMS = {
    "x86_64-darwin": Platform(None, (), ".dylib", ("-fPIC",), ("-shared",), fmi3="x86_64-darwin",
                              zig_target="x86_64-macos"),
    "aarch64-darwin": Platform(None, (), ".dylib", ("-fPIC",), ("-shared",), fmi3="aarch64-darwin",
                               zig_target="aarch64-macos"),
    "aarch64-linux": Platform(None, (), ".so", ("-fPIC",), ("-shared", "-Wl,--no-undefined"),
                              fmi3="aarch64-linux", zig_target="aarch64-linux-gnu"),
}


def zig_missing() -> Optional[str]:
    """None when ``zig cc`` (the ``ziglang`` package) is importable, else why not."""
    import importlib.util
    if importlib.util.find_spec("ziglang") is None:
        return f"the ziglang package is not installed in {sys.executable} (pip install ziglang)"
    return None


def platform_by_name(name: str) -> Platform:
    """A platform of :data:`PLATFORMS` or :data:`ZIG_PLATFORMS` by key or FMI folder name."""
    for key, plat in {**PLATFORMS, **ZIG_PLATFORMS}.items():
        if name in (key, plat.fmi2, plat.fmi3):
            return plat
    raise KeyError(f"unknown platform {name!r}")


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
    cc = platform.command()
    if cc is None:
        raise BuildError(f"no compiler for {platform.name} (tried "
                         f"{', '.join(filter(None, platform.compilers)) or 'zig cc'})")
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=platform.suffix, dir=out.parent)
    os.close(fd)
    cmd = [*cc, *COMMON, *(["-Werror"] if strict else []), *platform.cflags,
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


def layer_sources(fmi_version: int = 2) -> List[Path]:
    """The FMI layer's C files of one FMI version: the shared part and that version's API."""
    if fmi_version not in FMI_VERSIONS:
        raise ValueError(f"fmi_version must be one of {FMI_VERSIONS}, got {fmi_version!r}")
    return [FMI / "fmi_layer.c", FMI / "fmi_state.c", FMI / f"fmi{fmi_version}_api.c"]


def build_fmu_binary(model: str, platform: str, out_dir: Path, strict: bool = False,
                     fmi_version: int = 2) -> Path:
    """The FMI ``fmi_version`` binary of ``model`` for ``platform`` (a key or folder name of
    :data:`PLATFORMS` / :data:`ZIG_PLATFORMS`) into ``out_dir/<FMI folder>/``."""
    plat = PLATFORMS.get(platform) or platform_by_name(platform)
    folder = plat.folder(fmi_version)
    if folder is None:
        raise BuildError(f"FMI {fmi_version}.0 defines no binaries folder for {plat.name}")
    sources = [*core_sources(MODEL_SOURCES[model]), *layer_sources(fmi_version), model_glue(model)]
    out = Path(out_dir) / folder / f"{MODELS[model]}{plat.suffix}"
    return compile_binary(plat, sources, out, defines=[f"FMI_VERSION={fmi_version}"],
                          includes=[FMI], strict=strict)


def build_fmu_binaries(model: str, platform: str, out_dir: Path, strict: bool = False,
                       fmi_versions: Sequence[int] = FMI_VERSIONS) -> List[Path]:
    """The binaries of ``model`` for ``platform``, one per FMI version of ``fmi_versions`` (that
    the platform has a folder for), as :func:`build_fmu_binary` builds them, but with the core
    and the glue compiled once for all versions (they do not depend on the FMI version; only
    the layer is compiled per version)."""
    plat = PLATFORMS.get(platform) or platform_by_name(platform)
    versions = [v for v in fmi_versions if plat.folder(v)]
    if len(versions) < 2:
        return [build_fmu_binary(model, platform, out_dir, strict, v) for v in versions]
    cc = plat.command()
    if cc is None:
        raise BuildError(f"no compiler for {plat.name}")
    out = []
    with tempfile.TemporaryDirectory(prefix="spacerobot_objs_") as tmp:
        objects = []
        for i, src in enumerate([*core_sources(MODEL_SOURCES[model]), model_glue(model)]):
            obj = Path(tmp) / f"{i:02d}_{src.stem}.o"      # names unique: two estimator.c
            cmd = [*cc, *COMMON, *(["-Werror"] if strict else []), *plat.cflags,
                   f"-I{SRC}", f"-I{FMI}", "-c", str(src), "-o", str(obj)]
            res = subprocess.run(cmd, capture_output=True, text=True)
            if res.returncode != 0:
                raise BuildError(f"{' '.join(cmd)}\n{res.stdout}{res.stderr}")
            objects.append(obj)
        for v in versions:
            target = Path(out_dir) / plat.folder(v) / f"{MODELS[model]}{plat.suffix}"
            # the order of build_fmu_binary: core, layer, glue (the same layout)
            sources = [*objects[:-1], *layer_sources(v), objects[-1]]
            out.append(compile_binary(plat, sources, target, defines=[f"FMI_VERSION={v}"],
                                      includes=[FMI], strict=strict))
    return out


def build_all(out_dir: Path = DEFAULT_OUT, strict: bool = False, log=print,
              zig: Optional[bool] = None, fmi_versions: Sequence[int] = FMI_VERSIONS,
              jobs: Optional[int] = None) -> dict:
    """The library and every model's FMU binaries (each FMI version of ``fmi_versions``) for
    every platform that has a compiler; with ``zig`` (default: the environment variable
    ``SPACEROBOT_BUILD_ZIG`` set and not 0) also :data:`ZIG_PLATFORMS`, whose exports are then
    checked (:func:`check_exports`). ``jobs`` compilations run at once (default: the CPUs, at
    most 4).

    Returns ``{"library": path, "fmu": {platform: [paths]}, "skipped": {platform: why}}``.
    Raises :class:`BuildError` if the library itself cannot be built.
    """
    from concurrent.futures import ThreadPoolExecutor

    if zig is None:
        zig = os.environ.get("SPACEROBOT_BUILD_ZIG", "0") not in ("", "0")
    out_dir = Path(out_dir)
    result = {"library": build_library(out_dir, strict=strict), "fmu": {}, "skipped": {}}
    platforms = {**PLATFORMS, **(ZIG_PLATFORMS if zig else {})}
    if not zig:
        log(f"spacerobot: {', '.join(ZIG_PLATFORMS)} FMU binaries not built (only on request: "
            "pip install ziglang, then python native/build.py --zig)")
    todo = []
    for name, plat in platforms.items():
        if plat.compiler() is None:
            why = (zig_missing() if plat.zig_target
                   else f"no {' or '.join(filter(None, plat.compilers))} on PATH")
            result["skipped"][name] = why
            log(f"spacerobot: {name} FMU binaries not built: {why}")
            continue
        todo += [(name, m) for m in MODELS]
    workers = jobs or min(4, os.cpu_count() or 1)
    with ThreadPoolExecutor(max_workers=workers) as ex:
        futures = [(name, ex.submit(build_fmu_binaries, m, name, out_dir / "fmu", strict,
                                    fmi_versions)) for name, m in todo]
        for name, f in futures:
            for path in f.result():
                if platforms[name].zig_target:
                    check_exports(path, 3)
                result["fmu"].setdefault(name, []).append(path)
    # binaries of a platform not built now are not of these sources: gone, so that no FMU
    # carries them (e.g. an earlier --zig build, or mingw removed since)
    for name, plat in {**PLATFORMS, **ZIG_PLATFORMS}.items():
        for version in (2, 3):
            folder = plat.folder(version)
            if name in result["fmu"] and version in fmi_versions:
                continue
            if folder and (out_dir / "fmu" / folder).is_dir():
                shutil.rmtree(out_dir / "fmu" / folder)
                log(f"spacerobot: removed the {folder} FMU binaries of an earlier build")
    return result


# ---- exported symbols of a binary that cannot run here ------------------------------------------
def exported_symbols(path: Path) -> List[str]:
    """The names of the functions and data a shared library exports: an ELF file's defined
    global or weak dynamic symbols of default or protected visibility, a Mach-O file's external
    symbols defined in a section (without the leading underscore), a PE DLL's export table.
    A small reader of the three formats (64-bit, little-endian), so that binaries for other
    platforms can be checked without their tools."""
    import struct
    data = Path(path).read_bytes()
    if data[:4] == b"\x7fELF":
        if data[4] != 2 or data[5] != 1:
            raise ValueError(f"{path}: not a 64-bit little-endian ELF file")
        shoff, = struct.unpack_from("<Q", data, 0x28)
        shentsize, shnum = struct.unpack_from("<HH", data, 0x3A)
        sections = [struct.unpack_from("<IIQQQQIIQQ", data, shoff + i * shentsize)
                    for i in range(shnum)]
        names = []
        for sh in sections:
            if sh[1] != 11:                                  # SHT_DYNSYM
                continue
            str_off = sections[sh[6]][4]                     # sh_link: its string table
            for k in range(sh[5] // 24):
                st_name, st_info, st_other, st_shndx = struct.unpack_from(
                    "<IBBH", data, sh[4] + 24 * k)
                bind, visibility = st_info >> 4, st_other & 3
                if st_shndx != 0 and bind in (1, 2) and visibility in (0, 3) and st_name:
                    end = data.index(b"\0", str_off + st_name)
                    names.append(data[str_off + st_name:end].decode())
        return sorted(names)
    if data[:4] == b"\xcf\xfa\xed\xfe":                      # MH_MAGIC_64
        ncmds, = struct.unpack_from("<I", data, 16)
        off, names = 32, []
        for _ in range(ncmds):
            cmd, size = struct.unpack_from("<II", data, off)
            if cmd == 0x2:                                   # LC_SYMTAB
                symoff, nsyms, stroff, _ = struct.unpack_from("<IIII", data, off + 8)
                for k in range(nsyms):
                    strx, ntype = struct.unpack_from("<IB", data, symoff + 16 * k)
                    # external (N_EXT), defined in a section (N_SECT), not a debug entry
                    # (N_STAB) nor private (N_PEXT)
                    if ntype & 0xE0 == 0 and ntype & 0x10 == 0 and ntype & 0x0E == 0x0E \
                            and ntype & 0x01:
                        end = data.index(b"\0", stroff + strx)
                        names.append(data[stroff + strx:end].decode().removeprefix("_"))
            off += size
        return sorted(names)
    if data[:2] == b"MZ":
        pe, = struct.unpack_from("<I", data, 0x3C)
        nsec, = struct.unpack_from("<H", data, pe + 6)
        opt_size, = struct.unpack_from("<H", data, pe + 20)
        opt = pe + 24
        export_rva, _ = struct.unpack_from("<II", data, opt + 112)     # PE32+ data directory 0
        secs = [struct.unpack_from("<IIII", data, opt + opt_size + 40 * i + 8)
                for i in range(nsec)]                       # VirtualSize, VA, RawSize, RawPtr

        def at(rva: int) -> int:
            for vsize, va, rsize, ptr in secs:
                if va <= rva < va + max(vsize, rsize):
                    return ptr + rva - va
            raise ValueError(f"{path}: RVA {rva:#x} outside every section")
        if export_rva == 0:
            return []
        n_names, _, names_rva = struct.unpack_from("<III", data, at(export_rva) + 24)
        out = []
        for k in range(n_names):
            rva, = struct.unpack_from("<I", data, at(names_rva) + 4 * k)
            s = at(rva)
            out.append(data[s:data.index(b"\0", s)].decode())
        return sorted(out)
    raise ValueError(f"{path}: not an ELF, Mach-O or PE file")


#: what every Mach-O dylib exports besides its own symbols (defined by the linker)
MACHO_LINKER_SYMBOLS = ("__dso_handle", "_mh_dylib_header")


def check_exports(path: Path, fmi_version: int) -> List[str]:
    """The symbols ``path`` exports, all named ``fmi<fmi_version>*`` but for the Mach-O linker's
    own (:data:`MACHO_LINKER_SYMBOLS`) (:class:`BuildError` otherwise, or if it exports none);
    returns the ``fmi<fmi_version>*`` ones."""
    prefix = f"fmi{fmi_version}"
    names = [n for n in exported_symbols(path)
             if not (Path(path).suffix == ".dylib" and n in MACHO_LINKER_SYMBOLS)]
    others = [n for n in names if not n.startswith(prefix)]
    if others or not names:
        raise BuildError(f"{path} exports {len(names)} symbols, of which not {prefix}*: "
                         f"{', '.join(others[:10]) or '(it exports none)'}")
    return names


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, help="build only libspacerobot, into this folder")
    ap.add_argument("--sources", nargs="*", default=(), help="with --out: only these native/src files")
    ap.add_argument("--strict", action="store_true", help="warnings are errors")
    ap.add_argument("--zig", action="store_true", help="also the macOS and ARM Linux FMU binaries "
                    "with zig cc (pip install ziglang; the first build per target compiles "
                    "zig's C runtime, minutes)")
    ap.add_argument("--fmi-version", type=int, nargs="+", choices=FMI_VERSIONS,
                    default=list(FMI_VERSIONS), help="the FMI versions to build (default: both)")
    a = ap.parse_args(argv)
    try:
        if a.out:
            print(build_library(a.out, a.sources, a.strict))
        else:
            res = build_all(strict=a.strict, zig=a.zig or None, fmi_versions=a.fmi_version)
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
