"""Install step of the native core: ``native/build.py`` compiles ``libspacerobot`` and the FMUs'
binaries into ``spacerobot/core/lib/`` (the package's metadata is in pyproject.toml)."""
import importlib.util
import sys
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent


def _native():
    spec = importlib.util.spec_from_file_location("spacerobot_native_build", HERE / "native" / "build.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


class BuildPyWithNative(build_py):
    """build_py, then the native core (into the source tree for an editable install)."""

    def run(self):
        super().run()
        native = _native()
        if getattr(self, "editable_mode", False):
            out = HERE / "spacerobot" / "core" / "lib"
        else:
            out = Path(self.build_lib) / "spacerobot" / "core" / "lib"
        print("spacerobot: compiling the native core ...", file=sys.stderr)
        try:
            native.build_all(out, log=lambda msg: print(msg, file=sys.stderr))
        except native.BuildError as e:
            raise SystemExit(f"spacerobot: the native core did not compile:\n{e}")


setup(cmdclass={"build_py": BuildPyWithNative})
