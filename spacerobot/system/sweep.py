"""Parameter sweeps of the co-simulation on a Dask cluster, with a resumable CSV table.

A *point* is one co-simulation of the SSP system: robot, target size, identification method,
acceleration source, initial base velocity ``v0``, thruster bound ``F_max``, stop time, and
optionally any further parameter overrides. A *sweep* is the Cartesian product of lists of
these values (given on the command line or in a TOML file).

Every point runs :func:`spacerobot.system.runner.run_ssp` in a Dask worker process (a local
cluster by default: ``distributed.LocalCluster(processes=True, threads_per_worker=1)``, or an
existing scheduler with ``--scheduler``). The .ssp is built once per robot with
:func:`spacerobot.system.ssd.build_system` before any point is submitted; the workers receive
its path, so with a remote scheduler the build directory must be on a file system the workers
share.

Results table (CSV, one row per point, appended and flushed as each point finishes):

``sweep_id``
    stable hash of the point's parameters (:func:`point_id`); a re-run skips every point whose
    id is already in the table with ``status == "ok"`` and re-runs failed ones (their old row is
    dropped first, so that the table keeps one row per point). Rows are written by the
    process that runs the sweep, one flushed line per finished point, so an interrupted sweep
    (Ctrl-C, a crash) loses only the points in flight; ``<table>.lock`` keeps a second sweep
    from writing to the same table at the same time.
``robot, target, method, accel_source, v0_x, v0_y, v0_z, v0_norm, F_max, stop_time, overrides``
    the point's parameters (``overrides``: JSON of any extra FMI overrides, ``{}`` if none).
``status, error, wall_time, t_end, worker``
    ``ok`` or ``failed``; the error (exception type and message) of a failed point; wall-clock
    time of the point in its worker [s]; the simulated time reached [s]; ``host:pid`` of the
    worker process that ran it.
``diag.samples, diag.rejected, diag.status``
    the estimator's diagnostics at the end.
``est.<p>, true.<p>, relerr.<p>``
    for every estimated parameter ``<p>`` of the interface (``base.m``, ``base.b[1]`` ...
    ``target.Iyz``): the final estimate, the truth, and the relative error
    ``|est - true| / scale`` with ``scale = |true|``, or, where the truth is zero (a CoM
    component, a product of inertia), 1 m for ``b`` and the body's largest principal moment
    for the inertia tensor elements.

The planar model identifies only ``m``, ``b[1]``, ``b[2]`` and ``Izz`` of each body; the other
columns then hold the untouched initial guesses and are not plotted.

Example TOML (``docs/velocity_study.toml``)::

    robot = "planar"
    target = "medium"
    method = ["momentum", "force"]
    accel = ["measured", "differenced"]
    F_max = 0.1
    stop_time = 60.0
    v0 = [[0, 10], [50, 50], [200, 200]]
    workers = 2
    out = "results/velocity_study.csv"

    [overrides]          # optional extra FMI overrides applied to every point
    "plant.base.omega0[3]" = 0.1
"""
from __future__ import annotations

import argparse
import contextlib
import csv
import hashlib
import importlib
import io
import itertools
import json
import math
import os
import socket
import sys
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

from ..interface import ESTIMATE_NAMES, error_scale, estimate_vector, identified_estimates
from ..robots import DEFAULT_TARGET, INERTIA_NAMES, ROBOTS, TARGETS, scenario

#: where a point's co-simulation and the .ssp build come from ("module:function")
DEFAULT_RUNNER = "spacerobot.system.runner:run_ssp"
DEFAULT_BUILDER = "spacerobot.system.ssd:build_system"

METHOD_CODES = {"momentum": 1, "force": 2}
ACCEL_CODES = {"measured": 1, "differenced": 2}

#: every estimated parameter, in the order of ``Identifier.vector()``
PARAMS: Tuple[str, ...] = ESTIMATE_NAMES

#: the parameters each robot identifies (the planar model: x, y translation, z rotation)
IDENTIFIED = {name: tuple(identified_estimates(robot)) for name, robot in ROBOTS.items()}

DIAG = ("diag.samples", "diag.rejected", "diag.status")

POINT_COLUMNS = ("robot", "target", "method", "accel_source", "v0_x", "v0_y", "v0_z", "v0_norm",
                 "F_max", "stop_time", "overrides")
COLUMNS: Tuple[str, ...] = (
    ("sweep_id",) + POINT_COLUMNS + ("status", "error", "wall_time", "t_end", "worker") + DIAG
    + tuple(f"est.{p}" for p in PARAMS) + tuple(f"true.{p}" for p in PARAMS)
    + tuple(f"relerr.{p}" for p in PARAMS))


# ------------------------------------------------------------------------------------------------
# points
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Point:
    """One co-simulation of the sweep. ``v0`` is always stored as a 3-vector."""

    robot: str = "planar"
    target: Optional[str] = None        #: None: the robot's default target
    method: str = "momentum"
    accel_source: str = "measured"
    v0: Tuple[float, float, float] = (1.0, 2.0, 0.0)
    F_max: float = 10.0
    stop_time: float = 30.0
    overrides: Tuple[Tuple[str, float], ...] = field(default_factory=tuple)

    def __post_init__(self):
        if self.target is None and self.robot in DEFAULT_TARGET:
            object.__setattr__(self, "target", DEFAULT_TARGET[self.robot])
        v = tuple(float(x) for x in self.v0)
        if len(v) == 2:
            v = v + (0.0,)
        if len(v) != 3:
            raise ValueError(f"v0 must have 2 or 3 components, got {self.v0!r}")
        object.__setattr__(self, "v0", v)
        object.__setattr__(self, "F_max", float(self.F_max))
        object.__setattr__(self, "stop_time", float(self.stop_time))
        ov = self.overrides.items() if isinstance(self.overrides, Mapping) else self.overrides
        object.__setattr__(self, "overrides",
                           tuple(sorted((str(k), float(x)) for k, x in ov)))
        if self.method not in METHOD_CODES:
            raise ValueError(f"method must be one of {sorted(METHOD_CODES)}, got {self.method!r}")
        if self.accel_source not in ACCEL_CODES:
            raise ValueError(f"accel source must be one of {sorted(ACCEL_CODES)}, "
                             f"got {self.accel_source!r}")
        if self.robot not in ROBOTS:
            raise ValueError(f"robot must be one of {sorted(ROBOTS)}, got {self.robot!r}")
        if self.target not in TARGETS[self.robot]:
            raise ValueError(f"target must be one of {sorted(TARGETS[self.robot])} for robot "
                             f"{self.robot!r}, got {self.target!r}")

    def canonical(self) -> dict:
        """The parameters that identify the point (what :func:`point_id` hashes)."""
        return {"robot": self.robot, "target": self.target, "method": self.method,
                "accel_source": self.accel_source, "v0": [repr(x) for x in self.v0],
                "F_max": repr(self.F_max), "stop_time": repr(self.stop_time),
                "overrides": [[k, repr(x)] for k, x in self.overrides]}

    @property
    def id(self) -> str:
        return point_id(self)

    def fmi_overrides(self) -> Dict[str, float]:
        """The SSP runner overrides of this point (component-prefixed FMI names)."""
        body = TARGETS[self.robot][self.target]
        ov: Dict[str, float] = {"plant.target.m": body.mass}
        ov.update({f"plant.target.b[{i + 1}]": float(body.com[i]) for i in range(3)})
        ov.update({f"plant.target.{n}": float(body.inertia[k])
                   for k, n in enumerate(INERTIA_NAMES)})
        ov.update({f"plant.base.v0[{i + 1}]": self.v0[i] for i in range(3)})
        ov["plant.F_max"] = self.F_max
        ov["estimator.method"] = METHOD_CODES[self.method]
        ov["estimator.accel_source"] = ACCEL_CODES[self.accel_source]
        ov.update(dict(self.overrides))
        return ov

    def columns(self) -> Dict[str, object]:
        return {"sweep_id": self.id, "robot": self.robot, "target": self.target,
                "method": self.method, "accel_source": self.accel_source,
                "v0_x": self.v0[0], "v0_y": self.v0[1], "v0_z": self.v0[2],
                "v0_norm": math.sqrt(sum(x * x for x in self.v0)),
                "F_max": self.F_max, "stop_time": self.stop_time,
                "overrides": json.dumps(dict(self.overrides), sort_keys=True)}


def point_id(point: Point) -> str:
    """Stable 16-hex-digit hash of the point's parameters (sha256 of canonical JSON).

    Independent of the process, the Python hash seed and the order of overrides; ``v0 = [0, 10]``
    and ``[0, 10, 0]`` are the same point.
    """
    text = json.dumps(point.canonical(), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _as_list(x) -> list:
    if x is None:
        return []
    if isinstance(x, (list, tuple)):
        return list(x)
    return [x]


def make_points(robot="planar", target=None, method=("momentum", "force"),
                accel=("measured",), v0=None, F_max=None, stop_time=None,
                overrides: Optional[Mapping[str, float]] = None) -> List[Point]:
    """The Cartesian product of the given values, in a stable order, without duplicates.

    Every argument takes a single value or a list. ``None`` (target, v0, F_max, stop_time)
    means the robot's paper scenario value (:func:`spacerobot.robots.scenario`), e.g. planar:
    medium target, v0 = [1, 2] m/s, F_max = 10 N, 30 s. The momentum method does not use
    accelerations, so it is run once per grid point, with the first acceleration source.
    """
    robots = _as_list(robot)
    out: List[Point] = []
    seen = set()
    accels = _as_list(accel) or ["measured"]
    for rb in robots:
        sc = scenario(rb)
        v0s = list(v0) if v0 is not None else [sc.v0]
        if v0s and not isinstance(v0s[0], (list, tuple)):
            v0s = [v0s]
        targets = _as_list(target) or [DEFAULT_TARGET[rb]]
        fms = _as_list(F_max) or [sc.controller.F_max]
        sts = _as_list(stop_time) or [sc.stop_time]
        for tg, me, ac, v, fm, st in itertools.product(
                targets, _as_list(method), accels, v0s, fms, sts):
            if me == "momentum" and ac != accels[0]:
                continue
            p = Point(rb, tg, me, ac, tuple(v), fm, st, tuple((overrides or {}).items()))
            if p.id not in seen:
                seen.add(p.id)
                out.append(p)
    return out


# ------------------------------------------------------------------------------------------------
# one point (runs in a worker)
# ------------------------------------------------------------------------------------------------
def _resolve(spec: str):
    module, _, name = spec.partition(":")
    return getattr(importlib.import_module(module), name)


def _lookup(mapping, name: str, prefix: str):
    if mapping is None:
        return None
    for key in (name, f"{prefix}.{name}"):
        try:
            return float(mapping[key])
        except (KeyError, IndexError, TypeError, ValueError):
            continue
    return None


def expected_truth(point: Point) -> Dict[str, float]:
    """Truth of the point from the robot, the target and the point's overrides."""
    robot = ROBOTS[point.robot]
    truth = dict(zip(PARAMS, estimate_vector(robot.base,
                                             TARGETS[point.robot][point.target]).tolist()))
    for k, x in point.overrides:
        if k.startswith("plant.") and k[6:] in truth:
            truth[k[6:]] = float(x)
    return truth


def relative_errors(est: Mapping[str, float], truth: Mapping[str, float]) -> Dict[str, float]:
    """``|est - true| / scale`` per parameter (see the module docstring for ``scale``), for the
    parameters that have both an estimate and a truth."""
    scale = error_scale([truth.get(p, 0.0) for p in PARAMS])
    return {p: abs(est[p] - truth[p]) / s for p, s in zip(PARAMS, scale.tolist())
            if est.get(p) is not None and truth.get(p) is not None}


def run_point(point: Point, ssp_path: str, runner: str = DEFAULT_RUNNER) -> Dict[str, object]:
    """Run one point; never raises: a failure becomes a row with ``status = failed``."""
    row: Dict[str, object] = dict(point.columns())
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    t0 = time.perf_counter()
    try:
        run_ssp = _resolve(runner)
        res = run_ssp(str(ssp_path), stop_time=point.stop_time, overrides=point.fmi_overrides(),
                      progress=False)
        t = getattr(res, "time", None)
        t_end = float(t[-1]) if t is not None and len(t) else float("nan")
        row["t_end"] = t_end
        final = getattr(res, "final", None)
        est = {p: _lookup(final, p, "estimator") for p in PARAMS}
        missing = [p for p, x in est.items() if x is None]
        if missing:
            raise RuntimeError(f"run result has no final estimate of {', '.join(missing)}")
        truth = expected_truth(point)
        for p in PARAMS:
            x = _lookup(getattr(res, "truth", None), p, "plant")
            if x is not None:
                truth[p] = x
        data = getattr(res, "data", None) or {}
        for d in DIAG:
            x = _lookup(final, d, "estimator")
            if x is None and len(data.get(f"estimator.{d}", ())):
                x = float(data[f"estimator.{d}"][-1])
            row[d] = "" if x is None else (int(x) if float(x).is_integer() else x)
        rel = relative_errors(est, truth)
        for p in PARAMS:
            row[f"est.{p}"] = est[p]
            row[f"true.{p}"] = truth[p]
            row[f"relerr.{p}"] = rel[p]
        if not (t_end >= point.stop_time - 1e-6 * max(1.0, point.stop_time)):
            raise RuntimeError(f"co-simulation stopped at t = {t_end:g} s before the stop time "
                               f"{point.stop_time:g} s")
        row["status"], row["error"] = "ok", ""
    except Exception as e:  # noqa: BLE001 -- report every failure in the table
        row["status"] = "failed"
        msg = str(e).strip() or traceback.format_exc(limit=1).strip().splitlines()[-1]
        row["error"] = f"{type(e).__name__}: {msg}"
    row["wall_time"] = round(time.perf_counter() - t0, 3)
    return row


# ------------------------------------------------------------------------------------------------
# the table
# ------------------------------------------------------------------------------------------------
def read_table(csv_path) -> List[Dict[str, str]]:
    """Rows of a sweep table (complete lines only); ``[]`` if the file does not exist."""
    path = Path(csv_path)
    if not path.exists() or path.stat().st_size == 0:
        return []
    text = path.read_text()
    if not text.endswith("\n"):               # an interrupted write: drop the partial line
        text = text[: text.rfind("\n") + 1]
    reader = csv.DictReader(io.StringIO(text))
    return [r for r in reader if r.get("sweep_id") and None not in r.values()
            and None not in r]


def _check_header(path: Path) -> None:
    with path.open(newline="") as f:
        header = next(csv.reader(f), None)
    if header is not None and tuple(header) != COLUMNS:
        raise ValueError(f"{path} is not a sweep table of this version (its columns differ); "
                         f"choose another output file")


def _rewrite(path: Path, rows: List[Dict[str, str]]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


class _Table:
    """Append-only writer: one flushed (and fsynced) line per finished point."""

    def __init__(self, path: Path):
        self.path = path
        path.parent.mkdir(parents=True, exist_ok=True)
        new = not path.exists() or path.stat().st_size == 0
        if not new:
            data = path.read_bytes()
            if not data.endswith(b"\n"):      # drop a partial line left by an interruption
                with path.open("r+b") as f:
                    f.truncate(data.rfind(b"\n") + 1)
        self.f = path.open("a", newline="")
        self.w = csv.DictWriter(self.f, fieldnames=COLUMNS, extrasaction="ignore")
        if new:
            self.w.writeheader()
            self._flush()

    def _flush(self):
        self.f.flush()
        os.fsync(self.f.fileno())

    def write(self, row: Mapping[str, object]) -> None:
        self.w.writerow({k: ("" if row.get(k) is None else row.get(k)) for k in COLUMNS})
        self._flush()

    def close(self):
        self.f.close()


# ------------------------------------------------------------------------------------------------
# the sweep
# ------------------------------------------------------------------------------------------------
@dataclass
class SweepSummary:
    total: int = 0                 #: points in the grid
    skipped: int = 0               #: already in the table with status ok
    submitted: int = 0             #: run in this call
    ok: int = 0
    failed: int = 0
    failures: List[Tuple[str, str]] = field(default_factory=list)   #: (sweep_id, error)
    csv: str = ""

    def __str__(self) -> str:
        s = (f"{self.total} points: {self.skipped} already done, {self.submitted} run, "
             f"{self.ok} ok, {self.failed} failed -> {self.csv}")
        for pid, err in self.failures:
            s += f"\n  failed {pid}: {err}"
        return s


def _failed_row(point: Point, err: str) -> Dict[str, object]:
    row = dict(point.columns())
    row.update(status="failed", error=err)
    return row


def run_sweep(points: Sequence[Point], out_csv, *, workers: int = 2,
              scheduler: Optional[str] = None, client=None, build_dir=None,
              ssp: Optional[Mapping[str, str]] = None, progress: bool = True,
              runner: str = DEFAULT_RUNNER, builder: str = DEFAULT_BUILDER) -> SweepSummary:
    """Run every point not yet done and append its row to ``out_csv``.

    Parameters
    ----------
    points : the grid (see :func:`make_points`).
    out_csv : the results table; created, or resumed if it exists.
    workers : number of worker processes of the local cluster.
    scheduler : address of an existing Dask scheduler (then no local cluster is started).
    client : an existing ``distributed.Client`` (takes precedence over ``scheduler``).
    build_dir : where the .ssp of each robot is built (default: ``<out_csv>.build/``).
    ssp : ``{robot: path}`` of already built .ssp files (skips the build for those robots).
    progress : show a tqdm progress bar.
    runner, builder : ``"module:function"`` of the co-simulation runner and of the SSP build.

    Only one sweep at a time may write a table: a second one on the same ``out_csv`` raises
    :class:`SweepLocked` (an advisory lock on ``<out_csv>.lock``, held while the sweep runs).
    """
    out = Path(out_csv)
    out.parent.mkdir(parents=True, exist_ok=True)
    with _exclusive(out):
        return _run_sweep(points, out, workers=workers, scheduler=scheduler, client=client,
                          build_dir=build_dir, ssp=ssp, progress=progress, runner=runner,
                          builder=builder)


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


def _run_sweep(points, out: Path, *, workers, scheduler, client, build_dir, ssp, progress,
               runner, builder) -> SweepSummary:
    summary = SweepSummary(csv=str(out))
    uniq: Dict[str, Point] = {}
    for p in points:
        uniq.setdefault(p.id, p)
    summary.total = len(uniq)
    if out.exists() and out.stat().st_size:
        _check_header(out)
    rows = read_table(out)
    done = {r["sweep_id"] for r in rows if r["status"] == "ok"}
    todo = [p for pid, p in uniq.items() if pid not in done]
    summary.skipped = summary.total - len(todo)
    if not todo:
        return summary
    todo_ids = {p.id for p in todo}
    if any(r["sweep_id"] in todo_ids for r in rows):      # failed before: drop the old rows
        _rewrite(out, [r for r in rows if r["sweep_id"] not in todo_ids])

    ssp_paths = dict(ssp or {})
    robots = sorted({p.robot for p in todo} - set(ssp_paths))
    if robots:
        build = _resolve(builder)
        bdir = Path(build_dir) if build_dir else out.with_name(out.name + ".build")
        for rb in robots:
            built = build(rb, bdir / rb)
            if isinstance(built, Mapping):       # build_system returns {'ssp': path, ...}
                built = built["ssp"]
            ssp_paths[rb] = str(Path(built).resolve())

    from distributed import Client, LocalCluster, as_completed

    cluster = own_client = None
    table = _Table(out)
    try:
        if client is None:
            if scheduler:
                client = own_client = Client(scheduler)
            else:
                cluster = LocalCluster(n_workers=int(workers), processes=True,
                                       threads_per_worker=1, dashboard_address=":0")
                client = own_client = Client(cluster)
        stamp = f"{time.time_ns():x}"
        futures = {}
        for p in todo:
            fut = client.submit(run_point, p, ssp_paths[p.robot], runner, pure=False,
                                key=f"sweep-{p.id}-{stamp}", retries=0)
            futures[fut] = p
        summary.submitted = len(futures)
        bar = None
        if progress:
            from tqdm.auto import tqdm
            bar = tqdm(total=len(futures), desc="sweep", unit="point")
        try:
            for fut in as_completed(list(futures)):
                p = futures[fut]
                try:
                    row = fut.result()
                except Exception as e:  # noqa: BLE001 -- worker died, task lost ...
                    row = _failed_row(p, f"{type(e).__name__}: {e}")
                table.write(row)
                if row["status"] == "ok":
                    summary.ok += 1
                else:
                    summary.failed += 1
                    summary.failures.append((p.id, str(row["error"])))
                if bar is not None:
                    bar.update(1)
                    bar.set_postfix(ok=summary.ok, failed=summary.failed)
                fut.release()
        finally:
            if bar is not None:
                bar.close()
            for fut in futures:
                if not fut.done():
                    fut.cancel()
    finally:
        table.close()
        if own_client is not None:
            own_client.close()
        if cluster is not None:
            cluster.close()
    return summary


# ------------------------------------------------------------------------------------------------
# plot (the paper's Figs. 6-9)
# ------------------------------------------------------------------------------------------------
#: the paper's numbers quoted in the text (momentum-based I_n error at 60 s, F_max = 0.1 N)
PAPER_MOMENTUM_IN = ((math.hypot(0.0, 10.0), 0.066), (math.hypot(200.0, 200.0), 7.2))

_GROUPS = (("m", "mass", ("m",)), ("b", "centre of mass", ("b[1]", "b[2]", "b[3]")),
           ("I", "inertia", INERTIA_NAMES))


def _f(x: str) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def plot_sweep(csv_path, out_png=None, *, paper: bool = True):
    """Relative error of each final estimate against |v0| (log y), as the paper's Figs. 6-9.

    Panels: rows base / target, columns mass / centre of mass / inertia. One colour per series
    (method, acceleration source of the force method, and any other point parameter that
    varies in the table), one line style per component. Only ``status == ok`` rows and the
    parameters the robot identifies are drawn. With ``paper`` the two momentum-based I_n
    errors the paper quotes are marked. Returns the PNG path.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    csv_path = Path(csv_path)
    out_png = Path(out_png) if out_png else csv_path.with_suffix(".png")
    latest: Dict[str, Dict[str, str]] = {}
    for r in read_table(csv_path):
        latest[r["sweep_id"]] = r
    rows = [r for r in latest.values() if r["status"] == "ok"]
    if not rows:
        raise ValueError(f"{csv_path} has no successful sweep points to plot")
    varying = [c for c in ("robot", "target", "F_max", "stop_time", "overrides")
               if len({r[c] for r in rows}) > 1]

    def _short(c, v):
        if c == "overrides":
            ov = json.loads(v or "{}")
            return ", ".join(f"{k.split('.', 1)[-1]}={x:g}" for k, x in sorted(ov.items())) \
                or "no overrides"
        if c in ("F_max", "stop_time"):
            return f"{c}={_f(v):g}"
        return f"{c}={v}"

    def series(r):
        lab = r["method"] + (f" ({r['accel_source']} acc.)" if r["method"] == "force" else "")
        extra = ", ".join(_short(c, r[c]) for c in varying)
        return lab + (f", {extra}" if extra else "")

    groups: Dict[str, List[Dict[str, str]]] = {}
    for r in rows:
        groups.setdefault(series(r), []).append(r)
    identified = set()
    for r in rows:
        identified.update(IDENTIFIED.get(r["robot"], PARAMS))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    styles = ("-", "--", ":", "-.", (0, (5, 1)), (0, (1, 3)))
    markers = "osD^v<>p"
    from matplotlib.lines import Line2D

    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5), sharex=True)
    for i, who in enumerate(("base", "target")):
        for j, (_, title, comps) in enumerate(_GROUPS):
            ax = axes[i, j]
            shown = [c for c in comps if f"{who}.{c}" in identified]
            for s, (lab, rs) in enumerate(sorted(groups.items())):
                rs = sorted(rs, key=lambda r: _f(r["v0_norm"]))
                x = np.array([_f(r["v0_norm"]) for r in rs])
                for k, comp in enumerate(shown):
                    y = 100.0 * np.array([_f(r[f"relerr.{who}.{comp}"]) for r in rs])
                    ax.plot(x, np.maximum(y, 1e-12), linestyle=styles[k % len(styles)],
                            marker=markers[s % len(markers)], color=colors[s % len(colors)],
                            ms=4)
            handles = [Line2D([], [], color="k", linestyle=styles[k % len(styles)], label=c)
                       for k, c in enumerate(shown)] if len(shown) > 1 else []
            if paper and who == "target" and title == "inertia":
                px, py = zip(*PAPER_MOMENTUM_IN)
                handles += ax.plot(px, py, "k*", ms=11, label="paper, momentum: I_n")
            if shown:
                ax.set_yscale("log")
            ax.set_title(f"{who}: {title}" + (f" ({shown[0]})" if len(shown) == 1 else ""))
            ax.grid(True, which="both", alpha=0.3)
            if i == 1:
                ax.set_xlabel("|v0| [m/s]")
            if j == 0:
                ax.set_ylabel("relative error [%]")
            if handles:
                ax.legend(handles=handles, fontsize=7, loc="best")
    series_handles = [Line2D([], [], color=colors[s % len(colors)], marker=markers[s % len(markers)],
                             label=lab) for s, lab in enumerate(sorted(groups))]
    ncol = min(len(series_handles), 3)
    fig.legend(handles=series_handles, loc="lower center", ncol=ncol, fontsize=8, frameon=False)
    info = {c: sorted({r[c] for r in rows}, key=str) for c in ("robot", "target", "F_max",
                                                                "stop_time")}
    fig.suptitle("Final relative error against initial base velocity ("
                 + "; ".join(f"{c} = {', '.join(v)}" for c, v in info.items()) + ")")
    nrow = -(-len(series_handles) // ncol)
    fig.tight_layout(rect=(0, 0.03 + 0.025 * nrow, 1, 1))
    out_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=120)
    plt.close(fig)
    return out_png


# ------------------------------------------------------------------------------------------------
# command line
# ------------------------------------------------------------------------------------------------
def parse_v0(text: str) -> List[Tuple[float, ...]]:
    """``"0,10;50,50;200,200"`` -> ``[(0, 10), (50, 50), (200, 200)]``."""
    out = []
    for part in text.split(";"):
        part = part.strip()
        if not part:
            continue
        try:
            v = tuple(float(x) for x in part.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(f"bad velocity {part!r} in {text!r}; expected "
                                             f"'vx,vy[,vz];vx,vy[,vz];...'") from None
        if len(v) not in (2, 3):
            raise argparse.ArgumentTypeError(f"velocity {part!r} must have 2 or 3 components")
        out.append(v)
    if not out:
        raise argparse.ArgumentTypeError("no velocity given")
    return out


def _csv_list(conv=str):
    def parse(text: str):
        try:
            return [conv(x.strip()) for x in text.split(",") if x.strip()]
        except ValueError as e:
            raise argparse.ArgumentTypeError(str(e)) from None
    return parse


#: config/CLI key -> default
DEFAULTS = {"robot": ["planar"], "target": None, "method": ["momentum", "force"],
            "accel": ["measured"], "v0": None, "F_max": None, "stop_time": None,
            "workers": 2, "scheduler": None, "out": None, "overrides": {}, "build_dir": None,
            "plot": None}


def load_config(path) -> dict:
    """Read a sweep TOML file (keys as :data:`DEFAULTS`; ``F-max``/``stop-time`` also accepted)."""
    import tomllib

    with open(path, "rb") as f:
        cfg = tomllib.load(f)
    cfg = cfg.get("sweep", cfg)
    out = {}
    for k, v in cfg.items():
        key = k.replace("-", "_")
        if key == "accel_source":
            key = "accel"
        if key not in DEFAULTS:
            raise ValueError(f"{path}: unknown key {k!r}; known keys: {', '.join(DEFAULTS)}")
        out[key] = v
    if "v0" in out:
        v0 = out["v0"]
        if isinstance(v0, str):
            out["v0"] = parse_v0(v0)
        elif v0 and not isinstance(v0[0], (list, tuple)):
            out["v0"] = [v0]
    return out


def register(subparsers) -> argparse.ArgumentParser:
    """Add the ``sweep`` subcommand to an argparse ``subparsers`` object."""
    p = subparsers.add_parser(
        "sweep", help="parameter study on a Dask cluster (local by default), resumable CSV",
        description="Run the co-simulation over a grid of points (Cartesian product of the "
                    "lists given here or in --config) on a Dask cluster, appending one row per "
                    "point to a CSV table. Re-running with the same --out skips finished points.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    add_arguments(p)
    p.set_defaults(func=cli_sweep)
    return p


def add_arguments(p: argparse.ArgumentParser) -> None:
    S = argparse.SUPPRESS
    p.add_argument("--config", metavar="FILE.toml", help="TOML file with any of the options "
                   "below; options given on the command line take precedence")
    p.add_argument("--robot", type=_csv_list(), default=S, help="robot(s): planar,spatial "
                   "(default planar)")
    p.add_argument("--target", type=_csv_list(), default=S,
                   help="target size(s): small,medium,large (default: the robot's default)")
    p.add_argument("--method", type=_csv_list(), default=S,
                   help="momentum,force (default both)")
    p.add_argument("--accel", type=_csv_list(), default=S,
                   help="acceleration source(s) of the force method: measured,differenced "
                        "(default measured)")
    p.add_argument("--v0", type=parse_v0, default=S,
                   help="initial base velocities 'vx,vy[,vz];...' [m/s] (default: the robot's scenario, planar '1,2')")
    p.add_argument("--F-max", dest="F_max", type=_csv_list(float), default=S,
                   help="thruster force bound(s) [N] (default: the scenario's, 10)")
    p.add_argument("--stop-time", dest="stop_time", type=_csv_list(float), default=S,
                   help="stop time(s) [s] (default: the scenario's, planar 30, spatial 60)")
    p.add_argument("--set", dest="overrides", action="append", default=S, metavar="NAME=VALUE",
                   help="extra FMI override for every point, e.g. plant.base.omega0[3]=0.2 "
                        "(repeatable)")
    p.add_argument("--workers", type=int, default=S, help="local cluster worker processes "
                   "(default 2)")
    p.add_argument("--scheduler", default=S, metavar="ADDRESS",
                   help="use an existing Dask scheduler (workers must see the build directory)")
    p.add_argument("--build-dir", dest="build_dir", default=S,
                   help="where the .ssp is built (default <out>.build/)")
    p.add_argument("--out", default=S, help="results CSV (appended; resumed if it exists)")
    p.add_argument("--plot", default=S, metavar="PNG", help="also plot the table to PNG")
    p.add_argument("--dry-run", action="store_true", help="list the points and their ids")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def _settings(args: argparse.Namespace) -> dict:
    cfg = dict(DEFAULTS)
    if getattr(args, "config", None):
        cfg.update(load_config(args.config))
    given = {k: v for k, v in vars(args).items() if k in DEFAULTS}
    if "overrides" in given:
        ov = {}
        for item in given["overrides"]:
            name, sep, val = item.partition("=")
            if not sep:
                raise SystemExit(f"--set expects NAME=VALUE, got {item!r}")
            ov[name.strip()] = float(val)
        given["overrides"] = {**(cfg.get("overrides") or {}), **ov}
    cfg.update(given)
    if not cfg.get("out"):
        raise SystemExit("spacerobot sweep: --out CSV (or 'out' in the config) is required")
    return cfg


def cli_sweep(args: argparse.Namespace) -> int:
    """The ``spacerobot sweep`` command; returns the exit status (1 if a point failed)."""
    cfg = _settings(args)
    try:
        points = make_points(cfg["robot"], cfg["target"], cfg["method"], cfg["accel"], cfg["v0"],
                             cfg["F_max"], cfg["stop_time"], cfg["overrides"])
    except ValueError as e:
        raise SystemExit(f"spacerobot sweep: {e}")
    if getattr(args, "dry_run", False):
        for p in points:
            print(p.id, json.dumps(p.canonical(), sort_keys=True))
        return 0
    try:
        summary = run_sweep(points, cfg["out"], workers=cfg["workers"],
                            scheduler=cfg["scheduler"], build_dir=cfg["build_dir"],
                            progress=not getattr(args, "no_progress", False))
    except SweepLocked as e:
        print(f"spacerobot sweep: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        done = sum(r["status"] == "ok" for r in read_table(cfg["out"]))
        print(f"spacerobot sweep: interrupted; {cfg['out']} holds {done} finished point(s); "
              f"run the same command again to resume", file=sys.stderr)
        return 130
    print(summary)
    if cfg.get("plot"):
        print("plot:", plot_sweep(cfg["out"], cfg["plot"]))
    return 1 if summary.failed else 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``python -m spacerobot.system.sweep ...`` (same options as ``spacerobot sweep``)."""
    parser = argparse.ArgumentParser(prog="spacerobot-sweep")
    add_arguments(parser)
    return cli_sweep(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
