"""The sweep's results table: columns, reading (complete lines only), the append-only writer
(one flushed line per point), rewriting without re-run points, and the lock that keeps two
sweeps from writing to one table."""
from __future__ import annotations

import contextlib
import csv
import io
import os
from pathlib import Path
from typing import Dict, Iterable, List, Mapping, Tuple

from .points import PARAMS

DIAG = ("diag.samples", "diag.rejected", "diag.status")

POINT_COLUMNS = ("robot", "target", "method", "accel_source", "v0_x", "v0_y", "v0_z", "v0_norm",
                 "F_max", "stop_time", "overrides")
COLUMNS: Tuple[str, ...] = (
    ("sweep_id",) + POINT_COLUMNS + ("status", "error", "wall_time", "t_end", "worker") + DIAG
    + tuple(f"est.{p}" for p in PARAMS) + tuple(f"true.{p}" for p in PARAMS)
    + tuple(f"relerr.{p}" for p in PARAMS))


def read_table(csv_path, key: str = "sweep_id") -> List[Dict[str, str]]:
    """Rows of a results table (complete lines only, with a value in the ``key`` column);
    ``[]`` if the file does not exist."""
    path = Path(csv_path)
    if not path.exists() or path.stat().st_size == 0:
        return []
    text = path.read_text()
    if not text.endswith("\n"):               # an interrupted write: drop the partial line
        text = text[: text.rfind("\n") + 1]
    reader = csv.DictReader(io.StringIO(text))
    return [r for r in reader if r.get(key) and None not in r.values()
            and None not in r]


def canonical(rows: Iterable[Mapping[str, str]], key: str = "sweep_id") -> List:
    """The rows sorted by their id (the ``key`` column): figures computed from them (a mean is
    a float sum, whose last digit depends on the order) are then the same whatever order the
    rows finished and were written in (rows without an id keep their order, first)."""
    return sorted(rows, key=lambda r: r.get(key) or "")


def _check_header(path: Path, columns: Tuple[str, ...] = COLUMNS, what: str = "sweep") -> None:
    with path.open(newline="") as f:
        header = next(csv.reader(f), None)
    if header is not None and tuple(header) != tuple(columns):
        raise ValueError(f"{path} is not a {what} table of this version (its columns differ); "
                         f"choose another output file")


def _rewrite(path: Path, rows: List[Dict[str, str]], columns: Tuple[str, ...] = COLUMNS) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns)
        w.writeheader()
        w.writerows(rows)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


class _Table:
    """Append-only writer: one flushed (and fsynced) line per finished point."""

    def __init__(self, path: Path, columns: Tuple[str, ...] = COLUMNS):
        self.path, self.columns = path, tuple(columns)
        path.parent.mkdir(parents=True, exist_ok=True)
        new = not path.exists() or path.stat().st_size == 0
        if not new:
            data = path.read_bytes()
            if not data.endswith(b"\n"):      # drop a partial line left by an interruption
                with path.open("r+b") as f:
                    f.truncate(data.rfind(b"\n") + 1)
        self.f = path.open("a", newline="")
        self.w = csv.DictWriter(self.f, fieldnames=self.columns, extrasaction="ignore")
        if new:
            self.w.writeheader()
            self._flush()

    def _flush(self):
        self.f.flush()
        os.fsync(self.f.fileno())

    def write(self, row: Mapping[str, object]) -> None:
        self.w.writerow({k: ("" if row.get(k) is None else row.get(k)) for k in self.columns})
        self._flush()

    def close(self):
        self.f.close()


class SweepLocked(RuntimeError):
    """Another sweep is writing to the same table."""


@contextlib.contextmanager
def _exclusive(out: Path):
    """Advisory exclusive lock on ``<out>.lock`` (POSIX; elsewhere no lock)."""
    try:
        import fcntl
    except ImportError:              # pragma: no cover - Windows
        yield
        return
    lock = out.with_name(out.name + ".lock")
    with lock.open("a") as f:
        try:
            fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise SweepLocked(f"another sweep is writing to {out} (lock {lock} is held); "
                               f"wait for it or choose another output file") from None
        try:
            yield
        finally:
            fcntl.flock(f.fileno(), fcntl.LOCK_UN)
