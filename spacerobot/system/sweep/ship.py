"""A built system sent to Dask workers by value: the ``.ssp`` archive's bytes, scattered once to
every worker, written once per worker into its local scratch space under their SHA-256.

The workers then need only the installed package, no file system shared with the client: the
archive (the SSD, its parameter sets and the FMUs, about 1 MB) travels as Dask data, once per
worker (``Client.scatter(..., broadcast=True)``; a worker that joins later fetches it from a
peer when its first task needs it), and each task finds the file its worker wrote. The name
under the scratch folder is the content's hash, so two systems never share a file and a second
sweep on the same workers reuses it; the file is written under a temporary name and renamed, so
tasks that start together on one worker never read a partial archive.
"""
from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Dict, Optional

#: the folder under a worker's local directory (or the temp directory) that holds the archives
FOLDER = "spacerobot-systems"

#: archives this process has written or checked: (folder, digest) -> path
_LOCAL: Dict[tuple, Path] = {}


@dataclass(frozen=True, repr=False)
class ShippedSystem:
    """An ``.ssp`` archive as data: its file ``name``, the SHA-256 ``digest`` of its bytes and
    the bytes themselves."""

    name: str
    digest: str
    data: bytes

    def __repr__(self) -> str:             # not the bytes (Dask's messages, tracebacks)
        return f"ShippedSystem({self.name!r}, {self.digest[:16]}, {len(self.data)} bytes)"

    @classmethod
    def read(cls, path) -> "ShippedSystem":
        """The archive at ``path`` (on the client)."""
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"{path} is not a .ssp file"
                                    + (" (a folder: give the built .ssp archive)"
                                       if path.is_dir() else ""))
        data = path.read_bytes()
        return cls(path.name, hashlib.sha256(data).hexdigest(), data)

    def _holds(self, path: Path) -> bool:
        """The file at ``path`` is this archive."""
        return path.is_file() and hashlib.sha256(path.read_bytes()).hexdigest() == self.digest

    @property
    def key(self) -> str:
        """The Dask key of the scattered archive: the same for the same bytes."""
        return f"spacerobot-system-{self.digest}"

    def local_path(self, root: Optional[Path] = None) -> Path:
        """The archive as a file on this machine: ``<root>/spacerobot-systems/<digest>/<name>``,
        written on the first call (``root``: the Dask worker's local directory in a worker,
        else the temp directory). A file already there is used if its bytes hash to the
        digest (checked once per process) and replaced otherwise."""
        folder = Path(root or scratch_root()) / FOLDER / self.digest
        memo = (str(folder), self.digest)
        path = _LOCAL.get(memo)
        if path is not None and path.is_file():
            return path
        path = folder / self.name
        if not self._holds(path):
            folder.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{self.name}.", dir=folder)
            try:
                with os.fdopen(fd, "wb") as f:
                    f.write(self.data)
                try:
                    os.replace(tmp, path)   # atomic: a reader sees all of it or nothing
                except OSError:             # Windows: another task has it open, i.e. wrote it
                    if not self._holds(path):
                        raise
            finally:
                Path(tmp).unlink(missing_ok=True)
        _LOCAL[memo] = path
        return path




def scratch_root() -> Path:
    """This Dask worker's local directory (which the worker removes when it stops), or the
    temp directory outside a worker."""
    try:
        from distributed import get_worker
        return Path(get_worker().local_directory)
    except (ImportError, ValueError):       # ValueError: not in a worker
        return Path(tempfile.gettempdir())


def run_shipped(task: Callable, item, system: ShippedSystem, runner: str,
                version: Optional[str] = None):
    """``task(item, ssp_path, runner)`` with the archive written on this machine (what each
    Dask task of a study runs); ``RuntimeError`` if this machine's package is not the
    client's ``version`` (the row would be computed by other code)."""
    from ... import __version__
    if version is not None and version != __version__:
        raise RuntimeError(f"this worker has spacerobot {__version__}, the client "
                           f"{version}: install the client's version on every worker")
    return task(item, str(system.local_path()), runner)
