"""Executing a sweep on Dask: skip finished points, build each robot's .ssp once, send it to
the workers, submit the rest to a local cluster or an existing scheduler, write each row as it
finishes.

The same machinery runs any study whose items are co-simulations of one robot's .ssp
(:class:`Study`): the parameter sweep, and the Monte Carlo study
(:mod:`spacerobot.system.montecarlo`). An item has ``id`` (stable hash), ``robot`` and
``columns()`` (its parameters as table columns, including the study's key column).

The workers need the installed package only: each .ssp travels to them as Dask data
(:mod:`.ship`), never as a path, so no file system is shared with the client.
"""
from __future__ import annotations

import contextlib
import hashlib
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Mapping, Optional, Sequence, Tuple

from ... import __version__
from .points import Point
from .run import DEFAULT_BUILDER, DEFAULT_RUNNER, _resolve, run_point
from .ship import ShippedSystem, run_shipped
from .table import COLUMNS, _check_header, _exclusive, _rewrite, _Table, read_table


@dataclass(frozen=True)
class Study:
    """What kind of table a run of :func:`run_sweep` writes, and how one item runs.

    name : str                   "sweep", "montecarlo" (messages, progress bar, Dask keys)
    columns : tuple of str       the table's columns
    key : str                    the column holding the item's id
    task : callable              ``task(item, ssp_path, runner) -> row`` (never raises; a
                                 failure is a row with ``status = failed``)
    """

    name: str = "sweep"
    columns: Tuple[str, ...] = COLUMNS
    key: str = "sweep_id"
    task: Callable = run_point


#: the parameter sweep
SWEEP = Study()

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
        for pid, err in sorted(self.failures):          # not in the order they finished
            s += f"\n  failed {pid}: {err}"
        return s


def _failed_row(point, err: str) -> Dict[str, object]:
    row = dict(point.columns())
    row.update(status="failed", error=err)
    return row


def run_sweep(points: Sequence[Point], out_csv, *, workers: int = 2,
              scheduler: Optional[str] = None, client=None, build_dir=None,
              ssp: Optional[Mapping[str, str]] = None, progress: bool = True,
              runner: str = DEFAULT_RUNNER, builder: str = DEFAULT_BUILDER,
              study: Study = SWEEP) -> SweepSummary:
    """Run every point not yet done and append its row to ``out_csv``.

    Parameters
    ----------
    points : the grid (see :func:`make_points`).
    out_csv : the results table; created, or resumed if it exists.
    workers : number of worker processes of the local cluster.
    scheduler : address of an existing Dask scheduler (then no local cluster is started).
    client : an existing ``distributed.Client`` (takes precedence over ``scheduler``).
    build_dir : where the .ssp of each robot is built on this machine (default:
        ``<out_csv>.build/``).
    ssp : ``{robot: path}`` of already built .ssp files on this machine (skips the build for
        those robots).
    progress : show a tqdm progress bar.
    runner, builder : ``"module:function"`` of the co-simulation runner and of the SSP build.
    study : the kind of items and table (default: the parameter sweep, :data:`SWEEP`).

    Each robot's .ssp is read here and sent to the workers as data (:mod:`.ship`): the
    workers need the installed package only, no file of this machine.

    Only one sweep at a time may write a table: a second one on the same ``out_csv`` raises
    :class:`SweepLocked` (an advisory lock on ``<out_csv>.lock``, held while the sweep runs).
    """
    out = Path(out_csv)
    out.parent.mkdir(parents=True, exist_ok=True)
    with _exclusive(out):
        return _run_sweep(points, out, workers=workers, scheduler=scheduler, client=client,
                          build_dir=build_dir, ssp=ssp, progress=progress, runner=runner,
                          builder=builder, study=study)


def _run_sweep(points, out: Path, *, workers, scheduler, client, build_dir, ssp, progress,
               runner, builder, study: Study) -> SweepSummary:
    summary = SweepSummary(csv=str(out))
    todo = _points_to_run(points, out, summary, study)
    if not todo:
        return summary
    systems = {robot: ShippedSystem.read(path)
               for robot, path in _build_systems(todo, out, ssp, build_dir, builder).items()}

    from distributed import as_completed

    table = _Table(out, study.columns)
    try:
        with dask_client(workers, scheduler, client) as client:
            sent = ship(client, systems.values())
            stamp = f"{time.time_ns():x}"
            futures = {client.submit(run_shipped, study.task, p, sent[systems[p.robot].key],
                                     runner, __version__, pure=False, retries=0,
                                     key=f"{study.name}-{p.id}-{stamp}"): p for p in todo}
            summary.submitted = len(futures)
            bar = None
            if progress:
                from tqdm.auto import tqdm
                bar = tqdm(total=len(futures), desc=study.name, unit="point")
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
    return summary


@contextlib.contextmanager
def dask_client(workers: int = 2, scheduler: Optional[str] = None, client=None):
    """A ``distributed.Client``: ``client`` itself if given, else one connected to the
    ``scheduler`` address, else to a local cluster of ``workers`` processes with one thread
    each (closed on exit; a given client stays open)."""
    from distributed import Client, LocalCluster

    if client is not None:
        yield client
        return
    if scheduler:
        with Client(scheduler) as own:
            yield own
        return
    with LocalCluster(n_workers=int(workers), processes=True, threads_per_worker=1,
                      dashboard_address=":0") as cluster, Client(cluster) as own:
        yield own


def ship(client, systems) -> Dict[str, object]:
    """``{system.key: future}``: each :class:`ShippedSystem` scattered to every worker of
    ``client`` (waits for a first worker: a cluster whose workers are still starting, e.g. in a
    batch queue)."""
    client.wait_for_workers(1)
    return client.scatter({s.key: s for s in systems}, broadcast=True)


def _points_to_run(points: Sequence[Point], out: Path, summary: SweepSummary,
                   study: Study = SWEEP) -> List[Point]:
    """The points of the grid not yet in the table with status ok (counted in ``summary``);
    the old rows of points that failed before are dropped, so the table keeps one row each."""
    uniq: Dict[str, Point] = {}
    for p in points:
        uniq.setdefault(p.id, p)
    summary.total = len(uniq)
    if out.exists() and out.stat().st_size:
        _check_header(out, study.columns, study.name)
    key = study.key
    rows = read_table(out, key)
    done = {r[key] for r in rows if r["status"] == "ok"}
    todo = [p for pid, p in uniq.items() if pid not in done]
    summary.skipped = summary.total - len(todo)
    todo_ids = {p.id for p in todo}
    if any(r[key] in todo_ids for r in rows):
        _rewrite(out, [r for r in rows if r[key] not in todo_ids], study.columns)
    return todo


def _folder_name(robot: str) -> str:
    """Build folder of a robot: the built-in name, or for a URDF robot key (a path) the
    URDF's robot name and a hash of the key (two files may name their robot alike)."""
    from ...robots import BUILTIN_ROBOTS, robot_label
    if robot in BUILTIN_ROBOTS:
        return robot
    return f"{robot_label(robot)}-{hashlib.sha256(robot.encode()).hexdigest()[:8]}"


def _build_systems(todo: Sequence[Point], out: Path, ssp: Optional[Mapping[str, str]],
                   build_dir, builder: str) -> Dict[str, str]:
    """``{robot: absolute .ssp path}`` for every robot of ``todo``: given in ``ssp``, or built
    with ``builder`` into ``build_dir`` (default ``<out>.build/``) before any point runs."""
    ssp_paths = dict(ssp or {})
    robots = sorted({p.robot for p in todo} - set(ssp_paths))
    if robots:
        build = _resolve(builder)
        bdir = Path(build_dir) if build_dir else out.with_name(out.name + ".build")
        for rb in robots:
            built = build(rb, bdir / _folder_name(rb))
            if isinstance(built, Mapping):       # build_system returns {'ssp': path, ...}
                built = built["ssp"]
            ssp_paths[rb] = str(Path(built).resolve())
    return ssp_paths

