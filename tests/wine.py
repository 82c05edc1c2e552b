"""Running the Windows builds under Wine in the tests, and what works around Wine's own faults.

* :class:`WinePrefix`: one prefix per test process, booted in the background (``wineboot -i``)
  so that the boot overlaps the builds. A first boot has been seen to fail once in the
  parallel suite ("could not load kernel32.dll, status c0000135", not reproduced): it is
  booted afresh then, twice at most.
* :meth:`WinePrefix.run`: a run that ends with exit code 1 and prints nothing, on stdout or
  stderr, did not start (the hosts print a summary or an error line wherever they exit with
  1; a crash makes Wine print "Unhandled exception" on stderr; an ``abort()`` exits with 3
  and nothing printed, and is not run again): it is run again, twice at most, with a warning
  that the suite's summary shows. Every other result is the test's to judge.
  Such a run has been seen once in CI (the fuzzer's estimator run, stop 51: exit code 1, no
  output; 300 runs of the same command here, two at a time and at random intervals, all
  started). Wine's server exits when its last program does, so each run starts it and its
  services afresh; a server kept for the whole process (``wineserver -p``) would avoid that,
  but the services it then starts keep the first run's output pipes open, and that run never
  ends.
"""
from __future__ import annotations

import shutil
import subprocess
import warnings
from pathlib import Path
from typing import Optional, Sequence

#: quiet Wine; no Mono or Gecko installer, no menu entries
WINE_ENV = {"WINEDEBUG": "-all", "WINEDLLOVERRIDES": "mscoree,mshtml=;winemenubuilder.exe=d"}
#: the PATH of an empty environment (what a tool started by a scheduler may see)
EMPTY_PATH = "/usr/bin:/bin"
#: runs of a program that did not start, before the result is the test's
LAUNCH_RETRIES = 2


def wine() -> Optional[str]:
    return shutil.which("wine")


def wine_path(p: Path) -> str:
    """A Linux path as Wine's Z: drive sees it."""
    return "Z:" + str(p).replace("/", "\\")


def did_not_start(r: subprocess.CompletedProcess) -> bool:
    """A run that exited with 1 and printed nothing at all (module docstring)."""
    return r.returncode == 1 and not r.stdout and not r.stderr


class WinePrefix:
    """A Wine prefix for one test process; :meth:`run` waits for its boot."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.proc = self._boot()
        self.ready = False
        self.failed: Optional[str] = None      # the boot's error ("": booted), once known

    def _env(self) -> dict:
        """The environment of a program under this prefix: empty but for PATH and Wine's."""
        return {"PATH": EMPTY_PATH, "WINEPREFIX": str(self.folder), **WINE_ENV}

    def _boot(self) -> subprocess.Popen:
        return subprocess.Popen([wine(), "wineboot", "-i"], stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE, env=self._env())

    def _booted(self) -> str:
        """Wait for the boot; "" where it succeeded, else its error output."""
        _, err = self.proc.communicate(timeout=300)
        for _ in range(2):
            if self.proc.returncode == 0:
                return ""
            subprocess.run(["wineserver", "-k"], timeout=120, env=self._env())
            shutil.rmtree(self.folder, ignore_errors=True)
            self.proc = self._boot()
            _, err = self.proc.communicate(timeout=300)
        return "" if self.proc.returncode == 0 else err.decode(errors="replace")[-2000:]

    def _wait(self) -> None:
        """The boot done, and its wineserver gone."""
        if not self.ready:
            if self.failed is None:
                self.failed = self._booted()
            assert not self.failed, f"wineboot failed: {self.failed}"
            subprocess.run(["wineserver", "-w"], env=self._env(), timeout=120)
            self.ready = True

    def run(self, cmd: Sequence, timeout: float = 300,
            input: Optional[bytes] = None) -> subprocess.CompletedProcess:
        """``wine cmd...`` (bytes in and out), run again where it did not start (module
        docstring)."""
        self._wait()
        args = [wine(), *(str(c) for c in cmd)]

        def launch():
            return subprocess.run(args, input=input, capture_output=True, env=self._env(),
                                  timeout=timeout)
        r = launch()
        for attempt in range(1, LAUNCH_RETRIES + 1):
            if not did_not_start(r):
                break
            warnings.warn(f"Wine: {Path(str(cmd[0])).name} exited with {r.returncode} and no "
                          f"output (did not start); run again ({attempt} of "
                          f"{LAUNCH_RETRIES})", stacklevel=3)
            r = launch()
        return r
