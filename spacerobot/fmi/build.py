"""Build the plant and estimator FMUs for a scenario.

Each FMU bundles the script from ``fmu_plant/`` or ``fmu_estimator/`` plus a copy of the parts
of this library it needs, renamed to a package unique to that FMU (``_spacerobot_plant``,
``_spacerobot_estimator``) so that both can run in one Python process. The estimator bundle
has no plant package and no truth. A bundle with ``core`` (the ctypes binding of the native
core) carries the compiled library itself (``core/lib/libspacerobot.*``, the whole core) and
loads only that.
The scenario (robot description and defaults) goes into ``resources/spacerobot_config.json``.

pythonfmu's Linux binary is then replaced by the project's front library
(:mod:`.front_library`), so that any FMI host loads the FMU with no set-up and exits cleanly;
without a C compiler (or a shared libpython) the stock binary stays, with a warning.
"""
from __future__ import annotations

import importlib.util
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

from ..robots import Scenario, scenario_to_dict
from . import front_library

LIB = Path(__file__).resolve().parents[1]          # the spacerobot package
ROOT = LIB.parent                                   # repository / install root

#: what each FMU bundles from the library (modules and sub-packages)
BUNDLES = {
    "plant": ("robots.py", "interface.py", "kinematics.py", "fmi", "core", "plant"),
    "estimator": ("robots.py", "interface.py", "kinematics.py", "fmi", "core",
                  "estimator"),
    "sensors": ("robots.py", "interface.py", "kinematics.py", "fmi", "core", "sensors"),
}


def _script(kind: str) -> Path:
    spec = importlib.util.find_spec(f"fmu_{kind}")
    folder = Path(spec.submodule_search_locations[0]) if spec else ROOT / f"fmu_{kind}"
    return folder / f"spacerobot_{kind}_fmu.py"


#: how an FMU is built: ``native`` (the C core's binaries, :mod:`.native`; no Python at run
#: time) or ``pythonfmu`` (the Python core hosted by pythonfmu, for users who extend it in Python)
BACKENDS = ("native", "pythonfmu")
#: the backend ``build_fmu`` uses by default
DEFAULT_BACKEND = "native"


def native_kinds() -> tuple:
    """The kinds of FMU that have a native build."""
    from .native import MODELS
    return tuple(MODELS)


def fmu_backend(fmu) -> str:
    """The backend an FMU (a path or its bytes) was built with: ``native`` if it carries the
    native variable table, else ``pythonfmu``."""
    import io
    import zipfile

    from .native import VARIABLES_FILE
    src = io.BytesIO(fmu) if isinstance(fmu, (bytes, bytearray)) else fmu
    with zipfile.ZipFile(src) as zf:
        return "native" if f"resources/{VARIABLES_FILE}" in zf.namelist() else "pythonfmu"


def backend_of(kind: str, backend: str | None = None) -> str:
    """The backend an FMU of ``kind`` is built with when ``backend`` is asked for (None: the
    default): ``native`` only for the kinds that have a native build, ``pythonfmu`` for the
    others."""
    backend = backend or DEFAULT_BACKEND
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    return backend if backend != "native" or kind in native_kinds() else "pythonfmu"


def _bundle_core_library(lib_dir: Path) -> None:
    """Copy the compiled native core (``libspacerobot``, the one this process would load:
    :func:`spacerobot.core.library_path`) into the bundle's ``core/lib/``, where the bundled
    ``core`` package finds it at run time (it never looks elsewhere,
    :data:`spacerobot.core.BUNDLED`). The FMU then runs on the builder's platform only, like
    the library."""
    from ..core import CoreUnavailable, library_path

    src = library_path()
    if not src.is_file():
        raise CoreUnavailable(f"the native core is not built ({src} is missing): reinstall the "
                              f"package (pip install -e .) or run python native/build.py")
    lib_dir.mkdir(parents=True, exist_ok=True)
    shutil.copy2(src, lib_dir / ("libspacerobot" + src.suffix))   # a name core looks for


def build_fmu(kind: str, sc: Scenario, out_dir: str | Path, backend: str | None = None,
              fmi_version: int = 2) -> Path:
    """Build one FMU (``kind`` = 'plant', 'estimator' or 'sensors') into ``out_dir``; returns
    its path. ``backend`` (:data:`BACKENDS`; None: :data:`DEFAULT_BACKEND`): ``native`` builds the
    kinds that have a native build (:func:`native_kinds`) natively and the others with
    pythonfmu. ``fmi_version`` 3: an FMI 3.0 FMU (native kinds only)."""
    if fmi_version != 2 and backend_of(kind, backend) != "native":
        raise ValueError(f"FMI {fmi_version}.0 FMUs are built by the native backend only "
                         f"({kind!r} with backend {backend or DEFAULT_BACKEND!r})")
    if backend_of(kind, backend) == "native":
        from .native import build_native_fmu
        return build_native_fmu(kind, sc, out_dir, fmi_version=fmi_version)
    from pythonfmu.builder import FmuBuilder

    if kind not in BUNDLES:
        raise ValueError(f"kind must be one of {sorted(BUNDLES)}, got {kind!r}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    script = _script(kind)
    with tempfile.TemporaryDirectory(prefix=f"spacerobot_{kind}_") as tmp:
        stage = Path(tmp)
        pkg = stage / f"_spacerobot_{kind}"
        pkg.mkdir()
        (pkg / "__init__.py").write_text(f'"""spacerobot library bundled in the {kind} FMU."""\n')
        for item in BUNDLES[kind]:
            src = LIB / item
            if src.is_dir():
                shutil.copytree(src, pkg / item, ignore=shutil.ignore_patterns(
                    "__pycache__", "build.py", "front_library.*", "lib"))
            else:
                shutil.copy2(src, pkg / item)
        if "core" in BUNDLES[kind]:
            _bundle_core_library(pkg / "core" / "lib")
        config = stage / "spacerobot_config.json"
        from .native import known_scenario
        config.write_text(json.dumps({"kind": kind,
                                      "scenario": scenario_to_dict(known_scenario(kind, sc))},
                                     indent=1))
        shutil.copy2(script, stage / script.name)
        readme_dir = stage / "doc"
        readme_dir.mkdir()
        shutil.copy2(script.parent / "README.md", readme_dir / "index.md") if (
            script.parent / "README.md").exists() else None
        sys.path.insert(0, str(stage))
        try:
            fmu = FmuBuilder.build_FMU(stage / script.name, dest=out_dir,
                                       project_files=[pkg, config],
                                       documentation_folder=readme_dir,
                                       canGetAndSetFMUstate=True, canSerializeFMUstate=True,
                                       needsExecutionTool=True)
        finally:
            sys.path.remove(str(stage))
            for mod in [m for m in sys.modules if m.startswith(f"_spacerobot_{kind}")
                        or m == script.stem]:
                del sys.modules[mod]
    fmu = Path(fmu)
    front_library.install(fmu, fmu.stem)
    _keep_only_this_platform(fmu)
    return fmu


def _keep_only_this_platform(fmu: Path) -> None:
    """Drop the binaries of other platforms (pythonfmu's stock win64/darwin64 libraries): the
    bundled core library and the Python runtime record are this machine's, so the FMU claims
    only the platform it was built on."""
    import zipfile

    plat = {"linux": "linux64", "win32": "win64", "darwin": "darwin64"}.get(sys.platform)
    if plat is None:
        return
    keep = f"binaries/{plat}/"
    tmp = fmu.with_suffix(".fmu.tmp")
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
        for info in src.infolist():
            if not info.filename.startswith("binaries/") or info.filename.startswith(keep):
                dst.writestr(info, src.read(info))
    os.replace(tmp, fmu)
